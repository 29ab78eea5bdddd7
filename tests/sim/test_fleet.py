"""A fleet in one world (issue 28): lockstep runs, bodies as obstacles, collisions, refusals, figures."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.sim import simulate
from agvnav.sim.fleet import build_fleet, simulate_fleet
from agvnav.world.fleet import parse_fleet
from agvnav.world.scenario import ScenarioError, parse_scenario

HEAD = """\
name: lab_fleet
seed: 3
step_s: 0.05
map: lab
world_truth: {reflector_survey_std_m: 0.002}
traction: {speed_m_s: 0.5, max_accel_m_s2: 0.3, max_decel_m_s2: 0.3}
goniometer: {mount: [0.0, 0.0, 0.0], p_miss: 0.05}
positioning: {method: ekf, odometry_noise: [5.0e-5, 8.0e-4, 2.0e-4]}
vehicle: {model: differential, track_m: 0.5, wheel_radius_m: 0.08, encoder_counts_per_rev: 4096,
          truth: {wheel_diameter_ratio: 1.002, track_ratio: 1.01, slip_k: 0.0001}}
controller: {name: kanayama, params: {convergence_distance: 1.0}}
"""


def _line(x: float, y: float, heading: float, length: float) -> str:
    return f"{{start: [{x}, {y}, {heading}], segments: [{{type: line, length_m: {length}}}]}}"


def test_a_fleet_of_one_is_the_single_vehicle_run_bit_for_bit() -> None:
    single = parse_scenario(HEAD + "duration_s: 6.0\npath: " + _line(3.0, 2.0, 0.0, 2.0) + "\n", "one.yaml")
    fleet = parse_fleet(HEAD + "duration_s: 6.0\nfleet:\n  vehicles:\n    - id: only\n      path: "
                        + _line(3.0, 2.0, 0.0, 2.0) + "\n", "one.yaml")
    alone = simulate(single)
    result = simulate_fleet(fleet)
    series = result.results[0].series
    assert set(series) == set(alone.series)
    for name, values in alone.series.items():
        np.testing.assert_array_equal(series[name], values, err_msg=name)
    assert result.results[0].outcome == alone.outcome == "completed"


def test_a_small_fleet_completes_and_its_headline_agrees_with_the_vehicles() -> None:
    fleet = parse_fleet(HEAD + "fleet:\n  vehicles:\n"
                        "    - id: south\n      path: " + _line(3.0, 2.0, 0.0, 6.0) + "\n"
                        "    - id: north\n      path: " + _line(14.0, 8.5, 180.0, 6.0) + "\n"
                        "    - id: west\n      path: " + _line(2.0, 4.0, 90.0, 3.0) + "\n", "three.yaml")
    result = simulate_fleet(fleet)
    assert result.outcome == "completed", result.reason
    f, rows = result.figures, result.vehicles
    assert [r["outcome"] for r in rows] == ["completed"] * 3
    assert f["vehicles"] == 3 and f["completed"] == 3 and f["collisions"] == 0
    assert f["jobs_completed"] == sum(r["jobs_completed"] for r in rows) == 3
    assert f["min_separation_m"] == min(r["min_separation_m"] for r in rows)
    assert 0.5 < f["min_separation_m"] < 6.0
    assert f["vehicle_steps"] == sum(r.series["t"].size - 1 for r in result.results)
    # each vehicle's own figures are a single run's: its distance matches its path
    assert rows[0]["distance_m"] == pytest.approx(6.0, abs=0.1)


def test_the_bodies_motion_tables_are_the_plants_true_motion_over_every_step() -> None:
    """The fleet's arrays (sim.bodies) give each wheel-pair plant's own pose_at at any instant of the step."""
    fleet = parse_fleet(HEAD + "duration_s: 3.0\nfleet:\n  vehicles:\n"
                        "    - id: south\n      path: " + _line(3.0, 2.0, 0.0, 6.0) + "\n"
                        "    - id: west\n      path: " + _line(2.0, 4.0, 90.0, 3.0) + "\n", "two.yaml")
    bf = build_fleet(fleet)
    rng = np.random.default_rng(0)
    checked: list[float] = []

    def check(t: float) -> None:
        b = bf.bodies
        if b.t1 <= b.t0:
            return
        times = rng.uniform(b.t0, b.t1, 7)
        for i, vb in enumerate(bf.built):
            np.testing.assert_allclose(b.poses_at(times, np.array([i]))[:, 0], vb.plant.pose_at(times), atol=1e-9)
        checked.append(t)

    simulate_fleet(fleet, progress=check, built=bf)
    assert len(checked) > 50


def test_two_vehicles_driven_into_each_other_collide_named_on_the_true_poses() -> None:
    fleet = parse_fleet(HEAD + "fleet:\n  vehicles:\n"
                        "    - id: east\n      path: " + _line(3.0, 2.0, 0.0, 10.0) + "\n"
                        "    - id: west\n      path: " + _line(16.0, 2.0, 180.0, 10.0) + "\n", "crash.yaml")
    result = simulate_fleet(fleet)
    assert result.outcome == "failed"
    assert result.reason is not None and result.reason.startswith("collision of east and west at ")
    assert result.figures["collisions"] == 1 and result.figures["min_separation_m"] == 0.0
    (c,) = result.collisions
    t = c["t_s"]
    assert 8.0 < t < 14.0  # 13 m apart closing at up to 1 m/s, after the ramps
    for r in result.results:
        assert r.reason == "collision" and r.series["t"][-1] == pytest.approx(t)
    a, b = (r.series for r in result.results)
    gap = abs(a["x"][-1] - b["x"][-1])  # the true bodies (0.9 m long, centred) touch: gap <= 0.9 m
    assert gap <= 0.9 + 1e-9
    assert [v["reason"] for v in result.vehicles] == ["collision with west", "collision with east"]


def test_a_parked_vehicle_hides_a_reflector_from_another() -> None:
    # the observer at (3, 3) looks east at R5 (19.95, 4.0); the other stands at (12, 3.5), on that line of sight
    observer = "    - id: observer\n      path: " + _line(3.0, 3.0, 0.0, 0.3) + "\n"
    parked = "    - id: parked\n      path: " + _line(11.9, 3.53, 0.0, 0.2) + "\n"
    head = HEAD + "end_hold_s: 5.0\n"  # both stand still after their short paths
    alone = simulate_fleet(parse_fleet(head + "duration_s: 6.0\nfleet:\n  vehicles:\n" + observer, "a.yaml"))
    both = simulate_fleet(parse_fleet(head + "duration_s: 6.0\nfleet:\n  vehicles:\n" + observer + parked, "b.yaml"))
    r5 = 4  # index of R5 in the lab map

    def seen(result: object) -> int:
        refl = result.results[0].events["reflections"]  # type: ignore[attr-defined]
        return int(np.sum(refl["reflector_index"] == r5))

    assert seen(alone) >= 30  # 8 Hz for 6 s, a few missed
    assert seen(both) <= seen(alone) // 4


@pytest.mark.parametrize(
    ("vehicles", "message"),
    [
        ("    - id: a\n      path: " + _line(3.0, 2.0, 0.0, 2.0) + "\n"
         "    - id: b\n      path: " + _line(3.5, 2.2, 0.0, 2.0) + "\n",
         r"three.yaml:\d+: fleet.vehicles\[1\]: vehicle 'b' starts overlapping vehicle 'a'"),
    ],
)
def test_overlapping_starts_are_refused(vehicles: str, message: str) -> None:
    with pytest.raises(ScenarioError, match=message):
        build_fleet(parse_fleet(HEAD + "fleet:\n  vehicles:\n" + vehicles, "three.yaml"))


HALL = HEAD.replace("map: lab", "map: hall")


def _mission(vid: str, start: str, station: str, at: str = "") -> str:
    return (f"    - id: {vid}\n{at}      mission: {{network: hall_loop, start: {start}, "
            f"jobs: [{{action: goto, station: {station}}}]}}\n")


def test_a_start_off_every_route_is_refused_at_its_key() -> None:
    text = HALL + "fleet:\n  vehicles:\n" + _mission("a", "S1", "S2", "      at: [12.0, 6.0, 0.0]\n")
    with pytest.raises(ScenarioError, match=r"h.yaml:15: fleet.vehicles\[0\].at: vehicle 'a' starts off every route"):
        build_fleet(parse_fleet(text, "h.yaml"))


def test_a_start_pose_on_a_node_is_that_node() -> None:
    text = HALL + "fleet:\n  vehicles:\n" + _mission("a", "S1", "S2", "      at: [8.0, 3.0, 0.0]\n")
    built = build_fleet(parse_fleet(text, "h.yaml"))
    assert built.scenarios[0].mission is not None and built.scenarios[0].mission.start == "S1"


def test_more_vehicles_than_stations_are_refused() -> None:
    nodes = ["S1", "S2", "S3", "S4", "C1", "D", "P"]  # hall_loop has 6 stations
    text = HALL + "fleet:\n  vehicles:\n" + "".join(_mission(f"v{i}", n, "S2") for i, n in enumerate(nodes))
    with pytest.raises(ScenarioError, match=r"h.yaml:13: fleet.vehicles: 7 vehicles on network 'hall_loop', which "
                                            r"has only 6 stations"):
        build_fleet(parse_fleet(text, "h.yaml"))


def test_a_vehicle_error_names_the_vehicle_and_its_key() -> None:
    text = HALL + "fleet:\n  vehicles:\n" + _mission("a", "S1", "nowhere")
    with pytest.raises(ScenarioError, match=r"h.yaml:\d+: fleet.vehicles\[0\].mission.jobs\[0\].station: vehicle 'a'"):
        build_fleet(parse_fleet(text, "h.yaml"))


def test_a_vehicle_that_fails_stops_there_and_the_others_go_on() -> None:
    # "walled" drives east into pillar P1 (a wall collision ends its run at once); 'ok' drives on and completes
    fleet = parse_fleet(HEAD + "fleet:\n  vehicles:\n"
                        "    - id: ok\n      path: " + _line(3.0, 2.0, 0.0, 8.0) + "\n"
                        "    - id: walled\n      path: " + _line(3.0, 6.0, 0.0, 1.7) + "\n", "w.yaml")
    result = simulate_fleet(fleet)
    ok, walled = result.vehicles
    assert walled["outcome"] == "failed" and walled["reason"] == "collision"
    assert ok["outcome"] == "completed" and ok["end_s"] > walled["end_s"] + 5.0
    assert result.outcome == "failed" and result.reason == "walled: collision"
    assert result.collisions == [] and result.figures["completed"] == 1 and result.figures["failed"] == 1


REACTIVE = "scanner: {rate_hz: 12.5, step_deg: 1.0}\nreactive: {approach_speed_m_s: 0.0}\n"


def test_a_vehicle_stopped_behind_another_counts_it_every_step_whatever_the_recording_rate() -> None:
    body = ("duration_s: 14.0\nfleet:\n  vehicles:\n"
            "    - id: mover\n      path: " + _line(3.0, 2.0, 0.0, 9.0) + "\n"
            "    - id: parked\n      path: " + _line(9.0, 2.0, 0.0, 0.2) + "\n")
    every = simulate_fleet(parse_fleet(HEAD + REACTIVE + body, "stop.yaml"))
    sparse = simulate_fleet(parse_fleet(HEAD + REACTIVE + "record_step_s: 0.5\n" + body, "stop.yaml"))
    mover = every.vehicles[0]
    assert mover["outcome"] == "failed" and mover["reason"] == "timeout"  # it waits behind 'parked'
    assert mover["stopped_most_by"] == "parked"
    assert 1.0 < mover["time_stopped_by_vehicle_s"] <= mover["time_stopped_fields_s"]
    assert every.collisions == [] and every.figures["min_separation_m"] > 0.3
    # the per-step count agrees with the recorded series (every step recorded)
    s = every.results[0].series
    dt = np.diff(s["t"], prepend=s["t"][0])
    assert mover["time_stopped_fields_s"] == pytest.approx(float(np.sum(dt[s["reaction_level"] >= 2.0])), abs=1e-9)
    # a tenth of the rows, the same figures (counted every step) and the same run
    assert sparse.results[0].series["t"].size == pytest.approx(every.results[0].series["t"].size / 10, abs=2)
    for key in ("time_stopped_fields_s", "time_stopped_by_vehicle_s", "jobs_completed", "min_separation_m"):
        assert sparse.vehicles[0][key] == every.vehicles[0][key], key
    full, few = every.results[0].series, sparse.results[0].series
    at = np.searchsorted(full["t"], few["t"])
    np.testing.assert_array_equal(full["t"][at], few["t"])
    np.testing.assert_array_equal(full["x"][at], few["x"])  # the same run, recorded every 10th step


def test_a_mission_vehicle_stops_for_another_in_its_safety_field_and_without_fields_runs_into_it() -> None:
    # 'mover' leaves S1 (8, 3) east for S2; 'parked' stands on that lane at (13, 3)
    vehicles = ("duration_s: 14.0\nfleet:\n  vehicles:\n" + _mission("mover", "S1", "S2")
                + "    - id: parked\n      path: " + _line(13.0, 3.0, 0.0, 0.2) + "\n")
    fields = simulate_fleet(parse_fleet(HALL + REACTIVE + vehicles, "m.yaml"))
    mover = fields.vehicles[0]
    assert fields.collisions == [] and mover["reason"] == "timeout"
    assert mover["stopped_most_by"] == "parked" and mover["time_stopped_by_vehicle_s"] > 3.0
    assert 0.2 < fields.figures["min_separation_m"] < 2.5
    blind = simulate_fleet(parse_fleet(HALL + vehicles, "m.yaml"))
    assert blind.outcome == "failed" and blind.reason is not None and "collision of mover and parked" in blind.reason


def test_a_mission_vehicle_refuses_local_avoidance_at_its_key() -> None:
    text = HALL + "scanner: {}\nreactive: {avoid_segments: all, corridor_left_m: 1.0}\nfleet:\n  vehicles:\n" \
        + _mission("mover", "S1", "S2")
    with pytest.raises(ScenarioError, match=r"m.yaml:\d+: reactive.avoid_segments: vehicle 'mover': local avoidance"):
        build_fleet(parse_fleet(text, "m.yaml"))
