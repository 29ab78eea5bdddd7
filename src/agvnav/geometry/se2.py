"""Rigid motions of the plane, SE(2). A pose is ``(..., 3)``: ``[x, y, heading]``.

``compose(a, b)`` is the pose ``b`` (given in frame ``a``) expressed in the frame
``a`` is given in: world_T_body = compose(world_T_vehicle, vehicle_T_body).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry.angles import wrap_angle


def compose(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Compose poses ``a ⊕ b`` (both ``(..., 3)``, m and rad), broadcasting."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
    y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
    return np.stack([x, y, wrap_angle(a[..., 2] + b[..., 2])], axis=-1)


def inverse(a: ArrayLike) -> NDArray[np.float64]:
    """Inverse pose ``⊖a`` such that ``compose(a, inverse(a))`` is the identity."""
    a = np.asarray(a, dtype=np.float64)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = -c * a[..., 0] - s * a[..., 1]
    y = s * a[..., 0] - c * a[..., 1]
    return np.stack([x, y, wrap_angle(-a[..., 2])], axis=-1)


def between(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Relative pose ``⊖a ⊕ b``: pose ``b`` seen from frame ``a``."""
    return compose(inverse(a), b)


def transform_points(pose: ArrayLike, points: ArrayLike) -> NDArray[np.float64]:
    """Map body-frame points ``(..., 2)`` to the frame the pose ``(..., 3)`` is in."""
    pose = np.asarray(pose, dtype=np.float64)
    p = np.asarray(points, dtype=np.float64)
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    x = pose[..., 0] + c * p[..., 0] - s * p[..., 1]
    y = pose[..., 1] + s * p[..., 0] + c * p[..., 1]
    return np.stack([x, y], axis=-1)


def to_body(pose: ArrayLike, points: ArrayLike) -> NDArray[np.float64]:
    """Map points ``(..., 2)`` given in the pose's parent frame into the body frame."""
    pose = np.asarray(pose, dtype=np.float64)
    p = np.asarray(points, dtype=np.float64)
    dx = p[..., 0] - pose[..., 0]
    dy = p[..., 1] - pose[..., 1]
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    return np.stack([c * dx + s * dy, -s * dx + c * dy], axis=-1)


def bearing_to(pose: ArrayLike, points: ArrayLike) -> NDArray[np.float64]:
    """Bearing (rad, in [-pi, pi)) of ``points (..., 2)`` from the body x-axis, CCW positive."""
    pose = np.asarray(pose, dtype=np.float64)
    p = np.asarray(points, dtype=np.float64)
    absolute = np.arctan2(p[..., 1] - pose[..., 1], p[..., 0] - pose[..., 0])
    return wrap_angle(absolute - pose[..., 2])


def lateral_position_error(true_pose: ArrayLike, est_pose: ArrayLike) -> NDArray[np.float64]:
    """Position error of an estimate across the true heading (m), ``(...)`` from poses ``(..., 3)``.

    ``e_lat = -(x_e - x) sin(psi) + (y_e - y) cos(psi)``: the body-frame ``y`` of the
    estimate seen from the true pose (positive to the left, REP-103). Seed 000 measures
    positioning accuracy by this lateral component because the longitudinal one is
    dominated by the marker delay (seed 000 §4.2, Fig. 8).
    """
    p = np.asarray(true_pose, dtype=np.float64)
    q = np.asarray(est_pose, dtype=np.float64)
    dx, dy = q[..., 0] - p[..., 0], q[..., 1] - p[..., 1]
    return -dx * np.sin(p[..., 2]) + dy * np.cos(p[..., 2])
