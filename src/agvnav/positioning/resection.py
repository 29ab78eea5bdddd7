"""Resection: the head pose from three simultaneous bearings of three known reflectors (seed 000 §2.2).

The geometric circle intersection on the relative angles ("arcos capaces", seed 000 §2.2,
Fig. 1b). It generates the start-up search's hypotheses
(:func:`agvnav.positioning.identification.initial_pose_search`), where no odometric
heading exists yet; the fixes of a moving vehicle use
:func:`agvnav.positioning.triangulate`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import angle_diff, wrap_angle

__all__ = ["resect_three"]


def resect_three(
    reflector_xy: ArrayLike, bearings: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Head pose from three simultaneous centre bearings (rad) of three known reflectors.

    Geometric circle intersection on the relative angles (seed 000 §2.2, Fig. 1b, the
    "arcos capaces" method): P lies on the circle through R1, R2 that sees them under
    ``alpha = theta2 - theta1`` and on the circle through R2, R3 under ``beta``; the two
    circles meet at R2 and at P, the mirror of R2 in the line of their centres. The heading
    is then the circular mean of ``atan2(R_i - P) - theta_i``. Used here only to generate
    start-up hypotheses (no odometric heading exists yet); the fixes of a moving vehicle use
    :func:`agvnav.positioning.triangulate`.

    ``reflector_xy (..., 3, 2)``, ``bearings (..., 3)`` -> ``(pose (..., 3), valid (...))``;
    invalid on the critical circle and for collinear, coincident or inconsistent data.
    """
    R = np.asarray(reflector_xy, dtype=np.float64)
    th = np.asarray(bearings, dtype=np.float64)
    c12 = _arc_centre(R[..., 0, :], R[..., 1, :], angle_diff(th[..., 1], th[..., 0]))
    c23 = _arc_centre(R[..., 1, :], R[..., 2, :], angle_diff(th[..., 2], th[..., 1]))
    u = c23 - c12
    uu = np.sum(u * u, axis=-1)
    scale = np.maximum(np.sum((R[..., 1, :] - R[..., 0, :]) ** 2, -1), 1e-300)
    valid = np.isfinite(uu) & (uu > 1e-10 * scale)
    safe = np.where(valid, uu, 1.0)
    t = np.sum((R[..., 1, :] - c12) * u, axis=-1) / safe
    foot = c12 + t[..., None] * u
    p = 2.0 * foot - R[..., 1, :]
    absolute = np.arctan2(R[..., 1] - p[..., None, 1], R[..., 0] - p[..., None, 0])
    diff = wrap_angle(absolute - th)
    heading = wrap_angle(np.arctan2(np.mean(np.sin(diff), -1), np.mean(np.cos(diff), -1)))
    spread = np.max(np.abs(angle_diff(diff, heading[..., None])), axis=-1)
    valid &= np.all(np.isfinite(p), axis=-1) & (spread < 1e-3)
    pose = np.concatenate([p, heading[..., None]], axis=-1)
    return np.where(valid[..., None], pose, np.nan), valid


def _arc_centre(a: NDArray[np.float64], b: NDArray[np.float64], angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Centre of the circle through ``a``, ``b`` from which chord ab is seen under ``angle`` (CCW)."""
    chord = b - a
    left = np.stack([-chord[..., 1], chord[..., 0]], axis=-1)
    sin_a = np.sin(angle)
    cot = np.cos(angle) / np.where(np.abs(sin_a) > 1e-12, sin_a, np.nan)
    return 0.5 * (a + b) + 0.5 * cot[..., None] * left
