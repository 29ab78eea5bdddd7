"""Scalar fast path of the two-track speed loop (PID + motor pair) for the simulator's hot loop.

Same equations as :class:`agvnav.actuators.PID` and :func:`agvnav.actuators.motor_step`
(seed 004 §II) for two loops, in ``math``; it reads only public state of the loop.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

__all__ = ["ScalarSpeedLoop"]


class ScalarSpeedLoop:
    """The same PID + motor pair as a :class:`~agvnav.actuators.WheelSpeedLoop`, in scalar math.

    Reads its parameters (and state) from ``loop``: parallel PID with filtered
    derivative on the measurement and clamping anti-windup, output clipped to
    ``[u_min, u_max]``, then the exact zero-order-hold step of
    ``tau omega' = K_i u - omega`` per motor (seed 004 §II). ``step`` returns
    the new ``(omega_right, omega_left)`` (rad/s). Mirrors
    :meth:`agvnav.actuators.WheelSpeedLoop.step` for two loops in ``math`` (no NumPy
    per-call overhead); ``tests/actuators/test_actuator_fast_paths.py`` checks it to 1e-12.
    """

    def __init__(self, loop: Any) -> None:
        pid, motors = loop.pid, loop.motors
        self.kp, self.ki, self.kd = float(pid.kp), float(pid.ki), float(pid.kd)
        self.u_min, self.u_max = float(pid.u_min), float(pid.u_max)
        self.u_motor = float(motors.u_max)
        self.d_tau = float(pid.derivative_tau)
        self.anti_windup = bool(pid.anti_windup)
        self.tau = float(motors.tau)
        self.gains = [float(g) for g in motors.gains]
        self.integral = [float(v) for v in pid.integral]
        self.y_f = [float(v) for v in pid.y_filtered]
        self.primed = bool(pid.primed)
        self.omega = [float(v) for v in motors.omega]
        self._alpha: dict[float, float] = {}
        self._decay: dict[float, float] = {}

    def step(self, setpoint: Sequence[float], dt: float) -> tuple[float, float]:
        """One control period of ``dt`` s towards ``setpoint = (right, left)`` (rad/s)."""
        alpha = self._alpha.get(dt)
        if alpha is None:
            alpha = 1.0 if self.d_tau == 0.0 else -math.expm1(-dt / self.d_tau)
            self._alpha[dt] = alpha
            self._decay[dt] = math.exp(-dt / self.tau)
        decay = self._decay[dt]
        out = []
        for i in (0, 1):
            y = self.omega[i]
            if self.primed:
                prev = self.y_f[i]
                self.y_f[i] = prev + alpha * (y - prev)
                deriv = (self.y_f[i] - prev) / dt
            else:
                self.y_f[i], deriv = y, 0.0
            e = setpoint[i] - y
            cand = self.integral[i] + e * dt
            u_free = self.kp * e + self.ki * cand - self.kd * deriv
            u = min(self.u_max, max(self.u_min, u_free))
            pushing = (u_free > self.u_max and e > 0) or (u_free < self.u_min and e < 0)
            if not (self.anti_windup and pushing):
                self.integral[i] = cand
            u = min(self.u_motor, max(-self.u_motor, u))
            steady = self.gains[i] * u
            self.omega[i] = steady + (y - steady) * decay
            out.append(self.omega[i])
        self.primed = True
        return out[0], out[1]
