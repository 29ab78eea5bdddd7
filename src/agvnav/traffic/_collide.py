"""The executor's collision check as a kernel: the first pair of placed convex footprints that overlap.

Broad phase: the bounding circles (circumradius about the reference point) of the two vehicles meet,
``hypot(dx, dy) < r_a + r_b``. Narrow phase: the separating-axis test of two convex polygons (two
convex sets are disjoint iff some edge normal of one of them separates their projections, a strict
gap: polygons that only touch count as overlapping, as shapely's ``intersects`` does). Pairs are
visited in the order ``(a, b)``, ``a < b``, row by row, so the pair reported is the first that
:func:`agvnav.traffic.execute` reported with shapely.

The footprints are padded into one array ``(n, k_max, 2)`` (m, base_link) with their vertex counts;
each must be convex (:func:`is_convex`; the executor falls back to shapely otherwise).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agvnav._jit import jit

__all__ = ["first_overlap", "is_convex", "pad_footprints", "place", "polygons_overlap"]


@jit
def place(fp: NDArray[np.float64], k: int, x: float, y: float, h: float, out: NDArray[np.float64]) -> None:
    """The first ``k`` vertices of footprint ``fp`` placed at pose ``(x, y, h)`` (m, rad) into ``out``."""
    c, s = math.cos(h), math.sin(h)
    for i in range(k):
        out[i, 0] = x + c * fp[i, 0] - s * fp[i, 1]
        out[i, 1] = y + s * fp[i, 0] + c * fp[i, 1]


@jit
def _separates(p: NDArray[np.float64], np_: int, q: NDArray[np.float64], nq: int) -> bool:
    """True when some edge normal of ``p`` separates the projections of ``p`` and ``q`` (a strict gap)."""
    for i in range(np_):
        j = i + 1 if i + 1 < np_ else 0
        ax, ay = -(p[j, 1] - p[i, 1]), p[j, 0] - p[i, 0]
        lo_p, hi_p = math.inf, -math.inf
        for m in range(np_):
            d = ax * p[m, 0] + ay * p[m, 1]
            lo_p, hi_p = min(lo_p, d), max(hi_p, d)
        lo_q, hi_q = math.inf, -math.inf
        for m in range(nq):
            d = ax * q[m, 0] + ay * q[m, 1]
            lo_q, hi_q = min(lo_q, d), max(hi_q, d)
        if hi_p < lo_q or hi_q < lo_p:
            return True
    return False


@jit
def polygons_overlap(p: NDArray[np.float64], np_: int, q: NDArray[np.float64], nq: int) -> bool:
    """True when convex polygons ``p[:np_]`` and ``q[:nq]`` (vertices in order, m) share a point."""
    return not (_separates(p, np_, q, nq) or _separates(q, nq, p, np_))


@jit
def first_overlap(xs: NDArray[np.float64], ys: NDArray[np.float64], hs: NDArray[np.float64],
                  radius: NDArray[np.float64], fps: NDArray[np.float64], counts: NDArray[np.int64],
                  pa: NDArray[np.float64], pb: NDArray[np.float64]) -> int:
    """The first pair ``(a, b)``, ``a < b``, whose footprints placed at ``(xs, ys, hs)`` (m, rad) overlap,
    as ``a * n + b``; -1 when none (module doc). ``pa``, ``pb``: scratch ``(k_max, 2)``."""
    n = len(xs)
    for a in range(n):
        placed_a = False
        for b in range(a + 1, n):
            if math.hypot(xs[a] - xs[b], ys[a] - ys[b]) >= radius[a] + radius[b]:
                continue
            if not placed_a:
                place(fps[a], counts[a], xs[a], ys[a], hs[a], pa)
                placed_a = True
            place(fps[b], counts[b], xs[b], ys[b], hs[b], pb)
            if polygons_overlap(pa, counts[a], pb, counts[b]):
                return a * n + b
    return -1


def pad_footprints(footprints: list[NDArray[np.float64]]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The footprints ``(k_i, 2)`` padded into one ``(n, k_max, 2)`` array, and their vertex counts."""
    k_max = max((len(f) for f in footprints), default=1)
    fps = np.zeros((len(footprints), k_max, 2))
    for i, f in enumerate(footprints):
        fps[i, :len(f)] = f
    return fps, np.array([len(f) for f in footprints], dtype=np.int64)


def is_convex(fp: NDArray[np.float64]) -> bool:
    """True when polygon ``fp`` ``(k, 2)`` (vertices in order, k >= 3) is convex: every turn of one sign
    (collinear vertices allowed) and the boundary winds once."""
    d = np.diff(np.vstack([fp, fp[:1]]), axis=0)
    cross = d[:, 0] * np.roll(d[:, 1], -1) - d[:, 1] * np.roll(d[:, 0], -1)
    if len(fp) < 3 or not (np.all(cross >= 0.0) or np.all(cross <= 0.0)) or not np.any(cross != 0.0):
        return False
    turn = np.arctan2(cross, d[:, 0] * np.roll(d[:, 0], -1) + d[:, 1] * np.roll(d[:, 1], -1))
    return bool(abs(abs(float(np.sum(turn))) - 2.0 * math.pi) < 1e-6)
