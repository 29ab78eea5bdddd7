"""``agvnav bench safety``: the cases place the person where they say, rows summarise honestly, one run stops."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from agvnav.bench import safety
from agvnav.sim import simulate
from agvnav.sim.build import build
from agvnav.world.obstacles import ObstacleSpec, obstacle_from_spec
from agvnav.world.scenario import parse_scenario


def test_design_distance_is_the_cruise_stopping_distance():
    assert safety.design_distance() == pytest.approx(1.0 * 0.3 + 1.0 / (2 * 0.5) + 0.3)


@pytest.mark.parametrize("model", ["differential", "tricycle"])
@pytest.mark.parametrize("case", [c for c in safety.person_cases(False) if c[1] == 1.0])
def test_the_person_reaches_the_field_edge_at_the_stated_gap(model, case):
    m = safety._models()[model]
    doc = safety.scenario_doc(m, case, 0)
    sc = parse_scenario(yaml.safe_dump(doc, sort_keys=False), "case.yaml")
    build(sc)
    person = obstacle_from_spec(ObstacleSpec(**doc["obstacles"][0]))
    _, ratio, angle, speed = case
    t_enter = person.start + safety.WALK_IN_M / speed
    x, y = person.centre_at(t_enter)
    lateral = m.half_width + safety.LATERAL_MARGIN_M + safety.PERSON_RADIUS_M
    assert y == pytest.approx(safety.PATH_Y_M - lateral)
    # the tracked point's nominal position then, and the gap from the body's front to the person
    x0 = doc["path"]["start"][0]
    ramp = 1.0 / (2 * 0.5)
    s = ramp + (t_enter - 2.0) * 1.0
    front = x0 + s + (m.front - m.point_offset)
    assert x - safety.PERSON_RADIUS_M - front == pytest.approx(ratio * safety.design_distance(), abs=1e-9)
    assert math.degrees(math.atan2(*(person.waypoints[1] - person.waypoints[0])[::-1])) == pytest.approx(angle)


def test_stop_distance_adds_the_approach_of_a_person_walking_towards_the_vehicle():
    D = safety.design_distance()
    assert safety.case_stop_distance(90.0, 1.6) == pytest.approx(D)
    assert safety.case_stop_distance(45.0, 1.2) == pytest.approx(D)  # walking away: no credit taken
    # 135 deg at 1.2 m/s closes 0.849 m/s during the 0.3 s reaction and the 2 s of braking
    assert safety.case_stop_distance(135.0, 1.2) == pytest.approx(D + 1.2 * math.sqrt(0.5) * 2.3)


def test_summary_counts_and_zones():
    runs = [
        {"outcome": "completed", "collision": False, "min_clearance_m": 0.4, "result": "stop", "stops": 1,
         "t_end": 20.0, "completed": True, "corridor_dev_m": math.nan},
        {"outcome": "collision", "collision": True, "min_clearance_m": 0.0, "result": "collision", "stops": 1,
         "t_end": 9.0, "completed": False, "corridor_dev_m": math.nan},
    ]
    row = safety.summarise("differential", "person", "inside", 0.8, runs, baseline=18.0)
    assert row["runs"] == 2 and row["collisions"] == 1 and row["min_clearance_m"] == 0.0
    assert row["stops"] == 1.0 and row["avoided"] == 0 and row["time_lost_s"] == pytest.approx(2.0)
    assert row["max_corridor_dev_m"] is None
    assert row["outcomes"] == "collision 1, completed 1"
    beyond = dict(row, zone="beyond", collisions=0, appear_m=1.6)
    closing = safety.summary_rows([row, beyond])
    assert [r["case"].split(" D")[0] for r in closing] == [
        "ALL at/beyond their stopping distance", "ALL inside their stopping distance", "ALL appearing at/beyond"]
    assert [r["collisions"] for r in closing] == [0, 1, 0] and [r["runs"] for r in closing] == [2, 2, 2]


def test_one_crossing_at_the_stopping_distance_stops_without_collision():
    """A bench case, dead-reckoning to stay fast (the reaction does not depend on positioning)."""
    case = next(c for c in safety.person_cases(True) if c[1] == 1.0)
    doc = safety.scenario_doc(safety._models()["differential"], case, 0)
    doc.pop("goniometer")
    doc["positioning"] = {"method": "dead_reckoning"}
    doc["scanner"]["step_deg"] = 1.0
    r = simulate(parse_scenario(yaml.safe_dump(doc, sort_keys=False), "case.yaml"))
    assert r.outcome == "completed", r.reason
    person = r.reactive["obstacles"]["person"]
    assert person["result"] == "stop" and r.reactive["stops"] >= 1
    assert person["min_clearance_m"] > 0.1


@pytest.mark.slow
def test_quick_bench_has_no_collision_beyond_the_design_distance():
    rows = safety.run(quick=True, seed=0)
    beyond = next(r for r in rows if r["case"].startswith("ALL at/beyond"))
    assert beyond["collisions"] == 0 and beyond["runs"] > 0
    lanes = [r for r in rows if r["case"].startswith("lane")]
    assert all(r["avoided"] == r["runs"] and r["max_corridor_dev_m"] == 0.0 for r in lanes)
    assert np.all([r["collisions"] == 0 for r in lanes])
