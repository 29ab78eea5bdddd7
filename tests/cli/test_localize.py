"""agvnav simulate --log/--report, agvnav localize on the log, agvnav report: the command line round trip.

And localize as honest as simulate (issue 29): the tracking time and reflections used in the table, a
localization that mostly failed exits 3, a log it cannot trust is refused with one line (exit 2).
"""

import json
import re
import shutil

import numpy as np
import pytest
from typer.testing import CliRunner

from agvnav.cli import app
from agvnav.cli.simulate import RUN_FAILED_EXIT
from agvnav.logs import positioning_settings
from agvnav.sim import simulate
from agvnav.world.scenario import builtin_scenario, load_scenario

runner = CliRunner()


def _scenario(tmp_path):
    text = builtin_scenario("guidance_test").read_text()
    text = text.replace("end_hold_s: 1.0", "end_hold_s: 1.0\nduration_s: 4.0", 1)
    p = tmp_path / "s.yaml"
    p.write_text(text)
    return p


def _columns(path):
    header = path.read_text().splitlines()[0].split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {name: data[:, i] for i, name in enumerate(header)}


def test_simulate_log_then_localize_reproduces_the_estimate_and_report_writes_html(tmp_path):
    run, log, loc = tmp_path / "run", tmp_path / "run.mcap", tmp_path / "loc"
    args = ["simulate", str(_scenario(tmp_path)), "--out", str(run), "--log", str(log), "--report", "--no-plots"]
    res = runner.invoke(app, args)
    assert res.exit_code == 3, res.output  # 4 s: timeout, files written
    assert log.is_file() and (run / "report.html").is_file() and (run / "layout.json").is_file()
    assert "messages on 14 topics" in res.output
    res = runner.invoke(app, ["localize", str(log), "--out", str(loc)])
    assert res.exit_code == 0, res.output
    names = {p.name for p in loc.iterdir()}
    assert names == {"timeseries.csv", "timeseries.units.csv", "estimate.mcap", "metrics.json", "layout.json",
                     "map.png", "estimator_status.png", "positioning_errors.png", "positioning_histogram.png"}
    sim, est = _columns(run / "timeseries.csv"), _columns(loc / "timeseries.csv")
    for c in ("est_x", "est_y", "est_psi"):  # timeseries.csv holds 10 significant digits
        np.testing.assert_allclose(est[c], sim[c], rtol=2e-9, atol=1e-9)
    np.testing.assert_array_equal(est["est_status"], sim["est_status"])
    summary = json.loads((loc / "metrics.json").read_text())
    assert summary["method"] == "ekf" and summary["accepted"] > 0 and summary["positioning_rms_m"] < 0.05
    res = runner.invoke(app, ["localize", str(log), "--out", str(loc), "--method", "naive"])
    assert res.exit_code == 2 and "--force" in res.output  # the folder holds a result
    again = ["localize", str(log), "--out", str(loc), "--method", "naive", "--force", "--no-plots"]
    res = runner.invoke(app, again)
    assert res.exit_code == 0, res.output
    assert json.loads((loc / "metrics.json").read_text())["method"] == "naive"
    res = runner.invoke(app, ["report", str(loc), "--out", str(tmp_path / "r.html")])  # a localization reports too
    assert res.exit_code == 0, res.output
    assert (tmp_path / "r.html").read_text().startswith("<!DOCTYPE html>")


