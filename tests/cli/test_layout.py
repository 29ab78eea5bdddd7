"""``agvnav layout``: files written (a map that ``agvnav simulate`` loads), JSON, --verify, bad input exit 2."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from agvnav.cli import app
from agvnav.sim.build import build_world
from agvnav.world import load_map
from agvnav.world.scenario import parse_scenario

runner = CliRunner()

SMALL = """\
name: small
seed: 3
hall:
  outer: [[0, 0], [20, 0], [20, 12], [0, 12], [0, 0]]
  occluders:
    - {id: rack, kind: rack, points: [[5, 5], [15, 5], [15, 7], [5, 7], [5, 5]]}
routes:
  - name: south
    path: {start: [2, 2.5, 0], segments: [{type: line, length_m: 16}]}
goniometer: {max_range_m: 15, reflector_radius_m: 0.04}
candidates:
  sites: [{face: outer, spacing_m: 1.0}, {face: rack, spacing_m: 1.0}]
target: {route_spacing_m: 1.0}
verify: {max_length_m: 8, section_m: 4, speed_m_s: 1.0}
"""


def _spec(tmp_path: Path, text: str = SMALL) -> Path:
    p = tmp_path / "small.yaml"
    p.write_text(text, encoding="utf-8")
    return p


def test_layout_writes_map_heatmap_and_plan_and_verifies(tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = runner.invoke(app, ["layout", str(_spec(tmp_path)), "--out", str(out), "--verify"], env={"COLUMNS": "220"})
    assert res.exit_code == 0, res.output
    assert "planned" in res.output and "baseline" in res.output and "Wolsey" in res.output
    assert "measured rms (" in res.output and "0-4 m" in res.output
    world = load_map(out / "map.yaml")
    plan = json.loads((out / "plan.json").read_text())
    assert len(world.reflectors) == plan["table"][0]["reflectors"] >= 3
    assert (out / "heatmap.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the map loads in a scenario as `agvnav simulate` reads it
    path = "path: {start: [2, 2.5, 0], segments: [{type: line, length_m: 5}]}"
    sc = parse_scenario(f"map: {out / 'map.yaml'}\n{path}\n")
    assert build_world(sc).reflector_ids == world.reflector_ids


def test_layout_json(tmp_path: Path) -> None:
    res = runner.invoke(app, ["layout", str(_spec(tmp_path)), "--out", str(tmp_path / "o"), "--json"])
    assert res.exit_code == 0, res.output
    rec = json.loads(res.output)
    assert rec["table"][0]["layout"] == "planned" and rec["files"]["map"].endswith("map.yaml")
    assert rec["verify"] == [] and rec["table"][0]["meeting_target_pct"] >= 99.0
    assert {"agvnav", "seed", "quick", "python", "numpy", "cpu"} <= set(rec["metadata"])


def test_bad_polygon_is_one_line_exit_2(tmp_path: Path) -> None:
    bad = SMALL.replace("[0, 12], [0, 0]]", "[0, 12]]")
    res = runner.invoke(app, ["layout", str(_spec(tmp_path, bad)), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "small.yaml:4: hall.outer: the polygon does not close" in lines[0]


def test_unreachable_target_exit_2(tmp_path: Path) -> None:
    bad = SMALL.replace("max_range_m: 15", "max_range_m: 1.5")
    res = runner.invoke(app, ["layout", str(_spec(tmp_path, bad)), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    assert "target cannot be met" in res.output and "out of range" in res.output


def test_layout_never_writes_into_a_users_folder_and_replaces_its_own_only_with_force(tmp_path: Path) -> None:
    """issue 29: `layout --out site` replaced the user's site/map.yaml (exit 0); now refused, nothing touched."""
    site = tmp_path / "site"
    site.mkdir()
    (site / "map.yaml").write_text("reflectors: []  # the user's own survey\n", encoding="utf-8")
    res = runner.invoke(app, ["layout", str(_spec(tmp_path)), "--out", str(site), "--force"])
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "not an agvnav layout" in lines[0] and "choose another folder" in lines[0]
    assert (site / "map.yaml").read_text(encoding="utf-8") == "reflectors: []  # the user's own survey\n"
    assert [p.name for p in site.iterdir()] == ["map.yaml"]
    out = tmp_path / "out"  # a layout's own folder: refused without --force, replaced whole with it
    assert runner.invoke(app, ["layout", str(_spec(tmp_path)), "--out", str(out)]).exit_code == 0
    (out / "stale.txt").write_text("from an older layout", encoding="utf-8")
    res = runner.invoke(app, ["layout", str(_spec(tmp_path)), "--out", str(out)])
    assert res.exit_code == 2 and "another layout's results; use --force" in res.output
    assert (out / "stale.txt").exists()
    res = runner.invoke(app, ["layout", str(_spec(tmp_path)), "--out", str(out), "--force"])
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in out.iterdir()) == ["heatmap.png", "map.yaml", "plan.json"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "site", "small.yaml"]  # no temporary folder left
