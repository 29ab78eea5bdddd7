"""The SE(2) exponential of a constant body twist, written once as compiled kernels (issues 27, 28).

:func:`twist_pose` is the equation [seed002 eq25] (the arc of a constant twist; the SE(2)
exponential when ``v_y != 0``); everything that moves a pose by a constant twist calls it:
the batch form :func:`agvnav.kinematics.twist_step` (over broadcast arrays), the truth plants'
sub-steps and their ``pose_at`` (:func:`twist_table_poses`), and a fleet's true motion over a
step (:func:`fleet_twist_poses`: every vehicle's motion held in arrays, any vehicle at any
instant of the step in one compiled call). :func:`twist_log` is its inverse (the constant twist
that joins two poses), with which a fleet turns sampled poses into its motion table.

A motion table is a step from ``t0`` (s) cut into ``n`` sub-steps of ``h`` (s): the poses at the
sub-step boundaries ``states (n + 1, 3)`` and each sub-step's body twist ``twists (n, 3)``
``[v_x, v_y, omega]`` (m/s, rad/s). Its pose at ``t`` is the exponential of the twist of the
sub-step holding ``t`` for the time elapsed in it, ``t`` clipped to the step: exact for a motion
whose twist is constant inside each sub-step.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._jit import jit

__all__ = ["TwistPoses", "fleet_twist_poses", "fleet_twist_tables", "twist_log", "twist_pose", "twist_steps",
           "twist_table_pose", "twist_table_poses"]

#: Below this half angle (rad) ``sin(h)/h`` is its series ``1 - h^2/6`` (error below 1e-17).
SINC_SERIES_BELOW = 1e-4


@jit
def twist_pose(x: float, y: float, th: float, vx: float, vy: float, w: float, h: float) -> tuple[float, float, float]:
    """Exact pose after ``h`` s of a constant body twist ``(vx, vy, w)`` (m/s, rad/s) from ``(x, y, th)`` (m, rad).

    The SE(2) exponential: ``[x', y'] = [x, y] + sinc(dth/2) R(th + dth/2) [vx h, vy h]``,
    ``th' = th + dth``, ``dth = w h``, ``sinc(a) = sin(a)/a``; with ``vy = 0`` the chord
    ``ΔD sin(Δθ/2)/(Δθ/2)`` along the mid heading [seed002 eq25] [seed002 eq23] [seed002 eq24].
    The series ``1 - a^2/6`` below :data:`SINC_SERIES_BELOW` keeps straight lines exact. The
    heading is not wrapped (integrators keep it continuous).
    """
    dth = w * h
    half = 0.5 * dth
    sinc = 1.0 - half * half / 6.0 if abs(half) < 1e-4 else math.sin(half) / half
    mid = th + half
    fwd, lat = sinc * vx * h, sinc * vy * h
    c, s = math.cos(mid), math.sin(mid)
    return x + c * fwd - s * lat, y + s * fwd + c * lat, th + dth


@jit
def twist_log(x0: float, y0: float, th0: float, x1: float, y1: float, th1: float) -> tuple[float, float, float]:
    """The body increments ``(fwd, lat, dth)`` (m, m, rad) of the constant twist that moves ``(x0, y0, th0)``
    to ``(x1, y1, th1)`` in one unit of time: the inverse of :func:`twist_pose` [seed002 eq25].

    ``dth = th1 - th0`` wrapped to ``[-pi, pi)`` (a sub-step turns less than half a turn), and
    ``[fwd, lat] = R(-(th0 + dth/2)) [x1 - x0, y1 - y0] / sinc(dth/2)``.
    """
    dth = th1 - th0
    dth -= 2.0 * math.pi * math.floor((dth + math.pi) / (2.0 * math.pi))
    half = 0.5 * dth
    sinc = 1.0 - half * half / 6.0 if abs(half) < 1e-4 else math.sin(half) / half
    mid = th0 + half
    c, s = math.cos(mid), math.sin(mid)
    dx, dy = x1 - x0, y1 - y0
    return (c * dx + s * dy) / sinc, (-s * dx + c * dy) / sinc, dth


@jit
def twist_steps(pose: NDArray[np.float64], vx: NDArray[np.float64], vy: NDArray[np.float64],
                w: NDArray[np.float64], dt: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`twist_pose` over flat arrays: ``pose (k, 3)``, ``vx, vy, w, dt (k,)`` -> ``(k, 3)`` (m, rad)."""
    out = np.empty((pose.shape[0], 3))
    for i in range(pose.shape[0]):
        x, y, th = twist_pose(pose[i, 0], pose[i, 1], pose[i, 2], vx[i], vy[i], w[i], dt[i])
        out[i, 0], out[i, 1], out[i, 2] = x, y, th
    return out


