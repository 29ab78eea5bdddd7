"""Traffic control in the closed-loop fleet (issues 28, 30): jobs dispatched, routes planned together, ADG holds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from agvnav.sim.fleet import build_fleet, simulate_fleet
from agvnav.sim.traffic import plan_traffic
from agvnav.world.fleet import load_fleet, parse_fleet
from agvnav.world.scenario import ScenarioError

# One two-way lane of 6 m in the hall (y = 3 m, from WH at x = 7 to EH at x = 13), two stations fanned out at each
# end; differential AGVs (they turn on the spot at the lane's ends).
LANE = """\
name: hall_lane
description: one two-way lane in the hall, two stations at each end
tolerances: {joint_deg: 5.0}
nodes:
- {id: WA, x: 4.0, y: 5.0, kind: station}
- {id: WB, x: 4.0, y: 1.5, kind: station}
- {id: WH, x: 7.0, y: 3.0}
- {id: M, x: 10.0, y: 3.0}
- {id: EH, x: 13.0, y: 3.0}
- {id: EA, x: 16.0, y: 5.0, kind: station}
- {id: EB, x: 16.0, y: 1.5, kind: station}
edges:
- {id: WH-M, from: WH, to: M, speed_m_s: 1.0, two_way: true}
- {id: M-EH, from: M, to: EH, speed_m_s: 1.0, two_way: true}
- {id: WH-WA, from: WH, to: WA, speed_m_s: 0.5, two_way: true}
- {id: WH-WB, from: WH, to: WB, speed_m_s: 0.5, two_way: true}
- {id: EH-EA, from: EH, to: EA, speed_m_s: 0.5, two_way: true}
- {id: EH-EB, from: EH, to: EB, speed_m_s: 0.5, two_way: true}
"""

HEAD = """\
name: lane_fleet
seed: 3
step_s: 0.05
map: hall
world_truth: {reflector_survey_std_m: 0.002}
traction: {speed_m_s: 1.0, max_accel_m_s2: 0.3, max_decel_m_s2: 0.3}
goniometer: {mount: [0.0, 0.0, 0.0], p_miss: 0.05}
positioning: {method: ekf, odometry_noise: [5.0e-5, 8.0e-4, 2.0e-4]}
vehicle: {model: differential, track_m: 0.5, wheel_radius_m: 0.08, encoder_counts_per_rev: 4096,
          truth: {wheel_diameter_ratio: 1.002, track_ratio: 1.01, slip_k: 0.0001}}
