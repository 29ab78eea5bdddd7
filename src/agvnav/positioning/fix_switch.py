"""Which fix to form: relative angles, or absolute angles with the odometric heading held (seed 000 §2.3, §5).

Relative-angle triangulation is indeterminate on the circle through the reflectors
(:func:`near_critical_circle`, seed 000 §2.2); seed 000 §5 switches between the methods on
their predicted error (:func:`predicted_position_variances`); the absolute-angle
construction with the heading held (:func:`fix_given_heading`, seed 000 §2.3) is the
alternative. :class:`agvnav.positioning.dynamic.AnglePropagationEstimator` makes the choice.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import circumcentre
from agvnav.positioning.bounds import fisher_information

__all__ = ["fix_given_heading", "near_critical_circle", "predicted_position_variances"]


def near_critical_circle(reflector_xy: ArrayLike, head_xy: ArrayLike, margin: float) -> bool:
    """True when P lies within ``margin`` (relative to the radius) of the circle through three reflectors.

    ``reflector_xy (3, 2)``, ``head_xy (2,)`` (m). Collinear reflectors (no circle) give False.
    Seed 000 §2.2: the relative-angle triangulation is indeterminate on that circle.
    """
    centre, valid = circumcentre(*np.asarray(reflector_xy, dtype=np.float64))
    if not valid:
        return False
    radius = np.hypot(*(np.asarray(reflector_xy)[0] - centre))
    return bool(abs(np.hypot(*(np.asarray(head_xy) - centre)) - radius) < margin * radius)


def predicted_position_variances(
    reflector_xy: ArrayLike, head_pose: ArrayLike, bearing_std: float, heading_std: float
) -> tuple[float, float]:
    """Predicted position variance (m², trace of the x-y block) of the two methods at a head pose.

    Seed 000 §5 plans to "alternate the absolute and the relative methods according to the
    error associated with the goniometer's angular resolution" [seed000 §5]. The two
    predictions, from the linearised bearings ``J`` (``(3, 3)`` Fisher information
    ``J^T J / sigma^2``, blocks ``A`` (x-y) and ``b`` (x-y with heading)):

    * relative (three bearings only, heading from them): ``(J^T J / sigma^2)^-1``, which
      grows without bound near the critical circle [seed000 §2.2];
    * absolute with the odometric heading held [seed000 §2.3]: ``A^-1 + g g^T heading_std^2``
      with ``g = -A^-1 b`` (the position error a heading error causes).

    ``reflector_xy (3, 2)`` m, ``head_pose (3,)`` (m, m, rad), stds in rad. Returns
    ``(relative, absolute)``; ``inf`` where a prediction is singular.
    """
    info = fisher_information(np.asarray(reflector_xy, dtype=np.float64), np.asarray(head_pose, dtype=np.float64),
                              float(bearing_std))
    a, b = info[:2, :2], info[:2, 2]
    relative = float(np.trace(np.linalg.inv(info)[:2, :2])) if np.linalg.cond(info) < 1e12 else math.inf
    if np.linalg.cond(a) >= 1e12:
        return relative, math.inf
    a_inv = np.linalg.inv(a)
    g = -a_inv @ b
    return relative, float(np.trace(a_inv) + heading_std**2 * float(g @ g))


def fix_given_heading(
    reflector_xy: ArrayLike, bearings: ArrayLike, heading: float, weights: ArrayLike | None = None
) -> NDArray[np.float64] | None:
    """Head position (m) from the lines of absolute angle ``heading + theta_i`` through each reflector.

    The absolute-angle construction with the heading held at ``heading`` [seed000 §2.3]:
    the weighted least-squares intersection of the lines (``weights (n,)``, default 1);
    None when the lines are (nearly) parallel.
    """
    xy = np.asarray(reflector_xy, dtype=np.float64)
    phi = heading + np.asarray(bearings, dtype=np.float64)
    normal = np.column_stack([-np.sin(phi), np.cos(phi)])
    w = np.ones(len(phi)) if weights is None else np.asarray(weights, dtype=np.float64)
    lhs = normal.T @ (normal * w[:, None])
    if np.linalg.cond(lhs) >= 1e12:
        return None
    rhs = normal.T @ (w * np.sum(normal * xy, axis=1))
    return np.asarray(np.linalg.solve(lhs, rhs), dtype=np.float64)
