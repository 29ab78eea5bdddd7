"""Stateful dead-reckoning from encoder counts: pose and covariance, predict only."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_positive
from agvnav.odometry.covariance import OdometryNoise, propagate
from agvnav.odometry.increments import differential_increments, tricycle_increments
from agvnav.odometry.integrate import RULES
from agvnav.sensors.encoders import SteeringEncoder, WheelEncoder

FloatArray = NDArray[np.float64]


class _Odometer:
    def __init__(self, noise: OdometryNoise | None, rule: str, pose: ArrayLike, covariance: ArrayLike | None) -> None:
        if rule not in RULES:
            raise ValueError(f"rule must be one of {RULES}, got {rule!r}")
        self.noise = noise or OdometryNoise()
        self.rule = rule
        self.pose = require_finite("pose", pose).reshape(3).copy()
        self.covariance = np.zeros((3, 3)) if covariance is None else require_finite("covariance", covariance).copy()
        if self.covariance.shape != (3, 3):
            raise ValueError(f"covariance must have shape (3, 3), got {self.covariance.shape}")

    def _apply(self, delta_d: FloatArray | float, delta_theta: FloatArray | float) -> tuple[float, float]:
        self.pose, self.covariance = propagate(self.pose, self.covariance, delta_d, delta_theta, self.noise, self.rule)
        return float(delta_d), float(delta_theta)


class DifferentialOdometer(_Odometer):
    """Differential-drive odometer: cumulative wheel counts -> ``(ΔD, Δθ)`` [seed002 eq16] -> pose, P.

    The input of each step is ``U(k) = [ΔD, Δθ]`` [seed002 eq15]; the pose is their running
    sum from the start pose, the discrete form of [seed002 eq10]. The first ``update`` only
    latches the counts (no motion is assumed before it).
    """

    def __init__(self, right: WheelEncoder, left: WheelEncoder, track: float, noise: OdometryNoise | None = None,
                 rule: str = "arc", pose: ArrayLike = (0.0, 0.0, 0.0), covariance: ArrayLike | None = None) -> None:
        super().__init__(noise, rule, pose, covariance)
        self.right, self.left = right, left
        self.track = require_positive("track", track)
        self._last: tuple[int, int] | None = None

    def update(self, counts_right: int, counts_left: int) -> tuple[float, float]:
        """Integrate the counts since the previous call; returns the increment ``(ΔD, Δθ)``."""
        if self._last is None:
            self._last = (int(counts_right), int(counts_left))
            return 0.0, 0.0
        d_r = self.right.distance(int(counts_right) - self._last[0])
        d_l = self.left.distance(int(counts_left) - self._last[1])
        self._last = (int(counts_right), int(counts_left))
        return self._apply(*differential_increments(d_r, d_l, self.track))


class TricycleOdometer(_Odometer):
    """Tricycle (seed-000 stacker) odometer: traction counts of C and steering readings -> increments of O.

    ``ΔD = ds_C cos γ_m``, ``Δθ = ds_C sin γ_m / L`` with γ_m the mean of the
    steering readings at both ends of the step.
    """

    def __init__(self, traction: WheelEncoder, steering: SteeringEncoder, wheelbase: float,
                 noise: OdometryNoise | None = None, rule: str = "arc", pose: ArrayLike = (0.0, 0.0, 0.0),
                 covariance: ArrayLike | None = None) -> None:
        super().__init__(noise, rule, pose, covariance)
        self.traction, self.steering = traction, steering
        self.wheelbase = require_positive("wheelbase", wheelbase)
        self._last: tuple[int, float] | None = None

    def update(self, traction_counts: int, steering_counts: int) -> tuple[float, float]:
        """Integrate since the previous call; returns ``(ΔD, Δθ)`` of O."""
        gamma = float(self.steering.angle(steering_counts))
        if self._last is None:
            self._last = (int(traction_counts), gamma)
            return 0.0, 0.0
        ds = float(self.traction.distance(int(traction_counts) - self._last[0]))
        gamma_mid = 0.5 * (gamma + self._last[1])
        self._last = (int(traction_counts), gamma)
        return self._apply(*tricycle_increments(ds, gamma_mid, self.wheelbase))
