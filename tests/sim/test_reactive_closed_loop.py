"""Closed-loop reactive control (issue 18): stop for a crossing person and resume, collide without a
reaction, avoid a static obstacle inside the corridor, the tracked robot's front-ranger stop.

The runs dead-reckon (no goniometer) on short straight paths to stay fast; the reaction does not
depend on how the vehicle positions itself. The path runs 4 m from the hall's south wall, inside the
approach fields of ISO 13855's K = 1.6 m/s at 1 m/s (they reach 4.07 m sideways): the runs that do not
test the approach term set K (``approach_speed_m_s``) to 0 or 1.2 m/s (3.15 m).
"""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.sim import simulate
from agvnav.world.scenario import parse_scenario

DIFFERENTIAL = """
name: reactive_test
seed: {seed}
step_s: 0.05
duration_s: {duration}
vehicle:
  model: differential
  track_m: 0.5
  wheel_radius_m: 0.08
  encoder_counts_per_rev: 4096
traction: {{speed_m_s: 1.0, max_accel_m_s2: 0.5, max_decel_m_s2: 0.5}}
positioning: {{method: dead_reckoning}}
map: hall
path:
  start: [4.0, 4.0, 0.0]
  segments:
    - {{type: line, length_m: {length}}}
"""

SCANNER = "scanner: {fov_deg: 200.0, step_deg: 1.0, max_range_m: 8.0, noise_std_m: 0.01, rate_hz: 25.0}\n"


def _crossing(enabled: bool = True, seed: int = 0, start_s: float = 3.3, path: str = "[[11, 1], [11, 8]]",
              approach: float = 0.0, warning: float = 1.5):
    # the person reaches the vehicle's lane (y = 4 - 0.29 - 0.25) when its front (x + 0.29) is
    # 7.76 - 1.97 - start_s m from x = 11: 2.5 m for the default start, 0.5 m for 5.3 s
    text = DIFFERENTIAL.format(seed=seed, duration=20.0, length=10.0) + SCANNER + f"""
obstacles:
  - {{id: person, shape: cylinder, radius_m: 0.25, path: {path}, speed_m_s: 1.2, start_s: {start_s}}}
reactive: {{reaction_time_s: 0.3, margin_m: 0.3, resume_after_s: 1.0, enabled: {str(enabled).lower()},
           approach_speed_m_s: {approach}, warning_time_s: {warning}}}
"""
    return simulate(parse_scenario(text, "crossing.yaml"))


def test_crossing_person_stops_the_vehicle_without_collision_and_it_resumes():
    r = _crossing()
    assert r.outcome == "completed", r.reason
    fig = r.reactive
    assert fig["stops"] == 1 and fig["time_stopped_s"] > 0.5
    person = fig["obstacles"]["person"]
    assert person["result"] == "stop"
    assert 0.2 < person["min_clearance_m"] < 3.0
    level = r.series["reaction_level"]
    k_stop = int(np.argmax(level >= 2.0))
    assert np.any(level[k_stop:] == 0.0)  # resumed
    v = r.series["v_cmd"]
    assert np.max(v[k_stop:]) == pytest.approx(1.0)  # back to cruise after the stop


def test_without_a_reaction_the_person_is_hit():
    """The metric can fail: the same vehicle without a reaction, the person 0.5 m ahead."""
    r = _crossing(enabled=False, start_s=5.3)
    assert r.outcome == "failed" and r.reason == "collision"
    assert r.reactive["obstacles"]["person"] == {"min_clearance_m": 0.0, "result": "collision"}
    assert r.reactive["stops"] == 0


