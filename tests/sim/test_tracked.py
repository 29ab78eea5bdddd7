"""Issue 6: the tracked robot, its ultrasonic rangers and the hybrid automaton in the closed loop."""

import numpy as np
import pytest

from agvnav.guidance.hybrid import PolygonRoute
from agvnav.sensors import seed_004_layout
from agvnav.sim.laps import lap_errors, prepare_tracked, run_tracked
from agvnav.sim.rangers import UltrasonicSensorRole
from agvnav.world.scenario import parse_scenario
from agvnav.world.walls import square_landmarks

ROUTE = PolygonRoute.square(3.5)
WALLS = square_landmarks(ROUTE)
SCENARIO = """
name: tracked_test
seed: {seed}
step_s: 0.1
{duration}
vehicle:
  model: tracked
  terrain:
    truth: concrete
    odometry: {{slip_left: 0.016, slip_right: 0.016, icr_left: 1.12, icr_right: 1.12}}
    slip_noise_std: 0.003
ultrasonic: {{}}
route: {{side_m: 3.5}}
controller: {{name: hybrid, laps: {laps}}}
map:
  walls: {walls}
"""


def _run(laps: int, use_landmarks: bool, seed: int, duration: float | None = None):
    walls = [{"id": f"w{i}", "points": seg.tolist()} for i, seg in enumerate(WALLS)]
    text = SCENARIO.format(seed=seed, laps=laps, walls=walls,
                           duration="" if duration is None else f"duration_s: {duration}")
    sc = parse_scenario(text, "tracked_test")
    parts = prepare_tracked(sc)
    return run_tracked(sc, parts.route, parts.world, parts.layout, parts.params, use_landmarks=use_landmarks)


def test_ultrasonic_role_groups_simultaneous_pings_and_reports_the_wall_distance():
    layout = seed_004_layout()
    wall = np.array([[[-5.0, -0.5], [5.0, -0.5]]])  # 0.3 m right of the right sensors
    role = UltrasonicSensorRole(layout, wall)
    pose_at = lambda t: np.tile([0.0, 0.0, 0.0], (np.size(t), 1))  # noqa: E731
    rows = role.observe(pose_at, 0.0, 0.1, np.random.default_rng(0))
    assert rows.shape[1] == 1 + 5 and np.all(np.diff(rows[:, 0]) > 0)
    names = layout.names
    rf = rows[:, 1 + names.index("right_front")]
    assert np.all(np.isinf(rf) | (np.abs(rf - 0.3) < 0.02))
    assert np.sum(np.isfinite(rf)) == 2  # 20 Hz over 0.1 s
    lf = rows[:, 1 + names.index("left_front")]
    assert np.all(np.isinf(lf) | np.isnan(lf))  # nothing on the left


def test_lap_errors_per_lap_and_from_start():
    t = np.arange(5.0)
    xy = np.array([[0, 0], [1, 0], [0.3, 0.4], [2, 2], [0.6, 0.8]])
    le = lap_errors([2.0, 4.0], t, xy, (0.0, 0.0))
    np.testing.assert_allclose(le.error_m, [0.5, 1.0])
    np.testing.assert_allclose(le.per_lap_m, [0.5, 0.5])
    with pytest.raises(ValueError, match="samples"):
        lap_errors([1.0], t, xy[:3], (0, 0))


def test_automaton_closed_loop_visits_e0_side_e3_four_times_e4():
    r = _run(1, True, seed=3)
    seq = r.controller.visited()
    assert r.finished and seq[0] == "E0" and seq[-1] == "E4"
    assert seq.count("E3") == 4 and seq.count("E4") == 1
    legs = "".join(s[-1] for s in seq).split("3")
    assert all("1" in leg for leg in legs[:4])  # a right landmark on every leg (CCW square, walls outside)
    assert "E2" not in seq
    kinds = {c.kind for c in r.estimator.history}
    assert kinds == {"heading", "side_offset", "front_offset"}


def test_landmarks_beat_dead_reckoning_two_laps():
    with_lm = _run(2, True, seed=5)
    without = _run(2, False, seed=5)
    assert with_lm.laps.laps == without.laps.laps == 2
    assert np.all(with_lm.laps.per_lap_m < 0.10)  # the seed's 10 cm per lap
    assert np.all(without.laps.per_lap_m > 0.25)  # calibrated to the seed's ~50 cm order
    assert without.laps.error_m[1] > without.laps.error_m[0]  # dead reckoning grows
    assert with_lm.laps.error_m[1] < 0.10  # landmarks keep it bounded


def test_same_seed_same_run():
    a = _run(1, True, seed=7, duration=30.0)
    b = _run(1, True, seed=7, duration=30.0)
    for key in a.series:
        np.testing.assert_array_equal(a.series[key], b.series[key])
