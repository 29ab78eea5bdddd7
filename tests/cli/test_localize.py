"""agvnav simulate --log/--report, agvnav localize on the log, agvnav report: the command line round trip."""

import json

import numpy as np
from typer.testing import CliRunner

from agvnav.cli import app
from agvnav.world.scenario import builtin_scenario

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