def test_localize_and_report_refuse_bad_input_with_one_line(tmp_path):
    (tmp_path / "odometry.csv").write_text("t,delta_d,delta_theta\n0,0,0\n0.1,0.01,0\n")
    (tmp_path / "reflections.csv").write_text("t,bearing\n0.05,1.0\n")
    res = runner.invoke(app, ["localize", str(tmp_path), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "names no map" in res.output
    res = runner.invoke(app, ["localize", str(tmp_path / "nope.bag"), "--map", "lab"])
    assert res.exit_code == 2 and "an .mcap file or a folder" in res.output
    res = runner.invoke(app, ["report", str(tmp_path)])
    assert res.exit_code == 2 and "not a run folder" in res.output
    res = runner.invoke(app, ["simulate", "guidance_test", "--out", str(tmp_path / "x"), "--log", "run.bag"])
    assert res.exit_code == 2 and "must end in .mcap" in res.output


@pytest.fixture(scope="module")
def csv_log(tmp_path_factory):
    """A 6 s guidance test written as a CSV log folder (docs/logs.md), and its settings document."""
    result = simulate(load_scenario("guidance_test").model_copy(update={"duration_s": 6.0}))
    folder = tmp_path_factory.mktemp("csvlog") / "log"
    folder.mkdir()
    s, refl = result.series, result.events["reflections"]
    kw = {"delimiter": ",", "comments": "", "fmt": "%.17g"}
    np.savetxt(folder / "odometry.csv", np.column_stack([s["t"], s["odo_dd"], s["odo_dtheta"]]),
               header="t,delta_d,delta_theta", **kw)
    np.savetxt(folder / "reflections.csv", np.column_stack([refl["t"], refl["bearing"]]), header="t,bearing", **kw)
    np.savetxt(folder / "truth.csv", np.column_stack([s["t"], s["x"], s["y"], s["psi"]]), header="t,x,y,psi", **kw)
    settings = positioning_settings(result.scenario, s)
    (folder / "settings.json").write_text(json.dumps(settings, indent=2))
    return folder, settings


def _copy(folder, dest, settings=None):
    shutil.copytree(folder, dest)
    if settings is not None:
        (dest / "settings.json").write_text(json.dumps(settings, indent=2))
    return dest


def test_localize_prints_the_tracking_time_and_reflections_used(csv_log, tmp_path):
    folder, _ = csv_log
    res = runner.invoke(app, ["localize", str(folder), "--out", str(tmp_path / "loc"), "--no-plots"])
    assert res.exit_code == 0, res.output
    assert re.search(r"tracking \(% of the duration\)\s*│\s*100\.0 │", res.output)
    assert re.search(r"reflections used \(%\)\s*│\s*9\d\.\d │", res.output)
    doc = json.loads((tmp_path / "loc" / "metrics.json").read_text())
    assert doc["outcome"] == "completed" and doc["tracking_share"] == 1.0 and doc["reflections_used_share"] > 0.9


def test_a_localization_that_mostly_failed_writes_its_files_then_exits_3(csv_log, tmp_path):
    """Without its start pose the EKF never starts tracking: run FAILED, no accuracy figure in the table."""
    folder, settings = csv_log
    settings = {k: v for k, v in settings.items() if k not in ("initial_pose", "initial_covariance")}
    log = _copy(folder, tmp_path / "log", settings)
    res = runner.invoke(app, ["localize", str(log), "--out", str(tmp_path / "loc"), "--no-plots"])
    assert res.exit_code == RUN_FAILED_EXIT, res.output
    assert res.output.strip().splitlines()[-1].startswith("run FAILED: tracked 0 % of the log")
    assert re.search(r"positioning rms \(mm\)\s*│\s*- │", res.output)
    doc = json.loads((tmp_path / "loc" / "metrics.json").read_text())
    assert doc["outcome"] == "failed" and doc["tracking_share"] < 0.5 and doc["reason"] in res.output


def _misspelt(settings):
    return {("initial_pos" if k == "initial_pose" else k): v for k, v in settings.items()}


def _degrees(path):
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    np.savetxt(path, np.column_stack([data[:, 0], np.degrees(data[:, 1])]), delimiter=",", header="t,bearing",
               comments="")


@pytest.mark.parametrize(("case", "message"), [
    ("settings_key", r"settings\.json:\d+: initial_pos: unknown key"),
    ("column", r"reflections\.csv:1: unknown column 'bearing_deg'"),
    ("degrees", r"reflections\.csv:\d+: bearing \S+ is beyond 2π in magnitude: bearings are radians"),
    ("empty", r"reflections\.csv: no reflections"),
    ("mount_yaw", r"settings\.json:\d+: mount\[2\]: 90.0 is beyond 2π in magnitude"),
])
def test_a_log_it_cannot_trust_is_refused_with_one_line(csv_log, tmp_path, case, message):
    folder, settings = csv_log
    log = _copy(folder, tmp_path / "log", _misspelt(settings) if case == "settings_key" else None)
    refl = log / "reflections.csv"
    if case == "column":
        refl.write_text(refl.read_text().replace("t,bearing", "t,bearing_deg", 1))
    elif case == "degrees":
        _degrees(refl)
    elif case == "empty":
        refl.write_text("t,bearing\n")
    elif case == "mount_yaw":
        (log / "settings.json").write_text(json.dumps({**settings, "mount": [0.3, 0.0, 90.0]}, indent=2))
    res = runner.invoke(app, ["localize", str(log), "--out", str(tmp_path / "loc"), "--no-plots"])
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and re.search(message, lines[0]), res.output
    assert not (tmp_path / "loc").exists()


def test_the_summary_table_shows_every_time_in_one_unit():
    """issue 29: a failed localization printed 'tracking (ms) 650.0' under 'duration (s) 26.10'."""
    from agvnav.cli.localize import _summary_table

    _, _, rows = _summary_table({"method": "ekf", "outcome": "failed", "duration_s": 26.1, "tracking_s": 0.65,
                                 "tracking_off_truth_s": 0.0}, "log")
    table = {r[0]: r[1] for r in rows}
    assert table["duration (s)"] == "26.10" and table["tracking (s)"] == "0.6500"
    assert "tracking off truth (s)" in table and not any("(ms)" in r[0] for r in rows)
