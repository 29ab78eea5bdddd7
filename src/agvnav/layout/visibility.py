"""Which reflectors a goniometer sees from each route pose: range, occlusion, reflectors hiding each other.

A reflector is seen from head position ``P`` when its distance is inside
``[min_range, max_range]`` and no occluding segment properly crosses the line of
sight ``P -> R`` (the beam model of seed 000 §2.1: the laser sweeps the plane,
walls and racks stop it). A nearer reflector hides a farther one when their
angular extents overlap (the head cannot tell the two reflections apart, and a
cylinder in front physically blocks the one behind). All kernels are vectorised
over poses x reflectors with NumPy, chunked to bound memory.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import wrap_angle

__all__ = ["line_of_sight", "mutual_hiding", "visibility"]

_CHUNK = 2_000_000


def _cross(ux: NDArray[np.float64], uy: NDArray[np.float64], vx: NDArray[np.float64],
           vy: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(ux * vy - uy * vx)


def line_of_sight(p: NDArray[np.float64], r: NDArray[np.float64], segments: NDArray[np.float64]) -> NDArray[np.bool_]:
    """True where no segment of ``segments`` ``(M, 2, 2)`` properly crosses ``p[i] -> r[i]`` (both ``(n, 2)``, m).

    Proper crossing: the two segments' endpoints lie strictly on opposite sides of each
    other (touching a corner does not block). Chunked over ``n``.
    """
    n, m = p.shape[0], segments.shape[0]
    clear = np.ones(n, dtype=bool)
    if m == 0 or n == 0:
        return clear
    a, b = segments[:, 0, :], segments[:, 1, :]
    abx, aby = (b - a)[:, 0], (b - a)[:, 1]
    step = max(1, _CHUNK // m)
    for lo in range(0, n, step):
        px, py = p[lo:lo + step, 0:1], p[lo:lo + step, 1:2]
        dx, dy = r[lo:lo + step, 0:1] - px, r[lo:lo + step, 1:2] - py
        d1 = _cross(dx, dy, a[:, 0] - px, a[:, 1] - py)
        d2 = _cross(dx, dy, b[:, 0] - px, b[:, 1] - py)
        d3 = _cross(abx, aby, px - a[:, 0], py - a[:, 1])
        d4 = _cross(abx, aby, px + dx - a[:, 0], py + dy - a[:, 1])
        clear[lo:lo + step] = ~np.any((d1 * d2 < 0.0) & (d3 * d4 < 0.0), axis=1)
    return clear


def visibility(head: NDArray[np.float64], refl: NDArray[np.float64], segments: NDArray[np.float64],
               min_range: float, max_range: float) -> NDArray[np.bool_]:
    """Visible ``(K, C)``: reflector ``c`` in range of head ``k`` and in line of sight (walls only).

    ``head`` ``(K, 2)``, ``refl`` ``(C, 2)`` (m), ``segments`` ``(M, 2, 2)`` occluding faces.
    Only the pairs in range are tested against the segments.
    """
    head = np.asarray(head, dtype=np.float64)
    refl = np.asarray(refl, dtype=np.float64)
    if min_range < 0.0 or max_range <= min_range:
        raise ValueError(f"need 0 <= min_range < max_range, got {min_range}, {max_range}")
    d = np.hypot(refl[None, :, 0] - head[:, None, 0], refl[None, :, 1] - head[:, None, 1])
    vis = (d >= min_range) & (d <= max_range)
    k, c = np.nonzero(vis)
    vis[k, c] = line_of_sight(head[k], refl[c], np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2))
    return vis


def mutual_hiding(head: NDArray[np.float64], refl: NDArray[np.float64], radius: float,
                  vis: NDArray[np.bool_], neighbours: int = 3) -> NDArray[np.bool_]:
    """``vis`` ``(K, S)`` with reflectors hidden by a nearer visible one removed.

    Reflector ``i`` is hidden at head ``k`` when a visible ``j`` is nearer and their
    angular half-widths ``asin(radius / d)`` overlap: ``|θ_i - θ_j| < w_i + w_j`` (rad).
    Only the ``neighbours`` nearest in bearing on each side (circularly, across ±π) are
    compared, so the cost is ``O(K S log S)``; a point reflector (``radius = 0``) hides nothing.
    """
    if radius <= 0.0 or refl.shape[0] < 2:
        return vis.copy()
    dx = refl[None, :, 0] - head[:, None, 0]
    dy = refl[None, :, 1] - head[:, None, 1]
    d = np.hypot(dx, dy)
    w = np.arcsin(np.clip(radius / np.maximum(d, 1e-12), 0.0, 1.0))
    theta = np.where(vis, np.arctan2(dy, dx), 10.0)  # not visible: sorted to the end
    order = np.argsort(theta, axis=1, kind="stable")
    n = vis.sum(axis=1)[:, None]
    pos = np.arange(refl.shape[0])[None, :]
    th, ds, ws = (np.take_along_axis(a, order, axis=1) for a in (theta, d, w))
    hidden = np.zeros(vis.shape, dtype=bool)
    for off in range(1, min(neighbours, refl.shape[0] - 1) + 1):
        for sign in (1, -1):
            partner = (pos + sign * off) % np.maximum(n, 1)
            sep = np.abs(wrap_angle(th - np.take_along_axis(th, partner, axis=1)))
            near = np.take_along_axis(ds, partner, axis=1) < ds
            over = sep < ws + np.take_along_axis(ws, partner, axis=1)
            hidden |= over & near & (pos < n) & (partner != pos)
    out = vis.copy()
    rows = np.arange(vis.shape[0])[:, None]
    out[rows, order] &= ~hidden
    return out
