"""PID speed loop with the first-order motor model (seed 004 gains)."""

import numpy as np
import pytest
from scipy import signal

from agvnav.actuators import PID, SEED_004_GAINS, MotorPair, WheelSpeedLoop, motor_step


def _run(loop, setpoints, dt):
    return np.array([loop.step(r, dt) for r in setpoints])


def test_motor_step_is_exact_first_order_response():
    tau, gain, u, dt = 0.1, 0.4, 6.0, 0.013
    w = 0.0
    for k in range(1, 50):
        w = motor_step(w, u, dt, tau, gain)
        assert w == pytest.approx(gain * u * (1 - np.exp(-k * dt / tau)), rel=1e-12)


def test_motor_asymmetry_and_saturation():
    motors = MotorPair(asymmetry=0.1)
    for _ in range(2000):
        w = motors.step([100.0, 100.0], 1e-3)  # clipped to 12 V
    assert w[0] == pytest.approx(12.0 * motors.gain * 1.05, rel=1e-6)
    assert w[1] == pytest.approx(12.0 * motors.gain * 0.95, rel=1e-6)
    with pytest.raises(ValueError, match="asymmetry"):
        MotorPair(asymmetry=2.5)


def test_pid_step_matches_continuous_closed_loop_and_settles():
    """Closed loop K(Kp s + Ki) / ((tau + K Kd) s^2 + (1 + K Kp) s + K Ki)."""
    kp, ki, kd = SEED_004_GAINS
    motors = MotorPair(asymmetry=0.06)
    loop = WheelSpeedLoop(motors, PID(derivative_tau=1e-3))
    dt, n, step = 1e-3, 6000, 3.0
    w = _run(loop, np.full((n, 2), step), dt)
    t = dt * np.arange(1, n + 1)
    for i, k in enumerate(motors.gains):
        den = [motors.tau + k * kd, 1 + k * kp, k * ki]
        _, y = signal.step(signal.TransferFunction([k * kp, k * ki], den), T=t)
        y *= step
        assert np.max(np.abs(w[:, i] - y)) < 0.02 * step
        outside = np.nonzero(np.abs(y - step) > 0.02 * step)[0]
        settling = t[outside[-1] + 1]
        assert settling < 2.5  # the seed's gains settle a speed step in ~2 s
        held = t > settling + 0.05
        assert np.all(np.abs(w[held, i] - step) < 0.02 * step)
    assert w[-1] == pytest.approx([step, step], abs=1e-3)  # integral action removes the asymmetry


def test_anti_windup_recovers_faster_after_saturation():
    """Set-point beyond the 12 V top speed for 2 s, then 3 rad/s."""

    def recovery_time(anti_windup):
        loop = WheelSpeedLoop(MotorPair(), PID(anti_windup=anti_windup))
        r = np.where(np.arange(8000)[:, None] < 2000, 6.0, 3.0) * np.ones((1, 2))
        w = _run(loop, r, 1e-3)[2000:, 0]
        assert np.max(w) <= MotorPair().gain * 12.0 + 1e-9
        return np.nonzero(np.abs(w - 3.0) > 0.06)[0].max() * 1e-3

    with_aw, without = recovery_time(True), recovery_time(False)
    assert with_aw < 1.8
    assert without > with_aw + 1.0


def test_derivative_on_measurement_has_no_setpoint_kick():
    pid = PID(kp=0.0, ki=0.0, kd=5.0, size=1)
    pid.update([0.0], [1.0], 0.01)
    u = pid.update([100.0], [1.0], 0.01)
    assert u[0] == 0.0


def test_pid_rejects_bad_parameters():
    with pytest.raises(ValueError, match="u_min"):
        PID(u_min=1.0, u_max=-1.0)
    with pytest.raises(ValueError, match="kp"):
        PID(kp=-1.0)
    with pytest.raises(ValueError, match="dt"):
        PID().update([0, 0], [0, 0], 0.0)
