"""Issue 6: tracked scenarios through the loader, sim.simulate and `agvnav simulate` (incl. bad input)."""

import json

import pytest
from typer.testing import CliRunner

from agvnav.cli import app
from agvnav.sim import simulate
from agvnav.sim.laps import prepare_tracked, simulate_tracked
from agvnav.world.scenario import ScenarioError, builtin_scenario, builtin_scenario_names, load_scenario

runner = CliRunner()
SHIPPED = ["tracked_square_3p5_concrete", "tracked_square_3p5_grass", "tracked_square_4_concrete",
           "tracked_square_4_grass"]


def _short(tmp_path, old=None, new=None, laps=1):
    text = builtin_scenario("tracked_square_3p5_concrete").read_text().replace("laps: 10", f"laps: {laps}", 1)
    if old is not None:
        assert old in text
        text = text.replace(old, new, 1)
    p = tmp_path / "t.yaml"
    p.write_text(text)
    return p


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_tracked_scenarios_load(name):
    assert name in builtin_scenario_names()
    sc = load_scenario(name)
    assert sc.vehicle.model == "tracked" and sc.route is not None
    assert sc.controller.laps == 10 and sc.controller.compare_landmarks
    assert sc.route.side_m in (3.5, 4.0) and sc.controller.params == {}
    parts = prepare_tracked(sc)  # cross-part checks pass
    assert parts.world.wall_segments.shape == (8, 2, 2)


def test_simulate_tracked_one_lap_both_modes(tmp_path):
    sc = load_scenario(_short(tmp_path))
    res = simulate_tracked(sc)
    assert set(res.runs) == {True, False}
    rows = res.lap_rows()
    assert len(rows) == 1
    assert rows[0]["with_landmarks_per_lap_m"] < 0.1 < rows[0]["without_landmarks_per_lap_m"]


def test_cli_prints_the_per_lap_table_and_writes_outputs(tmp_path):
    out = tmp_path / "out"
    res = runner.invoke(app, ["simulate", str(_short(tmp_path)), "--out", str(out), "--seed", "2"])
    assert res.exit_code == 0, res.output
    assert "error per lap" in res.output and "with landmarks" in res.output and "mean" in res.output
    names = {p.name for p in out.iterdir()}
    assert {"laps.json", "laps.csv", "laps.png", "timeseries_with_landmarks.csv",
            "timeseries_without_landmarks.csv"} <= names
    summary = json.loads((out / "laps.json").read_text())
    assert summary["seed"] == 2 and len(summary["laps"]) == 1
    trans = summary["modes"]["with_landmarks"]["transitions"]
    assert [t[2] for t in trans].count("E3") == 4 and trans[-1][2] == "E4"


BAD = [
    ("  spacing_m: 0.30          # distance between the side pair (dist of eqs 6-7), assumption",
     "  spacing_m: 0.30\n  sensors: [{name: front, mount: [0.1, 0.0, 0.0]}]", "inside the vehicle body"),
    ("    - {id: leg0, points: [[0.500, -0.500], [3.000, -0.500]]}",
     "    - {id: leg0, points: [[0.500, -0.500], [0.500, -0.500]]}", "zero length"),
    ("  start: [0.0, 0.0, 0.0]", "  start: [10.0, 10.0, 0.0]", "never passes a landmark"),
    ("    truth: concrete", "    truth: mud", "truth"),
    ("  laps: 1", "  laps: 1\n  spin: true", "unknown key"),
]


@pytest.mark.parametrize("old, new, message", BAD)
def test_bad_input_one_line_message_and_exit_code(tmp_path, old, new, message):
    p = _short(tmp_path, old, new)
    with pytest.raises(ScenarioError, match=message):
        sc = load_scenario(p)
        prepare_tracked(sc)
    res = runner.invoke(app, ["simulate", str(p), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    err = res.stderr if hasattr(res, "stderr") else res.output
    lines = [ln for ln in err.strip().splitlines() if ln]
    assert len(lines) == 1 and lines[0].startswith("error:") and "t.yaml" in lines[0], err


KANAYAMA = """
name: tracked_kanayama
step_s: 0.05
vehicle:
  model: tracked
  terrain: {truth: concrete, odometry: concrete}
ultrasonic: {}
traction: {speed_m_s: 0.15}
map: {walls: []}
path:
  start: [1.0, 2.0, 90.0]
  segments:
    - {type: line, length_m: 1.5}
    - {type: arc, radius_m: 0.8, sweep_deg: -90.0}
    - {type: line, length_m: 1.0}
controller: {name: kanayama, params: {convergence_distance: 0.5}}
"""


def test_kanayama_follows_a_line_arc_path_on_the_tracked_plant(tmp_path):
    p = tmp_path / "k.yaml"
    p.write_text(KANAYAMA)
    res = simulate(load_scenario(p))
    assert res.completed and res.scenario.positioning.method is None  # rangers only: the wall-landmark localizer
    lateral = abs(res.series["lateral_error"])
    assert lateral.max() < 0.05  # track lag at the arc
    assert abs(res.series["distance"][-1] - (2.5 + 0.8 * 3.14159 / 2)) < 0.1
    res2 = runner.invoke(app, ["simulate", str(p), "--out", str(tmp_path / "o"), "--no-plots"])
    assert res2.exit_code == 0 and "tracked" in res2.output


def test_kanayama_needs_a_path(tmp_path):
    p = tmp_path / "k.yaml"
    p.write_text(KANAYAMA.split("path:")[0] + "controller: {name: kanayama}\n")
    with pytest.raises(ScenarioError, match="give a path"):
        load_scenario(p)


def test_an_unknown_hybrid_parameter_is_a_scenario_error_naming_the_key(tmp_path):
    path = _short(tmp_path, "  name: hybrid\n", "  name: hybrid\n  params: {cruise_speed: 0.1, foo: 1}\n")
    with pytest.raises(ScenarioError, match=r"controller\.params: the hybrid controller takes no parameter 'foo'"):
        prepare_tracked(load_scenario(path))
    res = runner.invoke(app, ["simulate", str(path), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "takes: cruise_speed, correction_rate" in res.output
    turn = _short(tmp_path, "  name: hybrid\n", "  name: hybrid\n  params: {turn_rate_deg_s: 12}\n")
    assert prepare_tracked(load_scenario(turn)).params.turn_rate == pytest.approx(0.20943951)