@jit
def twist_table_pose(states: NDArray[np.float64], twists: NDArray[np.float64], n: int, t0: float, h: float,
                     t: float) -> tuple[float, float, float]:
    """Pose ``(x, y, th)`` at ``t`` (s) of a motion table (module docstring) of ``n`` sub-steps of ``h`` s from
    ``t0``."""
    rel = min(max(t - t0, 0.0), n * h)
    i = min(int(rel / h), n - 1) if h > 0.0 else 0
    tau = rel - i * h
    return twist_pose(states[i, 0], states[i, 1], states[i, 2], twists[i, 0], twists[i, 1], twists[i, 2], tau)


@jit
def twist_table_poses(states: NDArray[np.float64], twists: NDArray[np.float64], t0: float, h: float,
                      t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Poses ``(k, 3)`` at instants ``t (k,)`` (s) of one motion table (:func:`twist_table_pose`)."""
    out = np.empty((t.shape[0], 3))
    n = twists.shape[0]
    for k in range(t.shape[0]):
        x, y, th = twist_table_pose(states, twists, n, t0, h, t[k])
        out[k, 0], out[k, 1], out[k, 2] = x, y, th
    return out


@jit
def fleet_twist_tables(poses: NDArray[np.float64], h: float, twists: NDArray[np.float64]) -> None:
    """Fill ``twists (n, G, 3)`` of motion tables whose boundary poses ``poses (n, G + 1, 3)`` are ``h`` s apart.

    Each sub-step's twist is :func:`twist_log` of its two boundary poses divided by ``h`` (m/s, rad/s).
    """
    for r in range(poses.shape[0]):
        for j in range(poses.shape[1] - 1):
            fwd, lat, dth = twist_log(poses[r, j, 0], poses[r, j, 1], poses[r, j, 2],
                                      poses[r, j + 1, 0], poses[r, j + 1, 1], poses[r, j + 1, 2])
            twists[r, j, 0], twists[r, j, 1], twists[r, j, 2] = fwd / h, lat / h, dth / h


@jit
def fleet_twist_poses(states: NDArray[np.float64], twists: NDArray[np.float64], n_sub: NDArray[np.int64],
                      t0: NDArray[np.float64], h: NDArray[np.float64], rows: NDArray[np.int64],
                      t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Poses ``(k, 3)`` of vehicles ``rows (k,)`` at instants ``t (k,)`` (s) from a fleet's motion tables.

    Vehicle ``r``'s table: ``states[r] (S + 1, 3)``, ``twists[r] (S, 3)`` of which the first
    ``n_sub[r]`` sub-steps of ``h[r]`` s from ``t0[r]`` are its step (:func:`twist_table_pose`).
    """
    out = np.empty((t.shape[0], 3))
    for k in range(t.shape[0]):
        r = rows[k]
        x, y, th = twist_table_pose(states[r], twists[r], n_sub[r], t0[r], h[r], t[k])
        out[k, 0], out[k, 1], out[k, 2] = x, y, th
    return out


class TwistPoses:
    """``pose_at`` of a plant's last step: :func:`twist_table_poses` of its motion table (module docstring).

    One object per plant, updated in place every step (:meth:`set`), so a reference taken once
    (a fault or collision wrapper keeps ``plant.pose_at``) always gives the current step; a kernel that
    knows the table (the goniometer's scan, :func:`agvnav.sensors.beam.scan_motion`) evaluates it itself.
    """

    __slots__ = ("h", "states", "t0", "twists")

    def __init__(self, states: NDArray[np.float64], twists: NDArray[np.float64], t0: float, h: float) -> None:
        self.set(states, twists, t0, h)

    def set(self, states: NDArray[np.float64], twists: NDArray[np.float64], t0: float, h: float) -> None:
        """Hold the step from ``t0`` (s) of sub-steps ``h`` (s, > 0): boundary poses ``states (n + 1, 3)`` and
        twists ``(n, 3)``."""
        self.states, self.twists, self.t0, self.h = states, twists, float(t0), float(h)

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        """True base_link pose ``(k, 3)`` (m, m, rad) at instants ``t (k,)`` (s) of the step (clipped to it)."""
        tt = np.ascontiguousarray(t, dtype=np.float64).reshape(-1)
        return np.asarray(twist_table_poses(self.states, self.twists, self.t0, self.h, tt), dtype=np.float64)
