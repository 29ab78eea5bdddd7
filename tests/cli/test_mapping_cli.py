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
    assert "scale unobservable" in res.output
    assert not (tmp_path / "m.yaml").exists()
