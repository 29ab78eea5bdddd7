"""Spatial and bearing-order look-ups for the start-up search on large maps (issue 11).

Two pure array functions, so the pose search scales with the number N of map reflectors
without forming an ``N x N x N`` table:

* :func:`nearest_neighbours` -- the ``k`` nearest reflectors of every reflector (a spatial
  index in blocks of rows: memory ``O(block N)``, never ``N^2`` at once). Reflections that
  follow each other around one revolution mostly come from reflectors next to each other
  in the map (the same wall, the same rack), so a consecutive triple of bearings is tried
  only against reflector triples built from one reflector and its neighbours.
* :func:`count_explained` -- how many observed bearings each hypothesis explains, by
  bearing order: the predicted bearings of one hypothesis are sorted once and each
  observed bearing is located among them by bisection; only its two circular
  neighbours can be the closest. ``O((N + k) log N)`` per hypothesis instead of the
  ``O(k N)`` table of every (bearing, reflector) difference, same count.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import angle_diff

__all__ = ["count_explained", "nearest_neighbours"]

#: Rows of the distance table computed at once by :func:`nearest_neighbours`.
_BLOCK = 512
#: Sorted predicted bearings of an invisible reflector: above every wrapped angle (< pi).
_INVISIBLE = 4.0
#: Row stride of the flattened sorted table (> 2 pi + margin, so rows never interleave).
_ROW = 8.0


def nearest_neighbours(xy: ArrayLike, k: int) -> NDArray[np.int64]:
    """Rows of the ``k`` nearest other points of every point, nearest first: ``(N, min(k, N - 1))``.

    ``xy (N, 2)`` positions (m). Ties are broken by row (stable sort), so the table is
    deterministic. ValueError for ``k < 1`` or fewer than two points.
    """
    p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    n = p.shape[0]
    if k < 1:
        raise ValueError(f"k (neighbours) must be >= 1, got {k}")
    if n < 2:
        raise ValueError(f"need at least 2 points for neighbours, got {n}")
    k = min(int(k), n - 1)
    out = np.empty((n, k), dtype=np.int64)
    for start in range(0, n, _BLOCK):
        rows = slice(start, min(start + _BLOCK, n))
        d2 = np.sum((p[rows, None, :] - p[None, :, :]) ** 2, axis=-1)
        d2[np.arange(d2.shape[0]), np.arange(rows.start, rows.stop)] = np.inf  # not its own neighbour
        out[rows] = np.argsort(d2, axis=1, kind="stable")[:, :k]
    return out


def count_explained(z: ArrayLike, predicted: ArrayLike, tol: float) -> NDArray[np.int64]:
    """Observed bearings explained by each hypothesis: ``(C,)`` counts.

    ``z (k,)`` observed bearings (rad, wrapped); ``predicted (C, N)`` the bearings (rad,
    wrapped) each of C hypotheses predicts for the N reflectors, NaN for a reflector it
    cannot see. A bearing counts when some visible reflector is predicted within ``tol``
    (rad, circular distance) of it; one reflector may explain several bearings (the
    coarse score of the start-up search).
    """
    zz = np.asarray(z, dtype=np.float64).reshape(-1)
    h = np.asarray(predicted, dtype=np.float64)
    if h.ndim != 2:
        raise ValueError(f"predicted must have shape (C, N), got {h.shape}")
    c, n = h.shape
    if c == 0 or zz.size == 0 or n == 0:
        return np.zeros(c, dtype=np.int64)
    visible = np.isfinite(h)
    nv = np.count_nonzero(visible, axis=1)[:, None]
    hs = np.sort(np.where(visible, h, _INVISIBLE), axis=1)
    offset = _ROW * np.arange(c, dtype=np.float64)[:, None]
    pos = np.searchsorted((hs + offset).ravel(), (zz[None, :] + offset).ravel()).reshape(c, zz.size)
    pos -= np.arange(c, dtype=np.int64)[:, None] * n  # position inside the row, 0..nv
    right = np.where(pos < nv, pos, 0)  # past the last visible one: wrap to the first
    left = np.where(pos > 0, np.minimum(pos - 1, nv - 1), nv - 1)  # before the first: wrap to the last
    rows = np.arange(c)[:, None]
    left, right = np.maximum(left, 0), np.maximum(right, 0)
    near = np.minimum(np.abs(angle_diff(zz[None, :], hs[rows, left])), np.abs(angle_diff(zz[None, :], hs[rows, right])))
    ok = (near < tol) & (nv > 0)
    return np.asarray(ok.sum(axis=1), dtype=np.int64)
