"""Incremental wheel/traction encoders and the absolute steering encoder (seed 002 §3, seed 000 §4.1).

An incremental encoder counts whole pulses: the cumulative count is
``floor(angle · counts_per_rev / 2π)``, so the quantisation error of an
increment is within one count. Distances follow from the wheel radius
(``distance = angle · r``). The steering encoder of the seed-000 stacker reads
the steering angle γ absolutely, rounded to the nearest count.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import as_float_array, require_finite, require_positive

TWO_PI = 2.0 * np.pi


def _check_cpr(counts_per_rev: int) -> int:
    if isinstance(counts_per_rev, bool) or int(counts_per_rev) != counts_per_rev or counts_per_rev < 1:
        raise ValueError(f"counts_per_rev must be a positive integer, got {counts_per_rev!r}")
    return int(counts_per_rev)


class WheelEncoder:
    """Incremental encoder on a wheel (or the traction wheel of a tricycle).

    Parameters
    ----------
    counts_per_rev : pulses per revolution of the encoder shaft (after any x4 decoding), >= 1.
    wheel_radius : nominal wheel radius r (m), > 0; the odometry's belief, not the truth.
    gear_ratio : encoder-shaft revolutions per wheel revolution (> 0), 1 for an encoder on the wheel.
    """

    def __init__(self, counts_per_rev: int, wheel_radius: float, gear_ratio: float = 1.0) -> None:
        self.counts_per_rev = _check_cpr(counts_per_rev)
        self.wheel_radius = require_positive("wheel_radius", wheel_radius)
        self.gear_ratio = require_positive("gear_ratio", gear_ratio)

    @property
    def counts_per_wheel_rev(self) -> float:
        """Counts per wheel revolution."""
        return self.counts_per_rev * self.gear_ratio

    @property
    def angle_resolution(self) -> float:
        """Wheel angle of one count (rad)."""
        return TWO_PI / self.counts_per_wheel_rev

    @property
    def distance_resolution(self) -> float:
        """Rolled distance of one count (m) at the nominal radius."""
        return self.angle_resolution * self.wheel_radius

    def counts(self, wheel_angle: ArrayLike) -> NDArray[np.int64]:
        """Cumulative count (int64, same shape) for the true cumulative wheel angle (rad): ``floor(φ/res)``."""
        phi = require_finite("wheel_angle", wheel_angle)
        return np.floor(phi / self.angle_resolution + 1e-9).astype(np.int64)

    def angle(self, counts: ArrayLike) -> NDArray[np.float64]:
        """Wheel angle (rad) of a (cumulative or incremental) count."""
        return as_float_array("counts", counts) * self.angle_resolution

    def distance(self, counts: ArrayLike) -> NDArray[np.float64]:
        """Rolled distance (m) of a count at the nominal radius (the inputs ΔD_R, ΔD_L of [seed002 eq16])."""
        return self.angle(counts) * self.wheel_radius

    def counts_for_distance(self, distance: ArrayLike) -> NDArray[np.int64]:
        """Cumulative count for a rolled distance (m) at the nominal radius."""
        return self.counts(require_finite("distance", distance) / self.wheel_radius)

    def quantisation_std(self) -> float:
        """Std (m) of the distance quantisation of one reading, ``resolution/√12`` (uniform error)."""
        return self.distance_resolution / np.sqrt(12.0)


class SteeringEncoder:
    """Absolute encoder on the steering axis (seed 000 §4.1 "encoder de dirección").

    Parameters
    ----------
    counts_per_rev : counts per steering-axis revolution, >= 1.
    offset : angle (rad) read as count 0: a mounting/calibration error the truth may carry.
    """

    def __init__(self, counts_per_rev: int, offset: float = 0.0) -> None:
        self.counts_per_rev = _check_cpr(counts_per_rev)
        off = float(offset)
        if not np.isfinite(off):
            raise ValueError(f"offset must be finite, got {offset!r}")
        self.offset = off

    @property
    def resolution(self) -> float:
        """Angle of one count (rad)."""
        return TWO_PI / self.counts_per_rev

    def counts(self, steering_angle: ArrayLike) -> NDArray[np.int64]:
        """Reading (int64) for the true steering angle (rad), rounded to the nearest count."""
        g = require_finite("steering_angle", steering_angle)
        return np.rint((g - self.offset) / self.resolution).astype(np.int64)

    def angle(self, counts: ArrayLike) -> NDArray[np.float64]:
        """Steering angle (rad) the odometry infers from a reading (nominal: zero offset)."""
        return as_float_array("counts", counts) * self.resolution


def wheel_count(wheel_angle: float, resolution: float) -> int:
    """Scalar fast path of :meth:`WheelEncoder.counts`: ``floor(phi / res + 1e-9)`` for one angle (rad).

    ``resolution`` is :attr:`WheelEncoder.angle_resolution` (rad per count). Same
    arithmetic as the vectorised method without NumPy's per-call overhead, for the
    simulator's per-step loop (``tests/sensors/test_encoders_fast.py`` checks equality).
    A NaN/inf angle raises a ValueError naming ``wheel_angle``, like the method.
    """
    if not math.isfinite(wheel_angle):
        raise ValueError("wheel_angle contains NaN or inf")
    return math.floor(wheel_angle / resolution + 1e-9)


def steering_reading(angle: float, offset: float, resolution: float) -> float:
    """Scalar fast path of ``SteeringEncoder.angle(SteeringEncoder.counts(angle))`` (rad).

    ``rint((angle - offset) / res) * res`` with ``offset`` and ``resolution`` those of the
    :class:`SteeringEncoder`; Python's ``round`` rounds half to even like ``np.rint``.
    A NaN/inf angle raises a ValueError naming ``steering_angle``, like the method.
    """
    if not math.isfinite(angle):
        raise ValueError("steering_angle contains NaN or inf")
    return round((angle - offset) / resolution) * resolution
