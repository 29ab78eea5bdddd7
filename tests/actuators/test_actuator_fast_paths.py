"""The scalar fast paths of the actuators equal their vectorised kernels (same arithmetic)."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from agvnav.actuators import PID, MotorPair, WheelSpeedLoop
from agvnav.actuators.scalar import ScalarSpeedLoop
from agvnav.actuators.speed_profile import _profile_speed_scalar, profile_speed
from agvnav.actuators.steering import _steering_step_scalar, steering_step

finite = st.floats(-3.0, 3.0, allow_nan=False)


@given(finite, finite, st.floats(-20.0, 20.0), st.floats(1e-3, 0.2), st.floats(0.0, 0.3))
def test_steering_step_scalar_equals_kernel(gamma: float, rate: float, cmd: float, dt: float, tau: float) -> None:
    gamma = float(np.clip(gamma, -1.5, 1.5))
    ref = steering_step(gamma, rate, cmd, dt, tau, 1.0, 1.5)
    got = _steering_step_scalar(gamma, rate, cmd, dt, tau, 1.0, 1.5)
    assert got == (float(ref[0]), float(ref[1]))


@given(finite, st.sampled_from([0.2, -0.3, 0.0, 1.0]), st.floats(-1.0, 50.0), st.floats(1e-3, 0.2))
def test_profile_speed_scalar_equals_kernel(v: float, target: float, remaining: float, dt: float) -> None:
    ref = float(profile_speed(v, target, remaining, dt, 0.3, 0.5))
    assert _profile_speed_scalar(v, target, remaining, dt, 0.3, 0.5) == ref


def test_scalar_speed_loop_matches_wheel_speed_loop() -> None:
    ref = WheelSpeedLoop(MotorPair(asymmetry=0.05), PID())
    fast = ScalarSpeedLoop(WheelSpeedLoop(MotorPair(asymmetry=0.05), PID()))
    rng = np.random.default_rng(0)
    sp = rng.uniform(-6, 6, 2)
    for k in range(300):
        sp = rng.uniform(-6, 6, 2) if k % 50 == 0 else sp
        a = ref.step(sp, 0.01)
        b = fast.step(tuple(sp), 0.01)
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-12)


def test_scalar_speed_loop_copies_a_primed_loop_state() -> None:
    ref = WheelSpeedLoop(MotorPair(asymmetry=0.05), PID())
    for _ in range(20):
        ref.step((3.0, -2.0), 0.01)
    assert ref.pid.primed
    fast = ScalarSpeedLoop(ref)
    assert fast.primed
    for _ in range(50):
        np.testing.assert_allclose(fast.step((1.0, 4.0), 0.01), ref.step((1.0, 4.0), 0.01), rtol=0, atol=1e-12)
