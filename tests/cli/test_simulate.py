import json

import numpy as np
from typer.testing import CliRunner

from agvnav.cli import app
from agvnav.world.scenario import builtin_scenario

runner = CliRunner()


def _short(tmp_path, extra="duration_s: 4.0", old=None, new=None):
    text = builtin_scenario("guidance_test").read_text().replace("end_hold_s: 1.0", f"end_hold_s: 1.0\n{extra}", 1)
    if old is not None:
        assert old in text
        text = text.replace(old, new, 1)
    p = tmp_path / "s.yaml"
    p.write_text(text)
    return p


def test_simulate_writes_all_outputs(tmp_path):
    out = tmp_path / "out"
    res = runner.invoke(app, ["simulate", str(_short(tmp_path)), "--out", str(out), "--seed", "3"])
    # 4 s do not finish the 5 m path: the files are written, the run is reported failed (timeout), exit 3
    assert res.exit_code == 3, res.output
    assert "run FAILED: timeout" in res.output
    assert "max |lateral error| after transient" in res.output
    names = {p.name for p in out.iterdir()}
    assert {
        "metrics.json",
        "timeseries.csv",
        "reflections.csv",
        "map.png",
        "errors.png",
        "positioning_histogram.png",
    } <= names
    m = json.loads((out / "metrics.json").read_text())
    for key in (
        "max_abs_lateral_error_m",
        "rms_lateral_error_m",
        "max_abs_wheel_heading_error_rad",
        "settling_distance_m",
        "positioning_rms_m",
        "sim_time_s",
        "integrity",
    ):
        assert key in m
    assert "wall_time_s" not in m and "real_time_factor" not in m  # machine figures: timing.json
    assert set(json.loads((out / "timing.json").read_text())) == {"wall_time_s", "real_time_factor"}
    assert m["seed"] == 3 and m["sim_time_s"] == 4.0
    assert m["outcome"] == "failed" and m["reason"] == "timeout"
    header = (out / "timeseries.csv").read_text().splitlines()[0].split(",")
    data = np.loadtxt(out / "timeseries.csv", delimiter=",", skiprows=1)
    assert "eps_c" in header and "xi_r" in header and data.shape == (81, len(header))
    np.testing.assert_allclose(data[:, header.index("t")], np.arange(81) * 0.05, atol=1e-9)


def test_simulate_no_plots(tmp_path):
    out = tmp_path / "o"
    res = runner.invoke(app, ["simulate", str(_short(tmp_path, "duration_s: 1.0")), "--out", str(out), "--no-plots"])
    assert res.exit_code == 3, res.output  # 1 s: the run times out (reported failed)
    assert not list(out.glob("*.png"))


def _bad(tmp_path, old, new):
    res = runner.invoke(app, ["simulate", str(_short(tmp_path, "duration_s: 1.0", old, new)), "--out", str(tmp_path)])
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    return lines[0]


def test_bad_scenarios_one_line_exit_2(tmp_path):
    assert "truth.slip: unknown key" in _bad(tmp_path, "slip_std:", "slip:")
    assert "controller.poles_per_m" in _bad(tmp_path, "poles_per_m: [-3.0, -3.0]", "poles_per_m: [3.0, 3.0]")
    assert "gap in the path" in _bad(
        tmp_path, "{type: line, length_m: 3.0}", "{type: line, length_m: 3.0, start: [0, 0]}"
    )
    msg = _bad(tmp_path, "map: lab", "map: {reflectors: [{id: A, x: 6, y: 1}], walls: []}")
    assert "reflector(s) in view" in msg
    assert "invalid YAML" in _bad(tmp_path, "map: lab", "map: [lab")
    res = runner.invoke(app, ["simulate", str(tmp_path / "missing.yaml")])
    assert res.exit_code == 2 and "no such scenario file" in res.output


def test_shipped_scenario_by_name_is_found(tmp_path):
    # only validates and starts the named scenario: --seed on a shipped name
    res = runner.invoke(app, ["simulate", "nonexistent_name", "--out", str(tmp_path)])
    assert res.exit_code == 2 and "guidance_test" in res.output


def test_simulate_gives_the_garbage_collector_back(tmp_path, monkeypatch):
    """Start-up runs without cyclic collection (issue 11); afterwards the caller's collector is as it was."""
    import gc

    from agvnav.world import scenario as scenario_module

    seen = []
    build = scenario_module.load_scenario

    def spy(*args, **kwargs):
        seen.append(gc.isenabled())  # while the scenario loads: collection is off
        return build(*args, **kwargs)

    monkeypatch.setattr(scenario_module, "load_scenario", spy)
    assert gc.isenabled()
    res = runner.invoke(app, ["simulate", str(_short(tmp_path)), "--out", str(tmp_path / "o"), "--no-plots"])
    assert res.exit_code == 3, res.output
    assert seen == [False]
    assert gc.isenabled() and gc.get_freeze_count() == 0
    res = runner.invoke(app, ["simulate", str(tmp_path / "missing.yaml"), "--out", str(tmp_path / "p")])
    assert res.exit_code == 2 and gc.isenabled() and gc.get_freeze_count() == 0  # also after a user error


def test_jit_forces_the_kernel_mode_and_the_run_records_it(tmp_path, monkeypatch, restore_jit_mode):
    """``--jit on|off`` forces the mode over ``AGVNAV_JIT``; metrics.json and the JSON metadata name it."""
    monkeypatch.setenv("AGVNAV_JIT", "1")
    scenario = str(_short(tmp_path, "duration_s: 1.0"))
    for flag, mode in (("off", "interpreted"), ("on", "compiled")):
        out = tmp_path / flag
        res = runner.invoke(app, ["simulate", scenario, "--out", str(out), "--no-plots", "--json", "--jit", flag])
        assert res.exit_code == 3, res.output  # 1 s: the run times out (reported failed)
        assert json.loads((out / "metrics.json").read_text())["kernels"] == mode
        doc = json.loads(res.stdout[res.stdout.index("{"):])
        assert doc["metadata"]["kernels"] == mode
    res = runner.invoke(app, ["simulate", scenario, "--out", str(tmp_path / "x"), "--jit", "maybe"])
    assert res.exit_code == 2 and "--jit maybe: expected on, off or auto" in res.output