@pytest.mark.parametrize("approach", [0.0, 1.2])
def test_a_person_walking_towards_the_vehicle_needs_fields_sized_for_the_approach(approach):
    """Head-on: the person walks 2.5 m along the path towards the vehicle (x 14 -> 11.5 from t = 5.95 s)
    and stops. Fields sized for standing obstacles (D = 1.6 m) stop too late; fields lengthened by the
    approach over the reaction and braking time (ISO 13855's K T) stop in time. No warning field here."""
    r = _crossing(start_s=5.95, path="[[14, 4], [11.5, 4]]", approach=approach, warning=0.0)
    if approach == 0.0:
        assert r.reason == "collision"
    else:
        assert r.reason == "timeout"  # stopped for good: the person stays on the path
        assert r.reactive["obstacles"]["person"]["result"] == "stop"
        assert r.reactive["obstacles"]["person"]["min_clearance_m"] > 0.1


def test_avoidance_passes_a_static_box_inside_the_corridor_and_rejoins():
    text = DIFFERENTIAL.format(seed=1, duration=45.0, length=14.0) + SCANNER + """
obstacles:
  - {id: pallet, shape: box, length_m: 1.2, width_m: 0.8, position: [11.0, 4.0]}
reactive:
  approach_speed_m_s: 0.0
  resume_after_s: 0.5
  avoid_segments: [0]
  corridor_left_m: 2.0
  corridor_right_m: 0.6
  avoid_after_s: 0.5
"""
    r = simulate(parse_scenario(text, "lane.yaml"))
    assert r.outcome == "completed", r.reason
    fig = r.reactive
    assert fig["detours"] == 1 and fig["obstacles"]["pallet"]["result"] == "avoid"
    assert fig["max_corridor_excess_m"] == 0.0
    assert fig["obstacles"]["pallet"]["min_clearance_m"] > 0.2
    y = r.series["y"]
    assert y.max() > 4.8  # went round on the left
    assert abs(r.series["lateral_error"][-1]) < 0.05  # back on the route at the end


def test_without_avoidance_the_box_blocks_the_lane():
    text = DIFFERENTIAL.format(seed=1, duration=20.0, length=14.0) + SCANNER + """
obstacles:
  - {id: pallet, shape: box, length_m: 1.2, width_m: 0.8, position: [11.0, 4.0]}
reactive: {resume_after_s: 0.5, approach_speed_m_s: 0.0}
"""
    r = simulate(parse_scenario(text, "blocked.yaml"))
    assert r.outcome == "failed" and r.reason == "timeout"
    assert r.reactive["obstacles"]["pallet"]["result"] == "stop"
    assert r.reactive["obstacles"]["pallet"]["min_clearance_m"] > 0.2


TRACKED = """
name: tracked_ranger_stop
seed: 0
step_s: 0.05
duration_s: 40.0
vehicle:
  model: tracked
  gauge_m: 0.33
  sprocket_radius_m: 0.05
traction: {speed_m_s: 0.15, max_accel_m_s2: 0.2, max_decel_m_s2: 0.2}
ultrasonic: {noise_std_m: 0.003}
positioning: {method: wall_landmarks}
map: hall
path:
  start: [4.0, 4.0, 0.0]
  segments:
    - {type: line, length_m: 6.0}
controller: {name: kanayama, params: {convergence_distance: 0.6}}
obstacles:
  - {id: crate, shape: box, length_m: 0.6, width_m: 0.8, position: [7.0, 4.0]}
"""


@pytest.mark.parametrize("stop_m", [0.4, None])
def test_tracked_robot_stops_on_its_front_ranger(stop_m):
    text = TRACKED + ("" if stop_m is None else f"reactive: {{ultrasonic_stop_m: {stop_m}}}\n")
    r = simulate(parse_scenario(text, "tracked.yaml"))
    if stop_m is None:  # no reaction: it drives into the crate
        assert r.reason == "collision"
        return
    assert r.reason == "timeout"  # stopped before the crate, for good (the crate stays)
    fig = r.reactive
    assert fig["stops"] >= 1
    clearance = fig["obstacles"]["crate"]["min_clearance_m"]
    assert 0.15 < clearance < 0.4
    reading = r.series["ranger_stop_range"]
    assert np.nanmin(reading) < 0.4
