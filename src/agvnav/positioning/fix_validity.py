"""When bearings give no fix: coincident reflectors, and P on the line of collinear ones (seed 000 §2.2-2.3).

Degenerate *layouts* flag a fix ``valid=False`` (batches) or raise (one fix):
coincident reflectors, NaN/inf values, and collinear reflectors with every pair of
bearings parallel -- the head stands on their line, where the circle through the
reflectors degenerates and every method is indeterminate (issue 13). :func:`_layout_flags`
and :func:`_parallel_rays` are the definition; :func:`_layout_ok` evaluates them in one
compiled pass (:func:`_layout_ok_kernel`); :func:`_check_single` is the single fix's form.
:func:`agvnav.positioning.triangulation.triangulate` applies them.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agvnav._jit import jit

__all__ = ["LAYOUT_TOL", "PARALLEL_TOL"]

#: Relative tolerance for coincident / collinear reflector layouts.
LAYOUT_TOL = 1e-9
#: Largest |sin| of the pairwise bearing differences for which the rays count as parallel
#: (P on the line of collinear reflectors: the fix is undetermined).
PARALLEL_TOL = 1e-9


def _check_single(r: NDArray[np.float64], b: NDArray[np.float64], h: NDArray[np.float64] | None) -> None:
    """Single-fix path: value problems raise (batches flag them instead). Plain Python: N is small.

    The same tests and sums as the batch flags' definition (:func:`_layout_flags`); the squared
    distances once per pair (``(p - q)**2 == (q - p)**2`` exactly), ``map`` rather than generators
    (issue 29: 11 -> 8 µs CPU of a ~30 µs fix, measured interleaved on a loaded machine).
    """
    pts = r.tolist()
    xs = [p[0] for p in pts]
    ys = [p[1] for p in pts]
    if not (all(map(math.isfinite, xs)) and all(map(math.isfinite, ys))):
        raise ValueError("reflectors contains NaN or inf")
    if not all(map(math.isfinite, b.tolist())):
        raise ValueError("bearings contains NaN or inf")
    if h is not None and not all(map(math.isfinite, h.ravel().tolist())):
        raise ValueError("heading_estimate contains NaN or inf")
    n = len(pts)
    pairs = [(i, j, (xs[i] - xs[j]) ** 2 + (ys[i] - ys[j]) ** 2) for i in range(n) for j in range(i + 1, n)]
    near = LAYOUT_TOL**2 * max([d for _, _, d in pairs], default=0.0)
    for i, j, d in pairs:
        if d <= near:
            raise ValueError(f"reflectors {i} and {j} coincide")
    if n < 3:
        return
    mx, my = sum(xs) / n, sum(ys) / n
    cx = [x - mx for x in xs]
    cy = [y - my for y in ys]
    sxx = sum([c**2 for c in cx])
    syy = sum([c**2 for c in cy])
    sxy = sum([u * v for u, v in zip(cx, cy, strict=True)])
    if sxx * syy - sxy * sxy <= LAYOUT_TOL * (sxx + syy) ** 2 and _parallel_rays(b).any():
        raise _OnReflectorLine  # geometry, not bad input: the batch path flags it invalid


class _OnReflectorLine(Exception):
    """P stands on the line of collinear reflectors (raised and caught inside this module)."""


def _parallel_rays(b: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Per element: every pair of bearings ``(..., N)`` differs by 0 or pi (within ``PARALLEL_TOL``)."""
    with np.errstate(invalid="ignore"):  # NaN bearings: not parallel (flagged as bad values elsewhere)
        d = np.sin(b[..., :, None] - b[..., None, :])
        return np.asarray(np.max(np.abs(d), axis=(-2, -1)) <= PARALLEL_TOL)


