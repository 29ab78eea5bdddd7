"""Brushed DC gearmotors of the tracked robot: first-order model, left/right asymmetry.

Seed 004 (§II) drives each track with a 12 V, 45 rpm brushed DC gearmotor and
blames the drift partly on the two motors not behaving alike. Model (the
electrical time constant is neglected, as usual for a gearmotor):

    tau * omega' = K * (1 ± epsilon/2) * u - omega,    |u| <= u_max

with ``omega`` the output-shaft (sprocket) speed in rad/s, ``u`` the applied
voltage, ``K`` the static gain (rad/s per V) and ``epsilon`` the asymmetry: the
right motor gets ``1 + epsilon/2``, the left ``1 - epsilon/2``. The default gain
makes 12 V give 45 rpm (seed 004). The time constant 0.1 s is an assumption.
Discretised exactly for a voltage held over the step (zero-order hold).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_positive

RPM = 2.0 * math.pi / 60.0
SEED_004_NO_LOAD_SPEED = 45.0 * RPM  # rad/s at 12 V (seed 004, §II)
SEED_004_VOLTAGE = 12.0  # V


def motor_step(
    omega: ArrayLike, u: ArrayLike, dt: float, tau: ArrayLike, gain: ArrayLike
) -> NDArray[np.float64]:
    """Shaft speed (rad/s) after ``dt`` s of voltage ``u`` (V); broadcast over ``(...)``.

    Exact solution of ``tau omega' = gain u - omega`` with ``u`` held constant.
    """
    w = np.asarray(omega, dtype=np.float64)
    steady = np.asarray(gain, dtype=np.float64) * np.asarray(u, dtype=np.float64)
    decay = np.exp(-dt / np.asarray(tau, dtype=np.float64))
    return steady + (w - steady) * decay


@dataclass
class MotorPair:
    """Right and left track motors; arrays are ordered ``[right, left]``.

    Parameters
    ----------
    tau : mechanical time constant (s). gain : static gain (rad/s per V).
    asymmetry : epsilon, relative gain difference right minus left (e.g. 0.02).
    u_max : supply voltage, the saturation of the driver (V).
    """

    tau: float = 0.1
    gain: float = SEED_004_NO_LOAD_SPEED / SEED_004_VOLTAGE
    asymmetry: float = 0.0
    u_max: float = SEED_004_VOLTAGE
    omega: NDArray[np.float64] = field(default_factory=lambda: np.zeros(2))

    def __post_init__(self) -> None:
        require_positive("tau", self.tau)
        require_positive("gain", self.gain)
        require_positive("u_max", self.u_max)
        if not math.isfinite(self.asymmetry) or abs(self.asymmetry) >= 2.0:
            raise ValueError(f"asymmetry must be finite with |asymmetry| < 2, got {self.asymmetry!r}")
        self.omega = require_finite("omega", self.omega).reshape(2).copy()

    @property
    def gains(self) -> NDArray[np.float64]:
        """Per-motor static gains ``[right, left]`` (rad/s per V)."""
        e = self.asymmetry / 2.0
        return self.gain * np.array([1.0 + e, 1.0 - e])

    def reset(self, omega: ArrayLike = (0.0, 0.0)) -> None:
        """Set both shaft speeds (rad/s)."""
        self.omega = require_finite("omega", omega).reshape(2).copy()

    def step(self, u: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Apply voltages ``u = [u_right, u_left]`` (V, clipped to ±u_max) for ``dt`` s."""
        require_positive("dt", dt)
        volts = np.clip(require_finite("u", u).reshape(2), -self.u_max, self.u_max)
        self.omega = motor_step(self.omega, volts, dt, self.tau, self.gains)
        return self.omega.copy()
