"""Data association of anonymous reflections: gate each bearing on the predicted bearings of the known reflectors.

A reflection is associated with the reflector whose predicted leading-edge bearing
([seed000 §2.1], :func:`agvnav.mapping.graph.bearing_prediction`) is nearest, if the
innovation is inside the gate ``n_sigma · σ_β + atan(position_tol / d)`` (the bearing
noise plus the uncertainty of the head position at range ``d``), the reflector is within
the head's range, and no second reflector falls inside its own gate (ambiguous
reflections are left out rather than guessed). The rest are candidates for new
reflectors (:mod:`agvnav.mapping.initialise`) or spurious.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import wrap_angle

__all__ = ["associate", "head_poses", "predicted_edge_bearings", "ray_covariances"]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


def head_poses(keyframe_poses: F64, keyframe: I64, offset: F64, mount: F64, scale: float = 1.0,
               offset_dist: F64 | None = None, calibration: tuple[float, float] = (0.0, 0.0),
               alpha: F64 | None = None) -> F64:
    """Head poses ``(B, 3)`` in map of reflections hanging on ``keyframe (B,)`` with odometry ``offset (B, 3)``.

    ``X(k) ∘ [s u_t, w_ψ] ∘ mount`` (m, m, rad) with ``w_ψ = (1 + b) u_ψ + κ u_D``: ``calibration = (κ, b)``
    the odometry's heading rate (rad/m) and turn scale, ``offset_dist (B,)`` the distance ``u_D`` rolled (m).
    ``alpha (B,)``: interpolated between ``X(k)`` and ``X(k+1)`` as the graph's bearing factor
    (:class:`agvnav.mapping.graph.BearingFactors`; ``offset`` is then ``u − α z``).
    """
    X = keyframe_poses[keyframe]
    u = offset.copy()
    kappa, b = calibration
    if offset_dist is not None and (kappa or b):
        u[:, 2] = (1.0 + b) * u[:, 2] + kappa * offset_dist
    px, py = X[:, 0], X[:, 1]
    if alpha is not None:
        Xn = keyframe_poses[keyframe + 1]
        u[:, 2] += alpha * wrap_angle(Xn[:, 2] - X[:, 2])
        px = px + alpha * (Xn[:, 0] - X[:, 0])
        py = py + alpha * (Xn[:, 1] - X[:, 1])
    cu, su = np.cos(u[:, 2]), np.sin(u[:, 2])
    wx = scale * u[:, 0] + cu * mount[0] - su * mount[1]
    wy = scale * u[:, 1] + su * mount[0] + cu * mount[1]
    c, s = np.cos(X[:, 2]), np.sin(X[:, 2])
    return np.column_stack([px + c * wx - s * wy, py + s * wx + c * wy, X[:, 2] + u[:, 2] + mount[2]])


def predicted_edge_bearings(heads: F64, reflectors: F64, radius: float, direction: int = 1) -> tuple[F64, F64]:
    """Predicted leading-edge bearings ``(B, N)`` (rad, head frame) and distances ``(B, N)`` (m)."""
    dx = reflectors[None, :, 0] - heads[:, None, 0]
    dy = reflectors[None, :, 1] - heads[:, None, 1]
    d = np.hypot(dx, dy)
    ratio = np.clip(radius / np.maximum(d, 1e-12), 0.0, 0.999999)
    beta = wrap_angle(np.arctan2(dy, dx) - heads[:, None, 2] - direction * np.arcsin(ratio))
    return beta, d


def associate(bearings: F64, heads: F64, reflectors: F64, radius: float, sigma: F64 | float,
              n_sigma: float = 5.0, position_tol: float = 0.05, max_range: float = 30.0,
              direction: int = 1, landmark_cov: F64 | None = None) -> I64:
    """Reflector index ``(B,)`` of each reflection, ``-1`` when none or more than one is inside the gate.

    Parameters
    ----------
    bearings : (B,) measured bearings (rad, head frame).
    heads : (B, 3) head poses in map at the measurement instants.
    reflectors : (N, 2) reflector centres (m).
    radius : reflector radius (m).
    sigma : bearing std (rad), scalar or (B,).
    n_sigma, position_tol : gate ``n_sigma·σ + atan(position_tol / d)`` (rad; m).
    max_range : reflectors farther than this (m) are not candidates.
    landmark_cov : (N, 2, 2) covariance of each reflector centre (m²), or None; its
        bearing variance ``gᵀ C g`` (``g = [−δy, δx]/d²``) joins ``σ²`` inside the gate.
    """
    B = bearings.shape[0]
    if reflectors.shape[0] == 0 or B == 0:
        return np.full(B, -1, dtype=np.int64)
    beta, d = predicted_edge_bearings(heads, reflectors, radius, direction)
    innov = np.abs(wrap_angle(bearings[:, None] - beta))
    sig2 = np.broadcast_to(np.asarray(sigma, dtype=np.float64), (B,))[:, None] ** 2
    if landmark_cov is not None:
        dx = reflectors[None, :, 0] - heads[:, None, 0]
        dy = reflectors[None, :, 1] - heads[:, None, 1]
        d2 = np.maximum(d * d, 1e-12)
        gx, gy = -dy / d2, dx / d2
        C = landmark_cov
        sig2 = sig2 + gx * gx * C[None, :, 0, 0] + 2.0 * gx * gy * C[None, :, 0, 1] + gy * gy * C[None, :, 1, 1]
    gate = n_sigma * np.sqrt(sig2) + np.arctan2(position_tol, np.maximum(d, 1e-6))
    inside = (innov <= gate) & (d <= max_range) & (d > radius)
    score = np.where(inside, innov / gate, np.inf)
    best = np.argmin(score, axis=1)
    n_inside = inside.sum(axis=1)
    return np.where(n_inside == 1, best, -1).astype(np.int64)


def ray_covariances(heads: F64, assoc: I64, reflectors: F64, sigma: float, prior_cov: F64 | None = None) -> F64:
    """Covariance ``(N, 2, 2)`` (m²) of each reflector from its associated bearings alone (poses held fixed).

    The information ``Σ g gᵀ / σ²`` (``g = [−δy, δx]/d²``, the bearing's gradient in the centre) of the
    reflections with ``assoc == j``, plus the inverse of ``prior_cov[j]`` where given; a reflector
    with too little information gets a 1 m² (per axis) covariance.
    """
    N = reflectors.shape[0]
    info = np.zeros((N, 2, 2))
    ok = assoc >= 0
    if np.any(ok):
        a = assoc[ok]
        dx = reflectors[a, 0] - heads[ok, 0]
        dy = reflectors[a, 1] - heads[ok, 1]
        d2 = np.maximum(dx * dx + dy * dy, 1e-12)
        g = np.column_stack([-dy / d2, dx / d2]) / sigma
        np.add.at(info, a, g[:, :, None] * g[:, None, :])
    if prior_cov is not None:
        info[: prior_cov.shape[0]] += np.linalg.inv(prior_cov)
    info += np.eye(2) * 1.0  # 1 m² per axis: a reflector seen along one line only stays uncertain
    return np.asarray(np.linalg.inv(info))
