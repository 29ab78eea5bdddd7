"""Bearings taken at different instants brought to one configuration of the robot (seeds 000 §2.2, 001 §2).

A rotating head sees each reflector at its own instant while the vehicle moves, so
"the angles theta_i must be known for one and the same configuration of the robot"
(seed 000 §2.2). :func:`centre_bearings` moves the reported leading-edge bearings to the
reflector centres; :func:`propagate_bearings` is the seeds' angle propagation (each
relative angle carried from its reflection to the fix instant by the kinematics and the
odometry); :func:`batch_ml_fix` solves every bearing of a revolution jointly for the
pose at the fix instant, the maximum-likelihood fix when odometry over one revolution is
taken as exact. The estimators that use them are in :mod:`agvnav.positioning.dynamic`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import angle_diff, between, compose, wrap_angle
from agvnav.positioning.edge_bearing import bearing_model, edge_offset

__all__ = ["batch_ml_fix", "centre_bearings", "ml_system", "propagate_bearings"]


def centre_bearings(
    edge_bearing: ArrayLike, pose: ArrayLike, mount: ArrayLike, reflector_xy: ArrayLike, radius: ArrayLike
) -> NDArray[np.float64]:
    """Reported leading-edge bearings (rad) moved to the reflector centres, ``+asin(r/d)``.

    The distance d is taken from the (predicted) base_link ``pose (..., 3)`` at the
    reflection; an error of a few cm in d changes the correction by ``r * dd / d^2``,
    i.e. micro-radians (seed 000 §2.1: the angle is read at the start of the reflection).
    """
    _, _, d = bearing_model(pose, mount, reflector_xy, radius)
    return wrap_angle(np.asarray(edge_bearing, dtype=np.float64) - edge_offset(d, radius))


def propagate_bearings(
    bearings: ArrayLike,
    odom_at_reflection: ArrayLike,
    odom_at_fix: ArrayLike,
    pose_at_fix: ArrayLike,
    mount: ArrayLike,
    reflector_xy: ArrayLike,
) -> NDArray[np.float64]:
    """Bring centre bearings measured at instants t_i to the fix instant t_f (seed 000 §2.2, [7]).

    The vehicle's motion from t_i to t_f is the odometric relative motion
    ``between(odom_f, odom_i)``; composing it with the pose at the fix gives the pose at
    t_i, and the reflector's relative angle changes by the kinematic prediction

        theta_i(t_f) = theta_i(t_i) + [h(x_f, R_i) - h(x_i, R_i)],

    with ``h`` the head-frame centre bearing. The correction is exact when the odometry
    is exact and ``pose_at_fix`` is right; callers iterate it with the new fix (a fixed
    point, since the correction's sensitivity to the pose error is second order).

    Shapes: ``bearings (..., n)``, ``odom_at_reflection (..., n, 3)``, ``odom_at_fix (..., 3)``,
    ``pose_at_fix (..., 3)``, ``reflector_xy (..., n, 2)``; returns ``(..., n)`` (rad).
    """
    x_f = np.asarray(pose_at_fix, dtype=np.float64)[..., None, :]
    rel = between(np.asarray(odom_at_fix, dtype=np.float64)[..., None, :], odom_at_reflection)
    x_i = compose(x_f, rel)
    h_f, _, _ = bearing_model(x_f, mount, reflector_xy, 0.0)
    h_i, _, _ = bearing_model(x_i, mount, reflector_xy, 0.0)
    return wrap_angle(np.asarray(bearings, dtype=np.float64) + angle_diff(h_f, h_i))


def batch_ml_fix(
    pose0: ArrayLike,
    bearings: ArrayLike,
    reflector_xy: ArrayLike,
    radius: ArrayLike,
    relative_motion: ArrayLike,
    mount: ArrayLike,
    bearing_var: ArrayLike,
    iterations: int = 10,
) -> tuple[NDArray[np.float64], NDArray[np.float64], bool]:
    """Joint Gauss-Newton fix of the pose at t_f from bearings taken at their own instants.

    Unknown ``x_f``; the pose at reflection i is ``x_i = x_f ⊕ d_i`` with ``d_i`` the
    odometric motion from t_f back to t_i (``relative_motion (n, 3)``). Minimises
    ``sum_i wrap(z_i - h(x_i, R_i))^2 / sigma^2`` with ``h`` the leading-edge bearing
    (:func:`~agvnav.positioning.edge_bearing.bearing_model`), Jacobian
    ``dh/dx_f = H_i J_i``, ``J_i = d(x_f ⊕ d_i)/dx_f``.

    ``bearings (n,)`` edge bearings (rad), ``reflector_xy (n, 2)``, ``radius (n,)``,
    ``bearing_var`` scalar or ``(n,)`` variances (rad²) weighting each residual.
    Returns ``(pose (3,), covariance (3, 3), valid)``; invalid when the normal matrix is
    singular (fewer than three independent directions) or the iteration diverges.
    """
    x = np.array(pose0, dtype=np.float64)
    z = np.asarray(bearings, dtype=np.float64)
    rel = np.asarray(relative_motion, dtype=np.float64)
    w = 1.0 / np.broadcast_to(np.asarray(bearing_var, dtype=np.float64), z.shape)
    for _ in range(iterations):
        A, r = ml_system(x, z, reflector_xy, radius, rel, mount)
        N = A.T @ (A * w[:, None])
        if np.linalg.cond(N) > 1e12:
            return x, np.full((3, 3), np.nan), False
        step = np.linalg.solve(N, A.T @ (r * w))
        x = x + step
        x[2] = wrap_angle(x[2])
        if np.max(np.abs(step)) < 1e-10:
            break
    A, r = ml_system(x, z, reflector_xy, radius, rel, mount)
    cov = np.linalg.inv(A.T @ (A * w[:, None]))
    valid = bool(np.all(np.isfinite(x)) and np.max(np.abs(r)) < 0.5)
    return x, 0.5 * (cov + cov.T), valid


def ml_system(
    x: NDArray[np.float64],
    z: NDArray[np.float64],
    xy: ArrayLike,
    radius: ArrayLike,
    rel: NDArray[np.float64],
    mount: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The batch fix's linear system at ``x (3,)``: Jacobian ``(n, 3)`` with respect to ``x_f``, residuals ``(n,)``.

    ``z (n,)`` edge bearings (rad), ``xy (n, 2)``, ``radius (n,)`` (m), ``rel (n, 3)`` the
    odometric motion from t_f back to each t_i; see :func:`batch_ml_fix`.
    """
    x_i = compose(x, rel)
    h, H, _ = bearing_model(x_i, mount, xy, radius)
    c, s = np.cos(x[2]), np.sin(x[2])
    J = np.zeros((rel.shape[0], 3, 3))
    J[:, 0, 0] = J[:, 1, 1] = J[:, 2, 2] = 1.0
    J[:, 0, 2] = -s * rel[:, 0] - c * rel[:, 1]
    J[:, 1, 2] = c * rel[:, 0] - s * rel[:, 1]
    return np.einsum("ni,nij->nj", H, J), angle_diff(z, h)
