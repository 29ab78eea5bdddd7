"""Which reflectors a goniometer sees from each route pose: range, occlusion, reflectors hiding each other.

A reflector is seen from head position ``P`` when its distance is inside
``[min_range, max_range]`` and no occluding segment properly crosses the line of
sight ``P -> R`` (the beam model of seed 000 §2.1: the laser sweeps the plane,
walls and racks stop it). A nearer reflector hides a farther one when their
angular extents overlap (the head cannot tell the two reflections apart, and a
cylinder in front physically blocks the one behind). All kernels are vectorised
over poses x reflectors with NumPy; the line-of-sight test of the pairs in range is one
compiled loop (numba) with early exits.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import cast

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["line_of_sight", "mutual_hiding", "visibility"]



def _crosses(ox: float, oy: float, ex: float, ey: float, seg: NDArray[np.float64]) -> bool:  # pragma: no cover
    """True if the segment ``o -> e`` properly crosses one of ``seg`` ``(M, 4)`` (bounding boxes first)."""
    ux, uy = ex - ox, ey - oy
    lo_x, hi_x, lo_y, hi_y = min(ox, ex), max(ox, ex), min(oy, ey), max(oy, ey)
    for m in range(seg.shape[0]):
        ax, ay, bx, by = seg[m, 0], seg[m, 1], seg[m, 2], seg[m, 3]
        if max(ax, bx) < lo_x or min(ax, bx) > hi_x or max(ay, by) < lo_y or min(ay, by) > hi_y:
            continue
        if (ux * (ay - oy) - uy * (ax - ox)) * (ux * (by - oy) - uy * (bx - ox)) >= 0.0:
            continue
        vx, vy = bx - ax, by - ay
        if (vx * (oy - ay) - vy * (ox - ax)) * (vx * (ey - ay) - vy * (ex - ax)) < 0.0:
            return True
    return False


def _visible_matrix(head: NDArray[np.float64], refl: NDArray[np.float64], seg: NDArray[np.float64],
                    rmin: float, rmax: float) -> NDArray[np.bool_]:  # pragma: no cover
    out = np.zeros((head.shape[0], refl.shape[0]), np.bool_)
    for k in range(head.shape[0]):
        for c in range(refl.shape[0]):
            d = math.hypot(refl[c, 0] - head[k, 0], refl[c, 1] - head[k, 1])
            if d >= rmin and d <= rmax:
                out[k, c] = not _crosses_jit(head[k, 0], head[k, 1], refl[c, 0], refl[c, 1], seg)
    return out


def _pairs_clear(p: NDArray[np.float64], r: NDArray[np.float64], seg: NDArray[np.float64]) -> NDArray[
        np.bool_]:  # pragma: no cover
    out = np.ones(p.shape[0], np.bool_)
    for i in range(p.shape[0]):
        out[i] = not _crosses_jit(p[i, 0], p[i, 1], r[i, 0], r[i, 1], seg)
    return out


_crosses_jit = cast(Callable[..., bool], njit(cache=True)(_crosses))
_visible_jit = cast(Callable[..., NDArray[np.bool_]], njit(cache=True)(_visible_matrix))
_clear_jit = cast(Callable[..., NDArray[np.bool_]], njit(cache=True)(_pairs_clear))


def _segments4(segments: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.ascontiguousarray(np.asarray(segments, dtype=np.float64).reshape(-1, 4))


def line_of_sight(p: NDArray[np.float64], r: NDArray[np.float64], segments: NDArray[np.float64]) -> NDArray[np.bool_]:
    """True where no segment of ``segments`` ``(M, 2, 2)`` properly crosses ``p[i] -> r[i]`` (both ``(n, 2)``, m).

    Proper crossing: the endpoints of each segment lie strictly on opposite sides of the
    other (touching a corner does not block). A compiled loop with a bounding-box
    rejection and an early exit per pair.
    """
    p = np.ascontiguousarray(p, dtype=np.float64).reshape(-1, 2)
    r = np.ascontiguousarray(r, dtype=np.float64).reshape(-1, 2)
    return np.asarray(_clear_jit(p, r, _segments4(segments)), dtype=bool)


def visibility(head: NDArray[np.float64], refl: NDArray[np.float64], segments: NDArray[np.float64],
               min_range: float, max_range: float) -> NDArray[np.bool_]:
    """Visible ``(K, C)``: reflector ``c`` in range of head ``k`` and in line of sight (walls only).

    ``head`` ``(K, 2)``, ``refl`` ``(C, 2)`` (m), ``segments`` ``(M, 2, 2)`` occluding faces;
    range is the centre distance in ``[min_range, max_range]``. One compiled loop over the pairs.
    """
    if min_range < 0.0 or max_range <= min_range:
        raise ValueError(f"need 0 <= min_range < max_range, got {min_range}, {max_range}")
    head = np.ascontiguousarray(head, dtype=np.float64).reshape(-1, 2)
    refl = np.ascontiguousarray(refl, dtype=np.float64).reshape(-1, 2)
    return np.asarray(_visible_jit(head, refl, _segments4(segments), float(min_range), float(max_range)), dtype=bool)


def _hiding(head: NDArray[np.float64], refl: NDArray[np.float64], radius: float,
            vis: NDArray[np.bool_]) -> NDArray[np.bool_]:  # pragma: no cover
    out = vis.copy()
    n = refl.shape[0]
    d = np.empty(n)
    th = np.empty(n)
    w = np.empty(n)
    for k in range(head.shape[0]):
        for i in range(n):
            dx, dy = refl[i, 0] - head[k, 0], refl[i, 1] - head[k, 1]
            d[i] = math.hypot(dx, dy)
            th[i] = math.atan2(dy, dx)
            w[i] = math.asin(min(1.0, radius / max(d[i], 1e-12)))
        for i in range(n):
            if not vis[k, i]:
                continue
            for j in range(n):
                if j == i or not vis[k, j] or d[j] >= d[i]:
                    continue
                sep = abs(th[i] - th[j])
                sep = min(sep, 2.0 * math.pi - sep)
                if sep < w[i] + w[j]:
                    out[k, i] = False
                    break
    return out


_hiding_jit = cast(Callable[..., NDArray[np.bool_]], njit(cache=True)(_hiding))


def mutual_hiding(head: NDArray[np.float64], refl: NDArray[np.float64], radius: float,
                  vis: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """``vis`` ``(K, S)`` with reflectors hidden by a nearer visible one removed.

    Reflector ``i`` is hidden at head ``k`` when a visible ``j`` is nearer and their
    angular half-widths ``asin(radius / d)`` overlap: ``|θ_i - θ_j| < w_i + w_j`` (rad,
    the separation taken across ±π). A point reflector (``radius = 0``) hides nothing.
    One compiled loop over poses and pairs.
    """
    vis = np.ascontiguousarray(vis, dtype=bool)
    if radius <= 0.0 or refl.shape[0] < 2:
        return vis.copy()
    head = np.ascontiguousarray(head, dtype=np.float64).reshape(-1, 2)
    refl = np.ascontiguousarray(refl, dtype=np.float64).reshape(-1, 2)
    return np.asarray(_hiding_jit(head, refl, float(radius), vis), dtype=bool)
