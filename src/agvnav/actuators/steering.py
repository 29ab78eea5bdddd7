"""Steering actuator of the tricycle's front drive wheel (seed 000, Fig. 9 loop).

The guidance laws of seed 000 output a steering *rate* command ``gamma_dot``
([seed000 eq11] [seed000 eq12] [seed000 eq13] [seed000 eq20] [seed000 eq21]
[seed000 eq22]); the real servo realises it with a lag and
within its limits. Model (an assumption, the seed gives no servo data):

* the realised rate follows the commanded rate as a first-order lag of time
  constant ``tau`` (exact zero-order-hold discretisation),
* the realised rate is clipped to ``±max_rate``,
* the angle is integrated and clamped to ``±max_angle`` (±90° by default, the
  mechanical stops of a pallet stacker's drive wheel); at a stop the rate is 0.

An angle-servo mode (``step_angle``) turns an angle set-point into a rate
command through a critically damped proportional position loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import as_float_array, require_nonnegative, require_positive


def steering_step(
    gamma: ArrayLike,
    rate: ArrayLike,
    rate_cmd: ArrayLike,
    dt: float,
    tau: float,
    max_rate: float,
    max_angle: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Advance the steering actuator by ``dt`` (s); broadcast over ``(...)``.

    Parameters
    ----------
    gamma, rate : steering angle (rad) and realised steering rate (rad/s) now.
    rate_cmd : commanded steering rate (rad/s), held over the step.
    dt : step (s). tau : lag time constant (s); 0 means no lag.
    max_rate : |rate| limit (rad/s). max_angle : |gamma| limit (rad).

    Returns
    -------
    (gamma_next, rate_next) : the new angle and the mean rate realised over the
    step (``(gamma_next - gamma) / dt``), so an integrator of ``rate_next``
    reproduces ``gamma_next`` exactly.
    """
    g = np.asarray(gamma, dtype=np.float64)
    r = np.asarray(rate, dtype=np.float64)
    u = np.asarray(rate_cmd, dtype=np.float64)
    alpha = 1.0 if tau <= 0.0 else -math.expm1(-dt / tau)
    r_lag = np.clip(r + alpha * (u - r), -max_rate, max_rate)
    g_next = np.clip(g + r_lag * dt, -max_angle, max_angle)
    return g_next, (g_next - g) / dt


def _steering_step_scalar(
    gamma: float, rate: float, rate_cmd: float, dt: float, tau: float, max_rate: float, max_angle: float
) -> tuple[float, float]:
    """Scalar fast path of :func:`steering_step` (same arithmetic, no NumPy call overhead)."""
    alpha = 1.0 if tau <= 0.0 else -math.expm1(-dt / tau)
    r_lag = min(max(rate + alpha * (rate_cmd - rate), -max_rate), max_rate)
    g_next = min(max(gamma + r_lag * dt, -max_angle), max_angle)
    return g_next, (g_next - gamma) / dt


@dataclass
class SteeringActuator:
    """Stateful steering servo: rate and angle limits, first-order lag.

    Defaults: ``max_angle = pi/2`` (±90°, issue 5 §3), ``max_rate = 1.0`` rad/s
    and ``tau = 0.1`` s (assumed typical of an AGV steering gearmotor).
    """

    max_angle: float = math.pi / 2
    max_rate: float = 1.0
    tau: float = 0.1
    gamma: float = 0.0
    rate: float = 0.0

    def __post_init__(self) -> None:
        require_positive("max_angle", self.max_angle)
        if self.max_angle > math.pi / 2 + 1e-12:
            raise ValueError(f"max_angle must be at most pi/2 (90 deg), got {self.max_angle!r}")
        require_positive("max_rate", self.max_rate)
        require_nonnegative("tau", self.tau)
        if abs(self.gamma) > self.max_angle:
            raise ValueError(f"gamma {self.gamma!r} is beyond max_angle {self.max_angle!r}")

    def reset(self, gamma: float = 0.0) -> None:
        """Place the wheel at ``gamma`` (rad) at rest."""
        if abs(gamma) > self.max_angle:
            raise ValueError(f"gamma {gamma!r} is beyond max_angle {self.max_angle!r}")
        self.gamma, self.rate = float(gamma), 0.0

    def step_rate(self, rate_cmd: float, dt: float) -> tuple[float, float]:
        """Apply a steering-rate command (rad/s) for ``dt`` s; return (gamma, rate)."""
        require_positive("dt", dt)
        u = float(as_float_array("rate_cmd", rate_cmd))
        if not math.isfinite(u):
            raise ValueError("rate_cmd must be finite")
        self.gamma, self.rate = _steering_step_scalar(
            self.gamma, self.rate, u, dt, self.tau, self.max_rate, self.max_angle
        )
        return self.gamma, self.rate

    def step_angle(self, gamma_cmd: float, dt: float) -> tuple[float, float]:
        """Servo to an angle set-point (rad): rate command ``(gamma_cmd - gamma) / tau_p``.

        ``tau_p = max(4 tau, dt)``: with the rate lag ``tau`` the loop
        ``tau s^2 + s + 1/tau_p`` is then critically damped (no overshoot).
        """
        if not math.isfinite(gamma_cmd):
            raise ValueError("gamma_cmd must be finite")
        target = float(np.clip(gamma_cmd, -self.max_angle, self.max_angle))
        return self.step_rate((target - self.gamma) / max(4.0 * self.tau, dt), dt)