controller: {name: kanayama, params: {convergence_distance: 0.5}}
"""


def _vehicle(vid: str, start: str, jobs: str = "[]") -> str:
    return (f"    - id: {vid}\n      mission: {{network: lane.yaml, start: {start}, jobs: {jobs}, "
            "align_heading: false}\n")


def _fleet(tmp_path: Path, body: str, traffic: str = "{home: false}") -> object:
    (tmp_path / "lane.yaml").write_text(LANE)
    text = HEAD + f"fleet:\n  traffic: {traffic}\n" + body
    return parse_fleet(text, str(tmp_path / "f.yaml"), base_dir=tmp_path)


# west stands at J1's pick WA and takes it to EA, east stands at J2's pick EB and takes it to WB: they meet head-on
# in the lane unless one waits for the other to clear it
HEAD_ON = ("  vehicles:\n" + _vehicle("west", "WA") + _vehicle("east", "EB")
           + "  jobs:\n"
           "    - {id: J1, pick: WA, drop: EA, pick_s: 1.0, drop_s: 1.0}\n"
           "    - {id: J2, pick: EB, drop: WB, pick_s: 1.0, drop_s: 1.0}\n")


def test_two_vehicles_meeting_head_on_in_a_lane_take_turns_and_do_every_job(tmp_path: Path) -> None:
    fleet = _fleet(tmp_path, HEAD_ON)
    result = simulate_fleet(fleet)  # type: ignore[arg-type]
    assert result.outcome == "completed", result.reason
    f, rows = result.figures, {r["id"]: r for r in result.vehicles}
    assert rows["west"]["dispatched_jobs"] == ["J1"] and rows["east"]["dispatched_jobs"] == ["J2"]
    assert f["collisions"] == 0 and f["traffic_conflicts"] == 0 and f["unserved_jobs"] == []
    assert f["deliveries"] == 2 and f["jobs_completed"] == f["jobs"] == 4
    # one of them waited at its start (its pick) for the other to clear the lane; the figures add up
    waiter = max(rows.values(), key=lambda r: r["traffic_wait_s"])
    other = rows["east" if waiter["id"] == "west" else "west"]
    assert waiter["traffic_wait_s"] > 5.0 and other["traffic_wait_s"] < waiter["traffic_wait_s"]
    assert f["traffic_wait_s"] == pytest.approx(waiter["traffic_wait_s"] + other["traffic_wait_s"])
    assert sum(waiter["traffic_wait_by_zone_s"].values()) == pytest.approx(waiter["traffic_wait_s"])
    assert sum(waiter["traffic_wait_by_node_s"].values()) == pytest.approx(waiter["traffic_wait_s"])
    start = {"west": "WA", "east": "EB"}[waiter["id"]]
    assert waiter["traffic_wait_most_at"] == start
    zone = max(waiter["traffic_wait_by_zone_s"], key=waiter["traffic_wait_by_zone_s"].get)
    assert zone == {"west": "edge:WH-WA~r", "east": "edge:EH-EB~r"}[waiter["id"]]  # the way out of its spur
    assert f["min_separation_m"] > 0.5
    # the recorded series agrees: the waiter stood at its hold point as long as it waited (to a step)
    s = result.results[[r["id"] for r in result.vehicles].index(waiter["id"])].series
    held = float(np.sum(np.diff(s["t"], prepend=s["t"][0])[s["traffic_hold"] > 0.5]))
    assert held == pytest.approx(waiter["traffic_wait_s"], abs=0.11)


def test_without_the_holds_the_same_plans_meet_in_the_lane(tmp_path: Path) -> None:
    # the same plans driven without standing at the ADG's hold points: both enter the lane and collide
    fleet = _fleet(tmp_path, HEAD_ON, "{home: false, follow_adg: false}")
    result = simulate_fleet(fleet)  # type: ignore[arg-type]
    assert result.figures["traffic_conflicts"] >= 1
    assert result.outcome == "failed" and result.collisions
    assert result.figures["traffic_wait_s"] == 0.0


def test_a_vehicle_waiting_behind_one_whose_run_ended_is_stopped_naming_it(tmp_path: Path) -> None:
    # a box on the lane the first vehicle drives (no safety fields): it runs into it, and the other, waiting for it
    # to clear the lane, would wait for ever: it is stopped, failed, naming the vehicle it waits for
    (tmp_path / "lane.yaml").write_text(LANE)
    body = HEAD + ("obstacles: [{id: box, shape: box, length_m: 0.6, width_m: 0.6, position: [11.5, 3.0]}]\n"
                   "fleet:\n  traffic: {home: false}\n") + HEAD_ON
    result = simulate_fleet(parse_fleet(body, str(tmp_path / "f.yaml"), base_dir=tmp_path))
    rows = {r["id"]: r for r in result.vehicles}
    hit = next(r for r in rows.values() if r["reason"] == "collision")
    waiter = rows["east" if hit["id"] == "west" else "west"]
    assert result.outcome == "failed"
    assert waiter["outcome"] == "failed"
    assert waiter["reason"].startswith(f"blocked: waits for traffic behind {hit['id']}")
    assert waiter["end_s"] < hit["end_s"] + 1.0  # stopped at once, not at the time limit


@pytest.mark.slow
def test_a_vehicle_without_work_stands_at_its_start_and_counts_as_done(tmp_path: Path) -> None:
    body = ("  vehicles:\n" + _vehicle("busy", "WA", "[{action: goto, station: WB}]") + _vehicle("spare", "EA"))
    result = simulate_fleet(_fleet(tmp_path, body))  # type: ignore[arg-type]
    assert result.outcome == "completed", result.reason
    spare = result.vehicles[1]
    assert spare["outcome"] == "completed" and spare["reason"].startswith("idle")
    assert spare["distance_m"] < 0.05 and spare["jobs"] == 0 and spare["traffic_wait_s"] == 0.0
    assert result.figures["jobs_completed"] == result.figures["jobs"] == 1


def test_traffic_control_needs_every_vehicle_on_the_mission_network(tmp_path: Path) -> None:
    body = ("  vehicles:\n" + _vehicle("a", "WA")
            + "    - id: b\n      path: {start: [10.0, 8.0, 0.0], segments: [{type: line, length_m: 2.0}]}\n")
    with pytest.raises(ScenarioError, match=r"fleet.vehicles\[1\]: vehicle 'b' drives a path"):
        build_fleet(_fleet(tmp_path, body))  # type: ignore[arg-type]


def test_a_job_at_an_unknown_station_is_refused_at_its_key(tmp_path: Path) -> None:
    body = "  vehicles:\n" + _vehicle("a", "WA") + "  jobs:\n    - {id: J1, pick: WB, drop: nowhere}\n"
    with pytest.raises(ScenarioError, match=r"fleet.jobs\[0\].drop: unknown station 'nowhere'"):
        build_fleet(_fleet(tmp_path, body))  # type: ignore[arg-type]


def test_the_shipped_fleet_with_jobs_is_planned_for_every_vehicle_and_job() -> None:
    fleet = load_fleet("warehouse_fleet_jobs")
    traffic = plan_traffic(fleet, fleet.vehicle_scenarios())
    assert len(traffic.jobs) == 6 and not traffic.assignment.unserved and not traffic.plan.unserved
    assert sum(len(js) for js in traffic.assignment.jobs.values()) == 6
    assert traffic.adg.is_acyclic() and traffic.adg.n_dependencies > 0
    assert all(m is not None for m in traffic.missions.values())


@pytest.mark.slow
def test_the_shipped_fleet_with_jobs_does_every_job_without_collision() -> None:
    result = simulate_fleet(load_fleet("warehouse_fleet_jobs"))
    f = result.figures
    assert result.outcome == "completed", result.reason
    assert f["collisions"] == 0 and f["traffic_conflicts"] == 0 and f["deliveries"] == 6
    assert f["jobs_completed"] == f["jobs"] and f["traffic_wait_s"] > 0.0


def test_a_single_mission_without_jobs_is_refused_at_its_key() -> None:
    from agvnav.sim.build import build
    from agvnav.world.scenario import builtin_scenario, parse_scenario

    text = Path(builtin_scenario("mission_hall_differential")).read_text()
    i, j = text.index("  jobs:\n"), text.index("controller:")
    with pytest.raises(ScenarioError, match=r"x.yaml:\d+: mission.jobs: the mission has no jobs"):
        build(parse_scenario(text[:i] + "  jobs: []\n" + text[j:], "x.yaml"))
