"""PID speed controller per motor (seed 004, §II: Kp = 10, Ki = 20, Kd = 0.5).

Seed 004 closes a PID speed loop around each track motor with hand-tuned
gains. The seed gives no detail beyond the gains, so the implementation makes
the usual industrial choices and says so:

* parallel form ``u = Kp e + Ki ∫e dt - Kd d(y_f)/dt`` with ``e = r - y``;
* derivative on the *measurement* (no derivative kick on set-point steps),
  low-pass filtered with time constant ``derivative_tau`` (first order, exact
  discretisation) so encoder quantisation is not amplified;
* output saturation to ``[u_min, u_max]`` (the driver's supply voltage) with
  anti-windup by conditional integration (clamping): the integrator does not
  integrate when the output is saturated and the error would push it further.

Vectorised: one object holds ``n`` independent loops (both tracks at once).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_nonnegative, require_positive

SEED_004_GAINS = (10.0, 20.0, 0.5)  # Kp (V s/rad), Ki (V/rad), Kd (V s^2/rad)


@dataclass
class PID:
    """Discrete PID with derivative on measurement and clamping anti-windup.

    Parameters
    ----------
    kp, ki, kd : gains (seed 004 defaults 10, 20, 0.5); units of output per
        unit error, per unit error·s and per unit error/s.
    u_min, u_max : output saturation (e.g. ±12 V).
    derivative_tau : derivative filter time constant (s); 0 disables filtering.
    anti_windup : False integrates unconditionally (kept to show the windup).
    size : number of independent loops.
    """

    kp: float = SEED_004_GAINS[0]
    ki: float = SEED_004_GAINS[1]
    kd: float = SEED_004_GAINS[2]
    u_min: float = -12.0
    u_max: float = 12.0
    derivative_tau: float = 0.02
    anti_windup: bool = True
    size: int = 2
    integral: NDArray[np.float64] = field(init=False)
    y_filtered: NDArray[np.float64] = field(init=False)
    u: NDArray[np.float64] = field(init=False)
    _primed: bool = field(init=False, default=False)

    def __post_init__(self) -> None:
        for name in ("kp", "ki", "kd", "derivative_tau"):
            require_nonnegative(name, getattr(self, name))
        if not (math.isfinite(self.u_min) and math.isfinite(self.u_max)) or self.u_min >= self.u_max:
            raise ValueError(f"need finite u_min < u_max, got {self.u_min!r}, {self.u_max!r}")
        if int(self.size) < 1:
            raise ValueError(f"size must be >= 1, got {self.size!r}")
        self.reset()

    @property
    def primed(self) -> bool:
        """True once a measurement has been filtered (the derivative term is live from the next update)."""
        return self._primed

    def reset(self) -> None:
        """Zero the integrator and forget the derivative history."""
        self.integral = np.zeros(self.size)
        self.y_filtered = np.zeros(self.size)
        self.u = np.zeros(self.size)
        self._primed = False

    def update(self, setpoint: ArrayLike, measurement: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Output ``(size,)`` for set-point and measurement ``(size,)`` after ``dt`` s."""
        require_positive("dt", dt)
        r = require_finite("setpoint", setpoint) * np.ones(self.size)
        y = require_finite("measurement", measurement) * np.ones(self.size)
        derivative = self._measurement_rate(y, dt)
        e = r - y
        candidate = self.integral + e * dt
        u_free = self.kp * e + self.ki * candidate - self.kd * derivative
        u = np.clip(u_free, self.u_min, self.u_max)
        if self.anti_windup:
            pushing = ((u_free > self.u_max) & (e > 0)) | ((u_free < self.u_min) & (e < 0))
            self.integral = np.where(pushing, self.integral, candidate)
        else:
            self.integral = candidate
        self.u = u
        return u.copy()

    def _measurement_rate(self, y: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
        """Filtered d(y)/dt: first-order low-pass of y, differenced (exact ZOH filter)."""
        if not self._primed:
            self.y_filtered, self._primed = y.copy(), True
            return np.zeros_like(y)
        alpha = 1.0 if self.derivative_tau == 0.0 else -math.expm1(-dt / self.derivative_tau)
        previous = self.y_filtered
        self.y_filtered = previous + alpha * (y - previous)
        return (self.y_filtered - previous) / dt
