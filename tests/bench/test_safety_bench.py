"""``agvnav bench safety``: cases place the person where they say, zones follow the design rule before any
run, rows summarise honestly, and the 135° crossing the stopping-distance fields missed now stops."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from agvnav.bench import safety
from agvnav.sim import simulate
from agvnav.world.obstacles import ObstacleSpec, obstacle_from_spec
from agvnav.world.scenario import parse_scenario


def test_design_figures():
    assert safety.design_distance() == pytest.approx(1.0 * 0.3 + 1.0 / (2 * 0.5) + 0.3)
    assert safety.design_reach() == pytest.approx(1.6 * (0.3 + 1.0 / 0.5))  # ISO 13855 K T = 3.68 m


def _nominal_base(doc, t, m):
    """base_link's x at ``t`` on the nominal profile (ramp at 0.5 m/s^2 to 1 m/s, then cruise)."""
    s = 0.25 * t * t if t <= 2.0 else 1.0 + (t - 2.0)
    return doc["path"]["start"][0] + s - m.point_offset


@pytest.mark.parametrize("model", ["differential", "tricycle"])
@pytest.mark.parametrize("case", [c for c in safety.person_cases(False) if c[1] == 1.0])
def test_the_person_appears_at_the_stated_distance_on_a_collision_course(model, case):
    m = safety._models()[model]
    doc = safety.scenario_doc(m, case, 0)
    person = obstacle_from_spec(ObstacleSpec(**doc["obstacles"][0]))
    _, ratio, angle, speed = case
    t_a = person.start
    assert not person.present(t_a - 0.01) and person.present(t_a)
    # at appearance: the person's edge is ratio x K T from the swept strip of the vehicle (independent geometry)
    x, y = person.centre_at(t_a)
    rel = np.array([x - _nominal_base(doc, t_a, m), y - safety.PATH_Y_M])
    h_x = (m.front, m.front + safety.design_distance())
    h_y = m.half_width + safety.LATERAL_MARGIN_M
    dx = max(h_x[0] - rel[0], 0.0, rel[0] - h_x[1])
    dy = max(abs(rel[1]) - h_y, 0.0)
    assert math.hypot(dx, dy) - safety.PERSON_RADIUS_M == pytest.approx(ratio * safety.design_reach(), abs=1e-6)
    # collision course: on the centre line when the nominal front reaches its edge
    t_c = t_a + (safety.PATH_Y_M - y) / (speed * math.sin(math.radians(angle)))
    xc, yc = person.centre_at(t_c)
    assert (xc, yc) == pytest.approx((safety.CROSSING_X_M, safety.PATH_Y_M), abs=1e-9)
    assert _nominal_base(doc, t_c, m) + m.front == pytest.approx(xc - safety.PERSON_RADIUS_M, abs=1e-9)
    assert math.degrees(math.atan2(*(person.waypoints[1] - person.waypoints[0])[::-1])) == pytest.approx(angle)


def test_zones_follow_the_design_rule_from_the_geometry():
    """beyond iff dist(person, H) - r >= K T: ratio 1.0 and 1.5 beyond, 0.5 inside, whatever the angle."""
    m = safety._models()["differential"]
    for _, ratio, angle, speed in safety.person_cases(False):
        lead = safety.appear_lead(m, angle, speed, ratio)
        assert safety.zone_of(m, angle, speed, lead) == ("beyond" if ratio >= 1.0 else "inside")
    # square across at 1.6 m/s, 2.0 s before the crossing: the person 3.2 m beside the path and r + 2 m ahead
    # of the front; its distance to the strip [front, front + D] x [-(w + 0.1), w + 0.1] by hand
    lead = 2.0
    rel = safety._relative(m, 90.0, 1.6, lead)
    assert rel == pytest.approx([m.front + safety.PERSON_RADIUS_M + 2.0, -3.2], abs=1e-12)
    dx = rel[0] - (m.front + safety.design_distance())
    dy = 3.2 - (m.half_width + safety.LATERAL_MARGIN_M)
    expected = math.hypot(dx, dy) - safety.PERSON_RADIUS_M
    assert safety.appear_distance(m, 90.0, 1.6, lead) == pytest.approx(expected, abs=1e-12)
    assert safety.zone_of(m, 90.0, 1.6, lead) == ("beyond" if expected >= safety.design_reach() else "inside")