def _layout_flags(r: NDArray[np.float64]) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Per-element (coincident, collinear) flags of layouts ``(..., N, 2)``."""
    d = r[..., :, None, :] - r[..., None, :, :]
    dist2 = np.sum(d * d, axis=-1)
    n = r.shape[-2]
    scale = np.max(dist2, axis=(-2, -1))
    off = np.where(np.eye(n, dtype=bool), np.inf, dist2)
    coincident = np.min(off, axis=(-2, -1)) <= LAYOUT_TOL**2 * scale
    c = r - np.mean(r, axis=-2, keepdims=True)
    sxx, syy, sxy = np.sum(c[..., 0] ** 2, -1), np.sum(c[..., 1] ** 2, -1), np.sum(c[..., 0] * c[..., 1], -1)
    collinear = (n >= 3) & (sxx * syy - sxy * sxy <= LAYOUT_TOL * (sxx + syy) ** 2)
    return coincident, collinear


def _layout_ok(r: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.bool_]:
    """``(m,)`` True where a fix's layout and bearings pass the batch checks: the validity flags.

    ``r`` is one shared layout ``(N, 2)`` or one per fix ``(m, N, 2)``, ``b (m, N)``. False where a
    bearing is NaN or inf, the reflectors coincide, or they are collinear and every pair of rays
    is parallel (P on their line): ``~(coincident | collinear & parallel) & finite`` with the flags
    of :func:`_layout_flags` and :func:`_parallel_rays`, which stay the definition (and the test
    oracle). One pass over the fixes (:func:`_layout_ok_kernel`); a shared layout's flags are
    settled once here.
    """
    m = b.shape[0]
    shared = r.ndim == 2
    coincident, collinear = _layout_flags(r) if shared else (False, False)
    ok = np.empty(m, dtype=bool)
    rr = r[None] if shared else r
    _layout_ok_kernel(np.ascontiguousarray(rr), np.ascontiguousarray(b), shared, bool(coincident), bool(collinear),
                      ok)
    return ok


@jit
def _layout_ok_kernel(
    r: NDArray[np.float64],
    b: NDArray[np.float64],
    shared: bool,
    coincident: bool,
    collinear: bool,
    ok: NDArray[np.bool_],
) -> None:
    """:func:`_layout_ok` in one pass: ``ok[k]`` for layouts ``r (1 or m, N, 2)`` (m) and bearings ``b (m, N)`` (rad).

    ``shared``: ``r`` is one layout whose ``coincident``/``collinear`` flags the caller computed
    (:func:`_layout_flags`); otherwise each fix's flags are computed here as :func:`_layout_flags`
    defines them, NaN comparing False as in its reductions. The parallel test is
    :func:`_parallel_rays` over the pairs ``i < j`` (``sin`` is odd; ``sin(0) = 0`` on the diagonal).
    """
    m, n = b.shape
    for k in range(m):
        finite = True
        for i in range(n):
            if not math.isfinite(b[k, i]):
                finite = False
        if not finite:
            ok[k] = False
            continue
        coin, coll = coincident, collinear
        if not shared:
            rk = r[k]
            scale = 0.0
            near = math.inf
            nan = False
            for i in range(n):
                for j in range(n):
                    dx = rk[i, 0] - rk[j, 0]
                    dy = rk[i, 1] - rk[j, 1]
                    d2 = dx * dx + dy * dy
                    if d2 != d2:
                        nan = True
                    elif d2 > scale:
                        scale = d2
                    if i != j and d2 < near:
                        near = d2
            coin = (not nan) and near <= LAYOUT_TOL * LAYOUT_TOL * scale
            mx = 0.0
            my = 0.0
            for i in range(n):
                mx += rk[i, 0]
                my += rk[i, 1]
            mx = mx / n
            my = my / n
            sxx = 0.0
            syy = 0.0
            sxy = 0.0
            for i in range(n):
                cx = rk[i, 0] - mx
                cy = rk[i, 1] - my
                sxx += cx * cx
                syy += cy * cy
                sxy += cx * cy
            tr = sxx + syy
            coll = n >= 3 and sxx * syy - sxy * sxy <= LAYOUT_TOL * (tr * tr)
        if coin:
            ok[k] = False
            continue
        parallel = False
        if coll:
            parallel = True
            for i in range(n):
                for j in range(i + 1, n):
                    if not abs(math.sin(b[k, i] - b[k, j])) <= PARALLEL_TOL:
                        parallel = False
        ok[k] = not parallel
