"""Compiled kernels of the goniometer's beam geometry (seed 000 §2.1), one formulation each.

The rotating beam meets a cylindrical reflector at the instant the offset between
the beam direction and the reflector's leading tangent edge passes a whole turn
(:meth:`agvnav.sensors.goniometer.Goniometer.scan`). These kernels evaluate that
offset (:func:`offset_one`, the one formulation), find the brackets where it passes
``2 pi`` on a time grid for every reflector (:func:`grid_crossings`), evaluate it for
one reflector per instant (:func:`offsets_at`) and test the line of sight
(:func:`line_of_sight`); :func:`chord_brackets`, :func:`chord_step` and :func:`seen_in_order` are the
root finder's bookkeeping around them (one call each instead of a dozen NumPy calls on a few
elements: issue 11), and :func:`scan_motion` runs the whole scan of one window in one call
when the plant's motion is a table a kernel evaluates (a Hermite curve,
:class:`agvnav.geometry.hermite.HermitePoses`; constant-twist sub-steps,
:class:`agvnav.kinematics.twist.TwistPoses`). They are
compiled by numba (``cache=True``: compiled once per machine, reused across runs;
:mod:`agvnav._jit`), loop over plain float64 arrays, and serve one vehicle or a batch of
instants alike: the goniometer calls them with the pose samples its ``pose_at`` gave, so no NumPy
per-call overhead remains in the scan's inner loops.
No ``fastmath``: the arithmetic is IEEE, operation for operation as written.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agvnav._jit import jit
from agvnav.geometry.angles import wrap_angle_kernel
from agvnav.geometry.hermite import hermite_poses
from agvnav.kinematics.twist import twist_table_poses

__all__ = [
    "chord_brackets", "chord_step", "grid_crossings", "line_of_sight", "offset_one", "offsets_at", "scan_motion",
    "seen_in_order", "wrapped_offsets",
]

_TWO_PI = 2.0 * math.pi


@jit
def offset_one(
    x: float, y: float, heading: float, t: float, rx: float, ry: float, r: float,
    mx: float, my: float, phase: float, omega: float, direction: int,
) -> tuple[float, float, float, float]:
    """Unwrapped beam-minus-leading-edge angle for one instant and one reflector (seed 000 §2.1).

    Parameters
    ----------
    x, y, heading : base_link pose at ``t`` (m, m, rad).
    t : instant (s).
    rx, ry, r : reflector centre (m) and radius (m).
    mx, my : head centre P in base_link (m).
    phase : head angle at t = 0 plus the mount's yaw (rad).
    omega : ``direction * 2 pi f`` (rad/s).
    direction : +1 for a CCW head, -1 for CW.

    Returns
    -------
    ``(offset (rad), head x (m), head y (m), head-to-centre distance d (m))``; the offset is
    ``direction * (beam - edge)`` with the edge at ``atan2 - direction * asin(r/d)``
    (``asin`` saturates at pi/2 inside the cylinder, ``d <= r``; the caller rejects those).
    """
    if mx != 0.0 or my != 0.0:
        c, s = math.cos(heading), math.sin(heading)
        x, y = x + c * mx - s * my, y + s * mx + c * my
    beam = heading + phase + omega * t
    dx, dy = rx - x, ry - y
    d = math.sqrt(dx * dx + dy * dy)
    half_width = math.asin(min(r / max(d, 1e-300), 1.0))
    if direction == 1:
        return beam - math.atan2(dy, dx) + half_width, x, y, d
    return math.atan2(dy, dx) + half_width - beam, x, y, d


@jit
def grid_crossings(
    grid: NDArray[np.float64], pose: NDArray[np.float64],
    rx: NDArray[np.float64], ry: NDArray[np.float64], r: NDArray[np.float64],
    mx: float, my: float, phase: float, omega: float, direction: int,
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """Brackets of the grid where a reflector's offset passes a whole turn.

    ``grid (k,)`` instants (s) with the base_link poses ``pose (k, 3)``; reflectors
    ``rx, ry, r (N,)`` (m). The offset, reduced to ``[0, 2 pi)``, drops by more than pi
    over a bracket where the beam passes the edge. Returns, bracket-major then by
    reflector, the bracket index ``i`` (crossing in ``[grid[i], grid[i+1]]``), the
    reflector row, and the offset at both ends (``f_lo`` in ``[-2 pi, 0)``, ``f_hi >= 0``).
    """
    k, n = len(grid), len(rx)
    w = np.empty((k, n))
    for i in range(k):
        x, y, h, ti = float(pose[i, 0]), float(pose[i, 1]), float(pose[i, 2]), float(grid[i])
        for j in range(n):
            o = offset_one(x, y, h, ti, float(rx[j]), float(ry[j]), float(r[j]), mx, my, phase, omega, direction)[0]
            w[i, j] = o % _TWO_PI
    m = max(k - 1, 0) * n
    interval, refl = np.empty(m, np.int64), np.empty(m, np.int64)
    f_lo, f_hi = np.empty(m), np.empty(m)
    c = 0
    for i in range(k - 1):
        for j in range(n):
            a, b = float(w[i, j]), float(w[i + 1, j])
            if a - b > math.pi:
                interval[c], refl[c] = i, j
                f_lo[c], f_hi[c] = a - _TWO_PI, b
                c += 1
    return interval[:c], refl[:c], f_lo[:c], f_hi[:c]


@jit
def offsets_at(
    t: NDArray[np.float64], pose: NDArray[np.float64],
    rx: NDArray[np.float64], ry: NDArray[np.float64], r: NDArray[np.float64],
    mx: float, my: float, phase: float, omega: float, direction: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`offset_one` for one reflector per instant: ``t (c,)``, ``pose (c, 3)``, reflectors ``(c,)``.

    Returns the unwrapped offsets (rad), head x, head y (m) and head-to-centre distances (m), each ``(c,)``.
    """
    c = t.shape[0]
    off, hx, hy, d = np.empty(c), np.empty(c), np.empty(c), np.empty(c)
    for i in range(c):
        off[i], hx[i], hy[i], d[i] = offset_one(
            float(pose[i, 0]), float(pose[i, 1]), float(pose[i, 2]), float(t[i]), float(rx[i]), float(ry[i]),
            float(r[i]), mx, my, phase, omega, direction,
        )
    return off, hx, hy, d


