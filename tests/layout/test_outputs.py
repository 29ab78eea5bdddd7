"""plan.json names the target and says why each failing route point fails; the written map loads as a world."""

from __future__ import annotations

import json
from pathlib import Path

from agvnav.layout import parse_layout, plan_layout
from agvnav.report.layout import plan_record
from agvnav.world import load_map, save_map


def test_plan_record_says_why_points_miss_the_target(small_text: str) -> None:
    text = small_text.replace("position_3sigma_m: 0.01", "position_3sigma_m: 0.002").replace(
        "fraction: 0.99", "fraction: 0.8")
    plan = plan_layout(parse_layout(text))
    rec = plan_record(plan)
    assert rec["target"]["position_3sigma_m"] == 0.002
    missing = rec["points_missing_target"]
    assert len(missing) == int((~plan.prediction.ok).sum()) > 0
    for p in missing:
        assert p["why"], p
        if "position_3sigma_m" in p["why"]:
            assert p["sigma_pos_m"] is None or 3 * p["sigma_pos_m"] > 0.002
        else:
            assert 3 * p["sigma_pos_m"] <= 0.002 + 1e-12


def test_written_map_is_the_plan(small_text: str, tmp_path: Path) -> None:
    plan = plan_layout(parse_layout(small_text))
    save_map(plan.world, tmp_path / "map.yaml")  # what write_layout writes (the heat map is the CLI test's)
    world = load_map(tmp_path / "map.yaml")
    assert world.reflector_ids == plan.world.reflector_ids
    rec = json.loads(json.dumps(plan_record(plan)))
    assert [r["id"] for r in rec["reflectors"]] == list(world.reflector_ids)
    assert rec["table"][0]["reflectors"] == len(world.reflectors)
