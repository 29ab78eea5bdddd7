"""agvnav map: a CSV drive folder in, a map YAML with covariances and a plot out; no anchor -> exit 2."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from typer.testing import CliRunner

from agvnav.cli import app
from agvnav.sensors.goniometer import leading_edge_bearing
from agvnav.world import Reflector, WorldMap, load_map, save_map

runner = CliRunner()
REFL = np.array([[0.0, 0.0], [10.0, -1.0], [11.0, 8.0], [4.0, 10.0], [-2.0, 6.0]])


def _drive(folder: Path) -> None:
    """A noise-free loop (0.3 m/s) as the documented CSV layout: odometry.csv, reflections.csv, settings.json."""
    steps, dt = 240, 0.1
    dd = np.full(steps, 0.03)
    dth = np.full(steps, 0.0075)
    x, y, th = [1.0], [2.0], [0.1]
    for k in range(steps):  # midpoint rule, the layout's integration
        m = th[-1] + 0.5 * dth[k]
        x.append(x[-1] + dd[k] * np.cos(m))
        y.append(y[-1] + dd[k] * np.sin(m))
        th.append(th[-1] + dth[k])
    folder.mkdir()
    t = np.arange(steps + 1) * dt
    odo = np.column_stack([t, np.r_[0.0, dd], np.r_[0.0, dth]])
    np.savetxt(folder / "odometry.csv", odo, delimiter=",", header="t,delta_d,delta_theta", comments="")
    rows = []
    for k in range(3, steps + 1, 3):
        b = np.ravel(leading_edge_bearing(np.array([x[k], y[k], th[k]]), REFL, np.full(len(REFL), 0.04))[0])
        rows += [(t[k], v) for v in b]
    np.savetxt(folder / "reflections.csv", np.array(rows), delimiter=",", header="t,bearing", comments="")
    (folder / "settings.json").write_text(json.dumps({"initial_pose": [1.0, 2.0, 0.1], "pulses_per_rev": 65535,
                                                      "odometry_noise": [1e-6, 1e-6, 1e-6]}))


def test_map_writes_a_loadable_map_with_covariances_and_a_plot(tmp_path: Path) -> None:
    _drive(tmp_path / "drive")
    survey = tmp_path / "survey.yaml"
    save_map(WorldMap((Reflector("A", 0.0, 0.0, 0.04, 0.001), Reflector("C", 11.0, 8.0, 0.04, 0.001))), survey)
    out, png = tmp_path / "map.yaml", tmp_path / "map.png"
    res = runner.invoke(app, ["map", str(tmp_path / "drive"), "--anchor", f"surveyed:{survey}", "--out", str(out),
                              "--plot", str(png), "--json"])
    assert res.exit_code == 0, res.output
    summary = json.loads(res.output.strip().splitlines()[-1])
    assert summary["anchor"] == "surveyed2" and summary["reflectors"] == len(REFL)
    world = load_map(out)
    assert {"A", "C"} <= set(world.reflector_ids)
    d = np.hypot(*(world.reflector_xy[:, None, :] - REFL[None]).transpose(2, 0, 1)).min(axis=1)
    assert d.max() < 1e-3
    assert all(r.covariance_m2 is not None and r.survey_std_m > 0.0 for r in world.reflectors)
    for r in world.reflectors:  # the frame-free std (mapping.output): at most the marginal per-axis std
        assert r.covariance_m2 is not None
        assert 0.0 < r.survey_std_m <= np.sqrt(0.5 * (r.covariance_m2[0][0] + r.covariance_m2[1][1])) * (1 + 1e-9)
    assert png.is_file() and png.stat().st_size > 1000


def test_map_without_an_anchor_refuses_scale_unobservable(tmp_path: Path) -> None:
    _drive(tmp_path / "drive")
    res = runner.invoke(app, ["map", str(tmp_path / "drive"), "--out", str(tmp_path / "m.yaml")])
    assert res.exit_code == 2
    assert "scale unobservable" in res.output and "(--anchor)" in res.output  # names the option that fixes it
    assert not (tmp_path / "m.yaml").exists()


def _other_site(xy: np.ndarray, scale: float = 1.03, rotation: float = 0.3, shift: tuple[float, float] = (5.0, -3.0)
                ) -> np.ndarray:
    """``xy`` (m) moved by a similarity: another site's survey of the same layout (shift, rotation, 3 % scale)."""
    c, s = np.cos(rotation), np.sin(rotation)
    return scale * xy @ np.array([[c, -s], [s, c]]).T + np.asarray(shift)


def _survey(path: Path, ids: str, xy: np.ndarray) -> Path:
    save_map(WorldMap(tuple(Reflector(i, float(p[0]), float(p[1]), 0.04, 0.001) for i, p in zip(ids, xy,
                                                                                             strict=True))), path)
    return path


