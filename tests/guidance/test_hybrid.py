"""Seed 004's hybrid automaton (Fig. 7) on the square route, with a scripted robot."""

import math

import numpy as np
import pytest

from agvnav.guidance.hybrid import HybridController, HybridParams, HybridState, PolygonRoute
from agvnav.sensors import seed_004_layout

SIDE = 3.5
LAYOUT = seed_004_layout()


def _landmarks(route, outside, offset=0.5, ahead=0.62):
    """A wall alongside the middle of every leg on the ``outside`` and one across each corner."""
    walls = []
    for k in range(route.n_legs):
        start, heading, length = route.leg(k)
        u = np.array([math.cos(heading), math.sin(heading)])
        n = np.array([-u[1], u[0]]) * (1.0 if outside == "left" else -1.0)
        walls.append([start + 1.0 * u + offset * n, start + (length - 1.0) * u + offset * n])
        corner = start + (length + ahead) * u
        walls.append([corner - 0.5 * n, corner + 0.5 * n])
    return np.array(walls)


def _unicycle(pose, v, omega, dt):
    x, y, th = pose
    if abs(omega) < 1e-12:
        return np.array([x + v * dt * math.cos(th), y + v * dt * math.sin(th), th])
    th1 = th + omega * dt
    return np.array([x + v / omega * (math.sin(th1) - math.sin(th)), y - v / omega * (math.cos(th1) - math.cos(th)), th1])


def _run(ctrl, walls, slip=(0.02, 0.03), dt=0.1, t_max=400.0, noise=0.0, seed=0, via_observe=False):
    """Truth drives with speed loss and yaw-rate error; odometry sees the commands."""
    rng = np.random.default_rng(seed)
    truth = ctrl.route.start_pose.copy()
    lap_truth, t = [], 0.0
    while t < t_max and not ctrl.finished:
        e = LAYOUT.echo(truth, walls)
        noisy = np.where(e.valid, e.range + noise * rng.standard_normal(e.range.shape), np.nan)
        ranges = dict(zip(LAYOUT.names, noisy.tolist()))
        n_before = len(ctrl.transitions)
        if via_observe:  # as a simulator delivering each ping at its instant
            ctrl.observe(t, ranges)
            cmd = ctrl.command(t)
        else:
            cmd = ctrl.command(t, ranges)
        if any(tr.target is HybridState.E4 for tr in ctrl.transitions[n_before:]):
            lap_truth.append(truth.copy())
        truth = _unicycle(truth, cmd.v * (1 - slip[0]), cmd.omega * (1 + slip[1]), dt)
        ctrl.localizer.predict(t + dt, cmd.v * dt, cmd.omega * dt)
        t += dt
    return np.array(lap_truth)


@pytest.mark.parametrize("turn, outside, side_state", [("left", "right", "E1"), ("right", "left", "E2")])
def test_automaton_visits_states_on_the_square(turn, outside, side_state):
    route = PolygonRoute.square(SIDE, turn=turn)
    walls = _landmarks(route, outside)
    ctrl = HybridController(route, LAYOUT, walls, laps=1)
    lap_truth = _run(ctrl, walls)
    assert ctrl.finished and ctrl.laps_done == 1 and ctrl.turns == 0  # E4 reset the counter
    seq = ctrl.visited()
    assert seq.count("E3") == 4 and seq[-1] == "E4"
    other = "E2" if side_state == "E1" else "E1"
    assert other not in seq
    # every leg: E0 -> side landmark state -> ... -> E3
    legs = "".join(s[-1] for s in seq).split("3")
    assert len(legs) == 5 and all(side_state[-1] in leg for leg in legs[:4])
    assert all(tr.t >= 0 and tr.cause for tr in ctrl.transitions)
    assert [tr.t for tr in ctrl.transitions] == sorted(tr.t for tr in ctrl.transitions)
    assert ctrl.transitions[-1].cause == "4 turns counted: lap 1 complete"
    kinds = {c.kind for c in ctrl.localizer.history}
    assert kinds == {"heading", "side_offset", "front_offset"}
    # the landmarks keep the lap error to a few centimetres despite 2 % / 3 % slip
    error = np.hypot(*(lap_truth[0, :2] - route.start_pose[:2]))
    assert error < 0.05


def test_landmarks_beat_dead_reckoning_over_laps():
    route = PolygonRoute.square(SIDE)
    walls = _landmarks(route, "right")
    errors = {}
    for use in (True, False):
        ctrl = HybridController(route, LAYOUT, walls, laps=2, use_landmarks=use, params=HybridParams(dwell=0.5))
        lap_truth = _run(ctrl, walls, noise=0.003, seed=4, via_observe=use)
        assert len(lap_truth) == 2
        errors[use] = np.hypot(*(lap_truth[:, :2] - route.start_pose[:2]).T)
    assert np.all(errors[True] < 0.06)
    assert errors[False][1] > 3 * errors[True][1]  # dead reckoning drifts
    assert errors[False][1] > errors[False][0]


def test_route_that_never_passes_a_landmark_is_refused():
    route = PolygonRoute.square(SIDE)
    far = np.array([[[10.0, 10.0], [12.0, 10.0]]])
    with pytest.raises(ValueError, match="never passes a landmark"):
        HybridController(route, LAYOUT, far)
    HybridController(route, LAYOUT, far, use_landmarks=False)  # fine without landmarks
    with pytest.raises(ValueError, match="zero length"):
        HybridController(route, LAYOUT, np.array([[[1.0, -0.5], [1.0, -0.5]]]))


def test_stop_state_outputs_zero_and_dwell_restarts():
    route = PolygonRoute.square(1.0)
    ctrl = HybridController(route, LAYOUT, [], laps=2, use_landmarks=False, params=HybridParams(dwell=2.0))
    _run(ctrl, np.zeros((0, 2, 2)), slip=(0.0, 0.0), t_max=200.0)
    e4 = [tr for tr in ctrl.transitions if tr.target is HybridState.E4]
    restart = [tr for tr in ctrl.transitions if tr.source is HybridState.E4]
    assert len(e4) == 2 and len(restart) == 1
    assert restart[0].t - e4[0].t == pytest.approx(2.0, abs=0.101)  # one 0.1 s step
    cmd = ctrl.command(1e3, {})
    assert cmd.v == 0.0 and cmd.omega == 0.0 and np.all(cmd.wheel_speeds == 0.0) and cmd.state == "E4"
