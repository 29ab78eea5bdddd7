"""Angles: wrapping and differences. Every angle residual in agvnav goes through here."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def wrap_angle(angle: ArrayLike) -> NDArray[np.float64]:
    """Wrap angles (rad) to the half-open interval [-pi, pi).

    Vectorised over any shape; returns a float64 array (0-d for a scalar).
    """
    a = np.asarray(angle, dtype=np.float64)
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def angle_diff(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Smallest signed difference ``a - b`` (rad), in [-pi, pi)."""
    return wrap_angle(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64))


def deg2rad(degrees: ArrayLike) -> NDArray[np.float64]:
    """Degrees to radians, for the user's edge (CLI, scenario files)."""
    return np.deg2rad(np.asarray(degrees, dtype=np.float64))


def rad2deg(radians: ArrayLike) -> NDArray[np.float64]:
    """Radians to degrees, for the user's edge (tables, plots)."""
    return np.rad2deg(np.asarray(radians, dtype=np.float64))