def test_map_refuses_anchors_from_another_site_and_accepts_this_sites(tmp_path: Path) -> None:
    """issue 29: another site's survey (shifted, rotated, 3 % larger) gave a scaled map, exit 0; now exit 2,
    one line naming the anchor, nothing written. This site's survey of the same reflectors is accepted."""
    _drive(tmp_path / "drive")
    for n, ids in ((2, "AC"), (3, "ACD")):
        rows, out = [0, 2, 3][:n], tmp_path / f"m{n}.yaml"
        other = _survey(tmp_path / f"other{n}.yaml", ids, _other_site(REFL[rows]))
        res = runner.invoke(app, ["map", str(tmp_path / "drive"), "--anchor", f"surveyed:{other}", "--out", str(out)])
        assert res.exit_code == 2, res.output
        lines = [ln for ln in res.output.splitlines() if ln.strip()]
        assert len(lines) == 1 and f"--anchor surveyed:{other}" in lines[0] and "odometry scale of 1.0" in lines[0]
        assert "+3.0 %" in lines[0] and "Traceback" not in res.output and not out.exists()
        good = _survey(tmp_path / f"good{n}.yaml", ids, REFL[rows])
        res = runner.invoke(app, ["map", str(tmp_path / "drive"), "--anchor", f"surveyed:{good}", "--out", str(out)])
        assert res.exit_code == 0, res.output
        assert "odometry scale 1.000" in res.output and len(load_map(out).reflectors) == len(REFL)
    # a 1.5 % scale is within wheel odometry's 2 %; --max-scale-error tightens the limit
    near = _survey(tmp_path / "near.yaml", "AC", _other_site(REFL[[0, 2]], scale=1.015))
    args = ["map", str(tmp_path / "drive"), "--anchor", f"surveyed:{near}", "--out", str(tmp_path / "m.yaml")]
    assert runner.invoke(app, [*args, "--force"]).exit_code == 0
    res = runner.invoke(app, [*args, "--force", "--max-scale-error", "1"])
    assert res.exit_code == 2 and "+1.5 %" in res.output and "beyond the 1 %" in res.output


def test_map_refuses_a_surveyed_reflector_the_drive_contradicts(tmp_path: Path) -> None:
    """Three surveyed reflectors, one 2 cm off its true position: refused, naming the anchor and the reflector."""
    _drive(tmp_path / "drive")
    xy = REFL[[0, 2, 3]].copy()
    xy[1, 0] += 0.02
    bad = _survey(tmp_path / "bad.yaml", "ACD", xy)
    res = runner.invoke(app, ["map", str(tmp_path / "drive"), "--anchor", f"surveyed:{bad}", "--out",
                              str(tmp_path / "m.yaml")])
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and f"--anchor surveyed:{bad}: surveyed reflector C is" in lines[0] and "sigma" in lines[0]
    assert not (tmp_path / "m.yaml").exists()


def test_map_refuses_an_existing_file_unless_force_and_writes_atomically(tmp_path: Path) -> None:
    """issue 29: `map --out FILE` overwrote an existing file (exit 0). Now: someone else's file and a map agvnav
    wrote are both refused without --force (exit 2, before the work), each message saying which; --force replaces."""
    _drive(tmp_path / "drive")
    survey = _survey(tmp_path / "survey.yaml", "AC", REFL[[0, 2]])
    out, png = tmp_path / "site.yaml", tmp_path / "map.png"
    out.write_text("reflectors: []  # hand-made\n", encoding="utf-8")
    args = ["map", str(tmp_path / "drive"), "--anchor", f"surveyed:{survey}", "--out", str(out)]
    res = runner.invoke(app, args)
    assert res.exit_code == 2 and "not a map agvnav wrote" in res.output and "--force" in res.output
    assert out.read_text(encoding="utf-8") == "reflectors: []  # hand-made\n"
    # the surveyed file itself is the default --out's classic victim: refused too
    res = runner.invoke(app, ["map", str(tmp_path / "drive"), "--anchor", f"surveyed:{survey}", "--out", str(survey)])
    assert res.exit_code == 2 and "not a map agvnav wrote" in res.output and len(load_map(survey).reflectors) == 2
    assert runner.invoke(app, [*args, "--force", "--plot", str(png)]).exit_code == 0
    assert out.read_text(encoding="utf-8").startswith("# agvnav map:") and png.is_file()
    res = runner.invoke(app, [*args, "--plot", str(tmp_path / "other.png")])
    assert res.exit_code == 2 and "holds a map agvnav wrote earlier; use --force" in res.output
    res = runner.invoke(app, [*args, "--force", "--plot", str(png)])  # both replaced
    assert res.exit_code == 0, res.output
    out.unlink()
    res = runner.invoke(app, [*args, "--plot", str(png)])
    assert res.exit_code == 2 and f"--plot {png}: the file exists" in res.output and not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["drive", "map.png", "survey.yaml"]  # no temporary left


def test_map_names_a_missing_output_folder_before_the_work(tmp_path: Path) -> None:
    """issue 29: `map --out nodir/x.yaml` mapped the whole drive, then failed with a bare Errno naming the
    temporary file. Now: one line naming the option and the folder, exit 2, nothing written; --plot alike."""
    _drive(tmp_path / "drive")
    survey = _survey(tmp_path / "survey.yaml", "AC", REFL[[0, 2]])
    args = ["map", str(tmp_path / "drive"), "--anchor", f"surveyed:{survey}"]
    res = runner.invoke(app, [*args, "--out", str(tmp_path / "nodir" / "x.yaml")])
    assert res.exit_code == 2 and "the folder" in res.output and "does not exist" in res.output
    assert "partial" not in res.output and "Errno" not in res.output
    res = runner.invoke(app, [*args, "--out", str(tmp_path / "x.yaml"), "--plot", str(tmp_path / "nodir" / "m.png")])
    assert res.exit_code == 2 and "--plot" in res.output and "does not exist" in res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["drive", "survey.yaml"]
