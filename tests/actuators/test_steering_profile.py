"""Steering actuator limits and lag; traction speed profile."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.actuators import SpeedProfile, SteeringActuator, profile_speed, steering_step


def test_steering_rate_lag_is_first_order():
    act = SteeringActuator(max_rate=10.0, tau=0.2)
    dt = 0.01
    for k in range(1, 40):
        _, rate = act.step_rate(0.5, dt)
        # mean rate over the step equals the lagged rate at its end (ZOH discretisation)
        assert rate == pytest.approx(0.5 * (1 - math.exp(-k * dt / 0.2)), rel=1e-9)


def test_steering_respects_rate_and_angle_limits():
    act = SteeringActuator(max_rate=0.5, tau=0.05)
    dt, gammas, rates = 0.01, [], []
    for _ in range(600):
        g, r = act.step_rate(5.0, dt)
        gammas.append(g)
        rates.append(r)
    assert max(rates) <= 0.5 + 1e-12
    assert max(gammas) == pytest.approx(math.pi / 2)
    assert rates[-1] == 0.0  # at the stop
    g, r = act.step_rate(-5.0, dt)
    assert r < 0 and g < math.pi / 2


def test_steering_angle_servo_converges_without_overshoot():
    act = SteeringActuator(max_rate=1.0, tau=0.1)
    trace = [act.step_angle(0.4, 0.01)[0] for _ in range(500)]
    assert trace[-1] == pytest.approx(0.4, abs=1e-4)
    assert max(trace) <= 0.4 + 0.01
    with pytest.raises(ValueError, match="max_angle"):
        SteeringActuator(max_angle=2.0)


@given(st.floats(-3, 3), st.floats(-2, 2), st.floats(-10, 10))
def test_steering_kernel_limits_property(gamma, rate, cmd):
    gamma = float(np.clip(gamma, -math.pi / 2, math.pi / 2))
    rate = float(np.clip(rate, -0.8, 0.8))
    g, r = steering_step(gamma, rate, cmd, 0.02, 0.1, 0.8, math.pi / 2)
    assert abs(g) <= math.pi / 2 and abs(r) <= 0.8 + 1e-12


def _drive(profile, length, dt, v_target=None):
    s, vs = 0.0, []
    for _ in range(100000):
        v = profile.command(length - abs(s), dt, v_target)
        if v == 0.0 and vs:
            break
        s += v * dt
        vs.append(v)
    return s, np.array(vs)


@pytest.mark.parametrize("length", [0.05, 1.0, 3.0])
def test_profile_respects_acceleration_and_stops_at_end(length):
    prof = SpeedProfile(cruise_speed=0.5, max_accel=0.3, max_decel=0.2)
    dt = 0.01
    s, v = _drive(prof, length, dt)
    assert s == pytest.approx(length, abs=2e-3)
    assert s <= length + 1e-12
    dv = np.diff(np.concatenate([[0.0], v]))
    assert np.max(dv) <= 0.3 * dt + 1e-12
    assert np.min(dv) >= -0.2 * dt - 1e-9 or length < 0.1  # a very short path may brake harder
    assert np.max(v) <= 0.5


def test_profile_reverse_direction():
    prof = SpeedProfile(cruise_speed=0.3, max_accel=0.5, max_decel=0.5)
    s, v = _drive(prof, 1.0, 0.01, v_target=-0.3)
    assert np.all(v <= 0) and s == pytest.approx(-1.0, abs=2e-3)


def test_profile_kernel_broadcasts():
    v = profile_speed(np.zeros(3), np.array([0.2, -0.2, 0.2]), np.array([5.0, 5.0, 0.0]), 0.1, 0.3, 0.3)
    assert v == pytest.approx([0.03, -0.03, 0.0])
