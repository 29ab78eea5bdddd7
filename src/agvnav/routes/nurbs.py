"""NURBS curves as VDA 5050 orders carry them (``trajectory``: degree, knotVector, controlPoints).

A NURBS of degree ``p`` with control points ``P_i`` and weights ``w_i > 0`` on a
non-decreasing knot vector of ``n + p + 1`` values is

``C(u) = sum_i N_ip(u) w_i P_i / sum_i N_ip(u) w_i``

(``N_ip``: the B-spline basis). It is evaluated here in homogeneous coordinates
(``scipy.interpolate.BSpline`` on ``(w x, w y, w)``); its tangent by the quotient
rule ``C' = (A' - C W') / W`` with ``A = sum N w P``, ``W = sum N w``.
VDA 5050 puts the knots in [0, 1]; the curve is clamped when the first and
last ``p + 1`` knots repeat, so it starts and ends at the first and last
control points, which must then stand on the edge's nodes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import pairwise

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import BSpline

__all__ = ["Nurbs", "nurbs_problem"]


def nurbs_problem(degree: int, knots: Sequence[float], weights: Sequence[float], n_points: int) -> str | None:
    """The first problem of a NURBS definition as one sentence, or None when it is valid."""
    if degree < 1:
        return f"degree must be at least 1, got {degree}"
    if n_points < degree + 1:
        return f"a degree-{degree} NURBS needs at least {degree + 1} control points, got {n_points}"
    if len(knots) != n_points + degree + 1:
        return f"knotVector must have {n_points + degree + 1} values (control points + degree + 1), got {len(knots)}"
    if any(not math.isfinite(k) for k in knots) or any(b < a for a, b in pairwise(knots)):
        return "knotVector must be finite and non-decreasing"
    if knots[degree] >= knots[n_points]:
        return "knotVector spans an empty parameter interval"
    bad = [i for i, w in enumerate(weights) if not (math.isfinite(w) and w > 0.0)]
    if bad:
        return f"controlPoints[{bad[0]}].weight must be positive, got {weights[bad[0]]!r}"
    return None


@dataclass(frozen=True, eq=False)
class Nurbs:
    """A planar NURBS: ``degree``, ``knots`` (n + degree + 1), ``points`` (n, 2) m, ``weights`` (n,)."""

    degree: int
    knots: tuple[float, ...]
    points: NDArray[np.float64]
    weights: NDArray[np.float64]
    _num: BSpline = field(init=False, repr=False)
    _dnum: BSpline = field(init=False, repr=False)

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, dtype=np.float64)
        w = np.asarray(self.weights, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 2 or w.shape != (pts.shape[0],) or not np.all(np.isfinite(pts)):
            raise ValueError(f"points must be finite (n, 2) and weights (n,), got {pts.shape} and {w.shape}")
        problem = nurbs_problem(int(self.degree), list(self.knots), list(w), pts.shape[0])
        if problem is not None:
            raise ValueError(problem)
        hom = np.column_stack([pts * w[:, None], w])
        spline = BSpline(np.asarray(self.knots, dtype=np.float64), hom, int(self.degree), extrapolate=False)
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "_num", spline)
        object.__setattr__(self, "_dnum", spline.derivative())

    @property
    def domain(self) -> tuple[float, float]:
        """Parameter interval ``[u_p, u_n]`` of the curve."""
        return float(self.knots[self.degree]), float(self.knots[len(self.points)])

    def _clip(self, u: ArrayLike) -> NDArray[np.float64]:
        lo, hi = self.domain
        return np.clip(np.asarray(u, dtype=np.float64), lo, hi)

    def point_at(self, u: ArrayLike) -> NDArray[np.float64]:
        """Point (..., 2) (m) at parameter ``u`` (clipped to the domain)."""
        h = self._num(self._clip(u))
        return np.asarray(h[..., :2] / h[..., 2:3])

    def tangent_at(self, u: ArrayLike) -> NDArray[np.float64]:
        """Derivative ``dC/du`` (..., 2) at parameter ``u`` (quotient rule, module doc)."""
        uu = self._clip(u)
        h, dh = self._num(uu), self._dnum(uu)
        c = h[..., :2] / h[..., 2:3]
        return np.asarray((dh[..., :2] - c * dh[..., 2:3]) / h[..., 2:3])

    def heading_at(self, u: ArrayLike) -> NDArray[np.float64]:
        """Tangent heading (rad) at parameter ``u``."""
        d = self.tangent_at(u)
        return np.asarray(np.arctan2(d[..., 1], d[..., 0]))

    def sample(self, step: float, oversample: int = 20) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        """Points (k, 2) and headings (k,) about ``step`` m apart in arclength, and the length (m).

        The arclength is the polyline length of a fine parameter sampling
        (``oversample`` times finer); the samples themselves are exact curve points.
        """
        lo, hi = self.domain
        fine = np.linspace(lo, hi, max(200, oversample * 10 * len(self.points)))
        pf = self.point_at(fine)
        cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pf, axis=0).T))])
        length = float(cum[-1])
        if length <= 0.0:
            raise ValueError("the NURBS has no length")
        s = np.linspace(0.0, length, max(2, math.ceil(length / step) + 1))
        u = np.interp(s, cum, fine)
        return self.point_at(u), self.heading_at(u), length