@jit
def wrapped_offsets(raw: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
    """The offsets ``raw (c,)`` (rad) wrapped to ``[-pi, pi)`` and the largest ``|wrapped|`` (rad).

    The wrap is :func:`agvnav.geometry.angles.wrap_angle_kernel` (the scalar form of
    :func:`agvnav.geometry.wrap_angle`), so the values are bit-identical; ``+-inf`` gives NaN
    and a NaN makes the largest NaN, as ``np.abs(f).max()`` does. The root finder's
    convergence test in one call instead of four NumPy calls on a few elements.
    """
    c = raw.shape[0]
    f = np.empty(c)
    worst = 0.0
    for i in range(c):
        w = wrap_angle_kernel(float(raw[i]))
        f[i] = w
        m = abs(w)
        if m > worst or m != m:  # a NaN stays the largest
            worst = m
    return f, worst


@jit
def chord_brackets(
    grid: NDArray[np.float64], interval: NDArray[np.int64], f_lo: NDArray[np.float64], f_hi: NDArray[np.float64],
    refl: NDArray[np.int64], rx: NDArray[np.float64], ry: NDArray[np.float64], r: NDArray[np.float64],
) -> tuple[NDArray[np.float64], ...]:
    """The chord iteration's start from the brackets of :func:`grid_crossings`.

    For crossing ``i`` in ``[lo, hi] = [grid[interval[i]], grid[interval[i] + 1]]`` (s) with offsets
    ``f_lo < 0 <= f_hi`` (rad) there: the secant slope ``(f_hi - f_lo) / (hi - lo)`` (rad/s), the
    first chord instant ``lo - f_lo / slope`` (s) and the reflector's centre and radius (m).
    Returns ``lo, hi, slope, t, rx, ry, r`` (each ``(c,)``) and ``max |hi|`` (s) as a 1-element array.
    """
    c = interval.shape[0]
    lo, hi, slope, t = np.empty(c), np.empty(c), np.empty(c), np.empty(c)
    trx, try_, tr = np.empty(c), np.empty(c), np.empty(c)
    h_max = np.zeros(1)
    top = 0.0
    for i in range(c):
        a, b = float(grid[interval[i]]), float(grid[interval[i] + 1])
        fl = float(f_lo[i])
        sl = (float(f_hi[i]) - fl) / (b - a)  # > 0: f_hi >= 0 > f_lo
        lo[i], hi[i], slope[i] = a, b, sl
        t[i] = a - fl / sl
        j = refl[i]
        trx[i], try_[i], tr[i] = rx[j], ry[j], r[j]
        top = max(top, abs(b))
    h_max[0] = top
    return lo, hi, slope, t, trx, try_, tr, h_max


@jit
def chord_step(
    t: NDArray[np.float64], pose: NDArray[np.float64],
    rx: NDArray[np.float64], ry: NDArray[np.float64], r: NDArray[np.float64],
    mx: float, my: float, phase: float, omega: float, direction: int,
    slope: NDArray[np.float64], lo: NDArray[np.float64], hi: NDArray[np.float64], tol: float,
) -> tuple[bool, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """One chord iteration of the goniometer's root finder at the instants ``t (c,)`` (s).

    The offsets there (:func:`offsets_at`, base_link poses ``pose (c, 3)``, one reflector per
    instant), wrapped (:func:`wrapped_offsets`). Returns ``(True, t, hx, hy, d)`` when every
    ``|offset| <= tol`` (rad), else ``(False, t', hx, hy, d)`` with the next instants
    ``t' = clip(t - f / slope, lo, hi)`` (a NaN stays NaN, as ``np.minimum``/``np.maximum`` keep it).
    """
    off, hx, hy, d = offsets_at(t, pose, rx, ry, r, mx, my, phase, omega, direction)
    f, worst = wrapped_offsets(off)
    if worst <= tol:
        return True, t, hx, hy, d
    c = t.shape[0]
    nxt = np.empty(c)
    for i in range(c):
        v = float(t[i]) - float(f[i]) / float(slope[i])
        a, b = float(lo[i]), float(hi[i])
        if v < a:
            v = a
        if v > b:
            v = b
        nxt[i] = v
    return False, nxt, hx, hy, d


@jit
def seen_in_order(
    t: NDArray[np.float64], refl: NDArray[np.int64], seen: NDArray[np.bool_],
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The instants ``t`` (s) and reflector rows ``refl`` where ``seen``, in time order (a stable sort:
    equal instants keep their order, as ``np.argsort(kind="stable")``)."""
    c = 0
    for i in range(t.shape[0]):
        if seen[i]:
            c += 1
    ts, rs = np.empty(c), np.empty(c, np.int64)
    k = 0
    for i in range(t.shape[0]):
        if not seen[i]:
            continue
        m = k  # insertion: shift the later instants right
        while m > 0 and ts[m - 1] > t[i]:
            ts[m], rs[m] = ts[m - 1], rs[m - 1]
            m -= 1
        ts[m], rs[m] = t[i], refl[i]
        k += 1
    return ts, rs


@jit
def _finite_poses(pose: NDArray[np.float64]) -> bool:
    """True if every element of ``pose (k, 3)`` is finite."""
    for i in range(pose.shape[0]):
        for j in range(3):
            v = pose[i, j]
            if v - v != 0.0:  # NaN and +-inf give NaN
                return False
    return True


#: Kinds of motion table :func:`scan_motion` evaluates itself.
HERMITE, TWIST = 0, 1


@jit
def motion_poses(kind: int, table: NDArray[np.float64], twists: NDArray[np.float64], t0: float, h: float,
                 t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Base_link poses ``(k, 3)`` at instants ``t (k,)`` (s) of a step's motion table of ``kind``:
    :data:`HERMITE`, the ``(4, 3)`` curve of :func:`~agvnav.geometry.hermite.hermite_poses` over ``[t0, t0 + h]``
    (``twists`` unused); :data:`TWIST`, boundary poses and sub-step twists of
    :func:`~agvnav.kinematics.twist.twist_table_poses` (sub-steps of ``h`` s from ``t0``)."""
    if kind == 0:
        return hermite_poses(table, t0, h, t)
    return twist_table_poses(table, twists, t0, h, t)


@jit
def scan_motion(
    kind: int, table: NDArray[np.float64], twists: NDArray[np.float64], t0: float, h: float, grid: NDArray[np.float64],
    rx: NDArray[np.float64], ry: NDArray[np.float64], r: NDArray[np.float64],
    mx: float, my: float, phase: float, omega: float, direction: int,
    wall_x0: NDArray[np.float64], wall_y0: NDArray[np.float64],
    wall_vx: NDArray[np.float64], wall_vy: NDArray[np.float64],
    min_range: float, max_range: float, rate_hz: float, angle_tol: float, eps: float, chord_iter: int,
) -> tuple[int, NDArray[np.float64], NDArray[np.int64]]:
    """The goniometer's exact crossings on the bracket ``grid`` (s) of one window, all in one call.

    The same steps as :meth:`agvnav.sensors.goniometer.Goniometer.scan`'s generic path, in the
    same order and arithmetic, with the base_link poses from the step's motion table
    (:func:`motion_poses` of ``(kind, table, twists, t0, h)``) instead of a call back into Python:
    :func:`grid_crossings`,
    :func:`chord_brackets`, up to ``chord_iter`` :func:`chord_step` to the tolerance
    ``max(angle_tol, 8 eps max|hi| 2 pi rate_hz)`` (rad), :func:`line_of_sight` and
    :func:`seen_in_order`. Returns ``(0, t, rows)``: the seen instants (s) and reflector rows in
    time order; ``(1, ...)`` when the chord iterations did not converge and ``(2, ...)`` on a
    non-finite pose (the caller then takes the generic path, which falls back to Illinois or
    raises). Walls ``start + [0, 1] direction`` (m), ranges (m) as in :func:`line_of_sight`.
    """
    no_t, no_rows = np.empty(0), np.empty(0, np.int64)
    pose = motion_poses(kind, table, twists, t0, h, grid)
    if not _finite_poses(pose):
        return 2, no_t, no_rows
    interval, refl, f_lo, f_hi = grid_crossings(grid, pose, rx, ry, r, mx, my, phase, omega, direction)
    if interval.shape[0] == 0:
        return 0, no_t, no_rows
    lo, hi, slope, t, trx, try_, tr, h_max = chord_brackets(grid, interval, f_lo, f_hi, refl, rx, ry, r)
    tol = max(angle_tol, 8.0 * eps * h_max[0] * _TWO_PI * rate_hz)
    for _ in range(chord_iter):
        pose = motion_poses(kind, table, twists, t0, h, t)
        if not _finite_poses(pose):
            return 2, no_t, no_rows
        done, t, hx, hy, d = chord_step(t, pose, trx, try_, tr, mx, my, phase, omega, direction, slope, lo, hi, tol)
        if done:
            seen = line_of_sight(refl, hx, hy, d, rx, ry, r, wall_x0, wall_y0, wall_vx, wall_vy, min_range, max_range)
            ts, rs = seen_in_order(t, refl, seen)
            return 0, ts, rs
    return 1, no_t, no_rows


@jit
def line_of_sight(
    refl: NDArray[np.int64], hx: NDArray[np.float64], hy: NDArray[np.float64], d: NDArray[np.float64],
    rx: NDArray[np.float64], ry: NDArray[np.float64], r: NDArray[np.float64],
    wall_x0: NDArray[np.float64], wall_y0: NDArray[np.float64],
    wall_vx: NDArray[np.float64], wall_vy: NDArray[np.float64],
    min_range: float, max_range: float,
) -> NDArray[np.bool_]:
    """``(c,)`` True where reflector ``refl[i]`` is in range and seen from the head ``(hx, hy)[i]``.

    In range: the squared beam length to the tangent point ``d^2 - r^2`` is positive and within
    ``[min_range^2, max_range^2]`` (m^2). Seen: the segment from the head to the near surface
    of the cylinder (``(d - r)/d`` of the way to the centre, shortened by 1e-9) crosses no wall
    ``start (wall_x0, wall_y0) + [0, 1] (wall_vx, wall_vy)`` (parallel pairs do not block:
    with ``a`` the wall start from the head, ``u`` the ray and ``v`` the wall, ``s = (a x v)/(u x v)``
    and ``w = (a x u)/(u x v)`` both in [0, 1] block) and passes no other reflector closer than
    its radius.
    """
    c = len(refl)
    out = np.zeros(c, np.bool_)
    for i in range(c):
        j = refl[i]
        di, ri, ox, oy = float(d[i]), float(r[j]), float(hx[i]), float(hy[i])
        range2 = di * di - ri * ri
        if not (range2 > 0.0 and range2 >= min_range * min_range and range2 <= max_range * max_range):
            continue
        scale = (di - ri) / max(di, 1e-300) * (1.0 - 1e-9)
        ux, uy = (float(rx[j]) - ox) * scale, (float(ry[j]) - oy) * scale
        out[i] = not (_hits_wall(ox, oy, ux, uy, wall_x0, wall_y0, wall_vx, wall_vy)
                      or _hits_disc(ox, oy, ux, uy, rx, ry, r, j))
    return out


@jit
def _hits_wall(
    ox: float, oy: float, ux: float, uy: float,
    wall_x0: NDArray[np.float64], wall_y0: NDArray[np.float64],
    wall_vx: NDArray[np.float64], wall_vy: NDArray[np.float64],
) -> bool:
    """True if the segment ``o -> o + u`` crosses any wall segment (see :func:`line_of_sight`)."""
    for m in range(len(wall_x0)):
        vx, vy = wall_vx[m], wall_vy[m]
        ax, ay = wall_x0[m] - ox, wall_y0[m] - oy
        den = ux * vy - uy * vx
        if den == 0.0:
            continue
        sign = 1.0 if den > 0.0 else -1.0
        num_s = (ax * vy - ay * vx) * sign
        num_w = (ax * uy - ay * ux) * sign
        den = abs(den)
        if 0.0 <= num_s <= den and 0.0 <= num_w <= den:
            return True
    return False


@jit
def _hits_disc(
    ox: float, oy: float, ux: float, uy: float,
    rx: NDArray[np.float64], ry: NDArray[np.float64], r: NDArray[np.float64], target: int,
) -> bool:
    """True if the segment ``o -> o + u`` passes within the radius of a reflector other than ``target``."""
    length2 = max(ux * ux + uy * uy, 1e-300)
    for j in range(len(rx)):
        if j == target:
            continue
        cx, cy = rx[j] - ox, ry[j] - oy
        tau = min(max((cx * ux + cy * uy) / length2, 0.0), 1.0)
        gx, gy = cx - tau * ux, cy - tau * uy
        if gx * gx + gy * gy < r[j] * r[j]:
            return True
    return False