def test_summary_counts_and_zones():
    runs = [
        {"outcome": "completed", "collision": False, "min_clearance_m": 0.4, "result": "stop", "stops": 1,
         "t_end": 20.0, "completed": True, "corridor_dev_m": math.nan},
        {"outcome": "collision", "collision": True, "min_clearance_m": 0.0, "result": "collision", "stops": 1,
         "t_end": 9.0, "completed": False, "corridor_dev_m": math.nan},
    ]
    baselines = [{"t_end": 18.0, "completed": True}, {"t_end": 17.0, "completed": True}]
    row = safety.summarise("differential", "person", "inside", 0.8, runs, baselines, reach=3.68)
    assert row["runs"] == 2 and row["collisions"] == 1 and row["min_clearance_m"] == 0.0
    assert row["stops"] == 1.0 and row["avoided"] == 0 and row["time_lost_s"] == pytest.approx(2.0)
    with pytest.raises(ValueError, match="one baseline per run"):
        safety.summarise("differential", "person", "inside", 0.8, runs, baselines[:1], reach=3.68)
    assert row["max_corridor_dev_m"] is None and row["reach_m"] == 3.68
    assert row["outcomes"] == "collision 1, completed 1"
    beyond = dict(row, zone="beyond", collisions=0, appear_m=3.7)
    closing = safety.summary_rows([row, beyond])
    assert [r["case"] for r in closing] == ["ALL at/beyond the designed distance", "ALL inside the designed distance"]
    assert [r["collisions"] for r in closing] == [0, 1] and [r["runs"] for r in closing] == [2, 2]
    # a crossing that ended in a detour (avoidance allowed there) counts in its summary row
    swerved = safety.summary_rows([row, dict(beyond, avoided=2), dict(beyond, avoided=1)])
    assert [r["avoided"] for r in swerved] == [3, 0] and swerved[0]["runs"] == 4


@pytest.mark.parametrize("model", ["differential", "tricycle"])
def test_the_true_appearance_distance_from_the_pose(model):
    """On the nominal pose it is the case's ratio x K T; a vehicle 0.2 m ahead of the nominal is closer (below
    K T at 1.0 K T); the distance does not depend on how the map is turned."""
    m = safety._models()[model]
    case = next(c for c in safety.person_cases(False) if c[1] == 1.0 and c[2] == 90.0)
    doc = safety.scenario_doc(m, case, 0)
    person = doc["obstacles"][0]
    t_a, p = person["start_s"], tuple(person["path"][0])
    nominal = (_nominal_base(doc, t_a, m), safety.PATH_Y_M, 0.0)
    kt = safety.design_reach()
    assert safety.appear_distance_at(m, p, nominal) == pytest.approx(kt, abs=1e-6)
    ahead = safety.appear_distance_at(m, p, (nominal[0] + 0.2, nominal[1], 0.0))
    # square across: the person is beside the strip's far end plus K T; 0.2 m more along x brings it closer
    rel = np.array([p[0] - nominal[0] - 0.2, p[1] - nominal[1]])
    dx = max(rel[0] - (m.front + safety.design_distance()), 0.0)
    dy = abs(rel[1]) - (m.half_width + safety.LATERAL_MARGIN_M)
    assert ahead == pytest.approx(math.hypot(dx, dy) - safety.PERSON_RADIUS_M, abs=1e-9) and ahead < kt
    # the same relative placement with the map turned by 90 degrees
    turned = safety.appear_distance_at(m, (-rel[1], rel[0]), (0.0, 0.0, math.pi / 2))
    assert turned == pytest.approx(ahead, abs=1e-9)


def test_rows_report_the_true_appearance_distance_and_the_runs_below_the_design():
    run = {"outcome": "completed", "collision": False, "min_clearance_m": 0.4, "result": "stop", "stops": 1,
           "t_end": 20.0, "completed": True, "corridor_dev_m": math.nan}
    runs = [dict(run, appear_dist_m=3.70), dict(run, appear_dist_m=3.675), dict(run, appear_dist_m=3.68)]
    base = [{"t_end": 18.0, "completed": True}] * 3
    row = safety.summarise("differential", "person", "beyond", 3.68, runs, base, reach=3.68)
    assert row["appear_dist_min_m"] == pytest.approx(3.675) and row["runs_below_design"] == 1
    lane = safety.summarise("differential", "lane", "-", None, [dict(run, appear_dist_m=math.nan)], base[:1])
    assert lane["appear_dist_min_m"] is None and lane["runs_below_design"] is None
    closing = safety.summary_rows([row, dict(row, appear_dist_min_m=3.9, runs_below_design=2), lane])
    assert closing[0]["appear_dist_min_m"] == pytest.approx(3.675) and closing[0]["runs_below_design"] == 3
    assert closing[1]["appear_dist_min_m"] is None and closing[1]["runs_below_design"] == 0


