"""Issue 18 follow-up: `agvnav simulate safety_...` shows the reactive figures; --json carries them."""

import json

import pytest
from typer.testing import CliRunner

from agvnav.cli import app
from agvnav.cli.simulate import RUN_FAILED_EXIT
from agvnav.world.scenario import builtin_scenario

runner = CliRunner()


@pytest.fixture(scope="module")
def crossing_yaml(tmp_path_factory):
    """safety_person_crossing cut to 12.5 s: the stop (10.9-12.35 s) is over; the run then times out."""
    text = builtin_scenario("safety_person_crossing").read_text()
    text = text.replace("step_s: 0.05", "step_s: 0.05\nduration_s: 12.5", 1)
    p = tmp_path_factory.mktemp("sc") / "crossing.yaml"
    p.write_text(text)
    return p


def test_summary_table_shows_stops_time_stopped_clearance_and_encounter(crossing_yaml, tmp_path):
    out = tmp_path / "out"
    res = runner.invoke(app, ["simulate", str(crossing_yaml), "--out", str(out), "--no-plots"],
                        env={"COLUMNS": "200"})
    assert res.exit_code == RUN_FAILED_EXIT, res.output  # cut short: timeout after the encounter
    lines = res.output.splitlines()

    def value(label):
        row = [ln for ln in lines if label in ln]
        assert row, (label, res.output)
        return row[0].split(label, 1)[1].strip(" │|").split()[0]

    metrics = json.loads((out / "metrics.json").read_text())["reactive"]
    assert value("emergency stops") == "1" == str(metrics["stops"])
    assert float(value("time stopped (s)")) == pytest.approx(metrics["time_stopped_s"]) == pytest.approx(1.5)
    clearance = metrics["obstacles"]["person"]["min_clearance_m"]
    assert clearance > 1.0  # so shown in m (display_unit: mm only below 1 m)
    assert float(value("min clearance to person (m)")) == pytest.approx(clearance, abs=5e-4)
    assert value("encounter with person") == "stop"
    assert "corridor" not in res.output  # no corridor in this scenario: no excursion row


def test_json_output_includes_the_reactive_section(crossing_yaml, tmp_path):
    res = runner.invoke(app, ["simulate", str(crossing_yaml), "--out", str(tmp_path / "o"), "--no-plots", "--json"])
    assert res.exit_code == RUN_FAILED_EXIT
    doc = json.loads(res.stdout)
    rx = doc["metrics"]["reactive"]
    assert rx["stops"] == 1 and rx["obstacles"]["person"]["result"] == "stop"
    assert rx == json.loads((tmp_path / "o" / "metrics.json").read_text())["reactive"]


def test_summary_of_a_run_without_reactive_control_has_no_reactive_rows(tmp_path):
    text = builtin_scenario("guidance_test").read_text().replace("end_hold_s: 1.0", "end_hold_s: 1.0\nduration_s: 2.0")
    p = tmp_path / "short.yaml"
    p.write_text(text)
    res = runner.invoke(app, ["simulate", str(p), "--out", str(tmp_path / "o"), "--no-plots"], env={"COLUMNS": "200"})
    assert "outcome" in res.output
    assert "stops" not in res.output and "encounter" not in res.output
