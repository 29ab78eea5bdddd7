"""Issue 18 follow-up: the reactive figures reach metrics.json and the CSV units sidecar."""

import csv
import dataclasses
import json
import math

import pytest

from agvnav.navigation.reactive import REACTIVE_SIGNALS
from agvnav.report.files import metrics_document, reactive_document, save_result
from agvnav.report.reference import COLUMNS
from agvnav.sim import simulate
from agvnav.world.scenario import builtin_scenario, parse_scenario


def _short(name: str, duration_s: float):
    """A shipped scenario cut to ``duration_s`` of simulated time (the encounter of the person
    crossing is over by 12.4 s: stop at 10.9 s, released at 12.35 s)."""
    text = builtin_scenario(name).read_text().replace("step_s: 0.05", f"step_s: 0.05\nduration_s: {duration_s}", 1)
    return parse_scenario(text, f"{name}_short.yaml")


@pytest.fixture(scope="module")
def crossing():
    return simulate(_short("safety_person_crossing", 12.5))


def test_metrics_json_carries_the_reactive_section_of_the_run(crossing, tmp_path):
    save_result(crossing, tmp_path / "out", plots=False)
    doc = json.loads((tmp_path / "out" / "metrics.json").read_text())
    rx = doc["reactive"]
    fig = crossing.reactive
    # known answer: one emergency stop for the person (protective field 1.6 m at 1 m/s),
    # held 1.5 s (30 steps of 0.05 s: the person's passage plus resume_after_s = 1 s)
    assert rx["stops"] == fig["stops"] == 1
    assert rx["time_stopped_s"] == pytest.approx(fig["time_stopped_s"]) == pytest.approx(1.5)
    assert rx["detours"] == fig["detours"] == 0
    assert rx["max_corridor_excess_m"] is None and math.isnan(fig["max_corridor_excess_m"])  # no corridor
    person = rx["obstacles"]["person"]
    assert person["result"] == fig["obstacles"]["person"]["result"] == "stop"
    assert person["min_clearance_m"] == pytest.approx(fig["obstacles"]["person"]["min_clearance_m"], abs=0.0)
    assert 1.0 < person["min_clearance_m"] < 1.6  # stopped within the protective field, never touched
    assert "NaN" not in (tmp_path / "out" / "metrics.json").read_text()  # strict JSON
    assert "wall_time_s" not in json.dumps(rx)  # deterministic: no timing in it


def test_reactive_section_is_deterministic(crossing):
    again = simulate(_short("safety_person_crossing", 12.5))
    assert reactive_document(again) == reactive_document(crossing)


def test_a_run_without_reactive_control_has_no_reactive_section(crossing):
    text = builtin_scenario("guidance_test").read_text().replace("end_hold_s: 1.0", "end_hold_s: 1.0\nduration_s: 2.0")
    plain = simulate(parse_scenario(text, "short.yaml"))
    assert plain.reactive == {}
    assert reactive_document(plain) is None
    assert "reactive" not in metrics_document(plain)
    # the rest of a reactive run's document is what it was before the section came
    bare = metrics_document(dataclasses.replace(crossing, reactive={}))
    full = metrics_document(crossing)
    assert list(full) == [*bare, "reactive"]
    assert {k: v for k, v in full.items() if k != "reactive"} == bare


def test_reactive_columns_are_documented_in_the_units_sidecar(crossing, tmp_path):
    for name in REACTIVE_SIGNALS:
        assert name in COLUMNS, name
    save_result(crossing, tmp_path / "out", plots=False)
    with open(tmp_path / "out" / "timeseries.units.csv", newline="") as fh:
        rows = {r["column"]: r for r in csv.DictReader(fh)}
    assert rows["clearance__person"]["unit"] == "m"
    assert "per obstacle" in rows["clearance__person"]["meaning"]
    assert rows["reaction_level"]["unit"] == "-"
    assert rows["field_v_max"]["unit"] == "m/s"
    assert not [n for n, r in rows.items() if r["meaning"] == "not documented"]
