"""Pose update from odometry increments: [seed002 eq20] (Euler), [seed002 eq25] (exact arc), [seed002 eq26] (midpoint).

``pose (..., 3)`` = ``[x, y, θ]``, increments ``ΔD`` (m, distance travelled by
the reference point along its path) and ``Δθ`` (rad), all broadcasting. The
returned heading is wrapped to [−π, π).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import wrap_angle

FloatArray = NDArray[np.float64]
RULES = ("arc", "midpoint", "euler")


def _check_rule(rule: str) -> None:
    if rule not in RULES:
        raise ValueError(f"rule must be one of {RULES}, got {rule!r}")


def _sinc(h: FloatArray) -> FloatArray:
    small = np.abs(h) < 1e-4
    safe = np.where(small, 1.0, h)
    return np.where(small, 1.0 - h * h / 6.0, np.sin(safe) / safe)


def _dsinc(h: FloatArray) -> FloatArray:
    """Derivative of ``sin(h)/h``."""
    small = np.abs(h) < 1e-4
    safe = np.where(small, 1.0, h)
    return np.where(small, -h / 3.0, (safe * np.cos(safe) - np.sin(safe)) / (safe * safe))


def _chord_and_heading(pose: FloatArray, dd: FloatArray, dth: FloatArray, rule: str) -> tuple[FloatArray, FloatArray]:
    """Length of the displacement and its direction for each rule (chord: [seed002 eq24])."""
    if rule == "euler":
        return dd + 0.0 * dth, pose[..., 2] + 0.0 * dth
    heading = pose[..., 2] + 0.5 * dth
    if rule == "midpoint":
        return dd + 0.0 * heading, heading
    return dd * _sinc(0.5 * dth), heading


def integrate_pose(pose: ArrayLike, delta_d: ArrayLike, delta_theta: ArrayLike, rule: str = "arc") -> FloatArray:
    """Dead-reckoned pose after one increment ``(ΔD, Δθ)``: ``f(X(k), U(k))`` of [seed002 eq14].

    ``rule="euler"``: ``x += ΔD cos θ`` ([seed002 eq20], translation then rotation).
    ``rule="arc"``: ``x += ΔD · sin(Δθ/2)/(Δθ/2) · cos(θ + Δθ/2)`` ([seed002 eq25], exact on arcs;
    the chord of [seed002 eq23] [seed002 eq24]).
    ``rule="midpoint"``: ``x += ΔD cos(θ + Δθ/2)`` [seed002 eq26]. Same for y with sin.
    """
    _check_rule(rule)
    pose = np.asarray(pose, dtype=np.float64)
    dd = np.asarray(delta_d, dtype=np.float64)
    dth = np.asarray(delta_theta, dtype=np.float64)
    chord, heading = _chord_and_heading(pose, dd, dth, rule)
    x = pose[..., 0] + chord * np.cos(heading)
    y = pose[..., 1] + chord * np.sin(heading)
    return np.stack([x, y, wrap_angle(pose[..., 2] + dth)], axis=-1)


def pose_jacobian(pose: ArrayLike, delta_d: ArrayLike, delta_theta: ArrayLike, rule: str = "arc") -> FloatArray:
    """``F = ∂pose'/∂pose`` ``(..., 3, 3)`` of ``integrate_pose``, for ``P' = F P Fᵀ + Q``."""
    _check_rule(rule)
    pose = np.asarray(pose, dtype=np.float64)
    dd, dth = np.asarray(delta_d, np.float64), np.asarray(delta_theta, np.float64)
    chord, heading = _chord_and_heading(pose, dd, dth, rule)
    F = np.zeros(chord.shape + (3, 3))
    F[..., 0, 0] = F[..., 1, 1] = F[..., 2, 2] = 1.0
    F[..., 0, 2] = -chord * np.sin(heading)
    F[..., 1, 2] = chord * np.cos(heading)
    return F


def increment_jacobian(pose: ArrayLike, delta_d: ArrayLike, delta_theta: ArrayLike, rule: str = "arc") -> FloatArray:
    """``G = ∂pose'/∂(ΔD, Δθ)`` ``(..., 3, 2)`` of ``integrate_pose`` (exact, including the chord's Δθ terms)."""
    _check_rule(rule)
    pose = np.asarray(pose, dtype=np.float64)
    dd = np.asarray(delta_d, dtype=np.float64)
    dth = np.asarray(delta_theta, dtype=np.float64)
    chord, heading = _chord_and_heading(pose, dd, dth, rule)
    c, s = np.cos(heading), np.sin(heading)
    if rule == "arc":
        h = 0.5 * dth
        d_len_dd, d_len_dth = _sinc(h), 0.5 * dd * _dsinc(h)
    else:
        d_len_dd, d_len_dth = np.ones_like(chord), np.zeros_like(chord)
    d_head_dth = 0.0 if rule == "euler" else 0.5
    G = np.zeros(chord.shape + (3, 2))
    G[..., 0, 0] = d_len_dd * c
    G[..., 1, 0] = d_len_dd * s
    G[..., 0, 1] = d_len_dth * c - chord * s * d_head_dth
    G[..., 1, 1] = d_len_dth * s + chord * c * d_head_dth
    G[..., 2, 1] = 1.0
    return G