def _fake_run(model_name, case, seed, obstacle=True):
    """A stand-in for one run: completion at 100 + 10 seed s, 5 s later with the obstacle."""
    return {"outcome": "completed", "collision": False, "min_clearance_m": 0.5, "result": "stop", "stops": 1,
            "t_end": 100.0 + 10.0 * seed + (5.0 if obstacle else 0.0), "completed": True,
            "corridor_dev_m": math.nan, "appear_dist_m": 4.0 if obstacle and case is not None else math.nan}


def test_time_lost_compares_each_run_with_the_same_seed_without_the_obstacle(monkeypatch):
    """Every seed gets its own baseline: the time lost is 5 s in every row, whatever the seeds' own times."""
    monkeypatch.setattr(safety, "run_one", _fake_run)
    monkeypatch.setattr(safety.os, "cpu_count", lambda: 1)  # in-process, so the stand-in is used
    rows = safety.run(quick=True, seed=3)
    cases = [r for r in rows if r["model"] != "all"]
    assert len(cases) == 2 * (len(safety.person_cases(True)) + 1) and all(r["runs"] == 2 for r in cases)
    assert [r["time_lost_s"] for r in rows] == pytest.approx([5.0] * len(rows))


def _case_135(approach: float):
    """The bench's 135° (slanting towards the vehicle) crossing at 1.0 K T, dead-reckoning, coarser scan."""
    case = next(c for c in safety.person_cases(False) if c[1] == 1.0 and c[2] == 135.0)
    doc = safety.scenario_doc(safety._models()["differential"], case, 0)
    doc.pop("goniometer")
    doc["positioning"] = {"method": "dead_reckoning"}
    doc["scanner"]["step_deg"] = 1.0
    doc["reactive"]["approach_speed_m_s"] = approach
    doc["duration_s"] = 16.0
    return simulate(parse_scenario(yaml.safe_dump(doc, sort_keys=False), "case.yaml"))


def test_the_135_degree_crossing_stops_in_time_with_the_approach_fields():
    r = _case_135(1.6)
    person = r.reactive["obstacles"]["person"]
    assert r.reason != "collision" and person["result"] == "stop"
    assert person["min_clearance_m"] > 0.3


def test_the_135_degree_crossing_is_hit_with_the_stopping_distance_fields():
    """The same case with the fields of the previous design (K = 0): the person gets into the strip too late."""
    r = _case_135(0.0)
    assert r.reason == "collision" and r.reactive["obstacles"]["person"]["result"] == "collision"


@pytest.mark.slow
def test_quick_bench_has_no_collision_beyond_the_design_distance():
    rows = safety.run(quick=True, seed=0)
    beyond = next(r for r in rows if r["case"].startswith("ALL at/beyond"))
    assert beyond["collisions"] == 0 and beyond["runs"] > 0
    lanes = [r for r in rows if r["case"].startswith("lane")]
    assert all(r["avoided"] == r["runs"] and r["max_corridor_dev_m"] == 0.0 for r in lanes)
    assert np.all([r["collisions"] == 0 for r in lanes])


def test_one_shipped_open_floor_map_for_the_bench_and_the_scenarios():
    """``hall_open`` is the hall without the pillar, the rack and the pillar's reflectors; the bench and the two
    safety scenarios on the open floor name it instead of carrying copies."""
    from agvnav.world import builtin_map_names, load_builtin_map
    from agvnav.world.scenario import builtin_scenario

    assert "hall_open" in builtin_map_names()
    hall, open_floor = load_builtin_map("hall"), load_builtin_map("hall_open")
    assert [r.to_dict() for r in open_floor.reflectors] == [
        r.to_dict() for r in hall.reflectors if not r.id.startswith("P")]
    assert [w.to_dict() for w in open_floor.walls] == [w.to_dict() for w in hall.walls if w.id == "outer"]
    assert safety.scenario_doc(safety._models()["differential"], None, 0)["map"] == "hall_open"
    for name in ("safety_lane_obstacle", "safety_person_stepping_out"):
        assert yaml.safe_load(builtin_scenario(name).read_text(encoding="utf-8"))["map"] == "hall_open"


@pytest.mark.slow
def test_a_run_records_its_true_appearance_distance_near_the_nominal():
    case = next(c for c in safety.person_cases(True) if c[1] == 1.0)
    rec = safety.run_one("differential", case, 0)
    assert rec["appear_dist_m"] == pytest.approx(safety.design_reach(), abs=0.1) and rec["appear_dist_m"] != 3.68
    assert math.isnan(safety.run_one("differential", None, 0, obstacle=False)["appear_dist_m"])
