"""Predicted accuracy at route poses: the bearing-only Cramér-Rao bound of the visible set.

The goniometer measures bearings ``θ_i = atan2(y_i - y, x_i - x) - ψ`` of the
reflectors (seed 000 §2.2, Fig. 1a). With independent bearing noise of std ``σ``
the Fisher information of ``[x, y, ψ]`` is additive over the visible reflectors,

.. math:: I = \\sum_i \\frac{1}{\\sigma^2} J_i^T J_i, \\qquad J_i = [dy_i/d_i^2, -dx_i/d_i^2, -1],

so the planner accumulates ``I`` per pose as reflectors are chosen and inverts it
(:func:`agvnav.positioning.bounds.inv_sym3`) to get the CRLB — the same bound as
:func:`agvnav.positioning.crlb` [seed000 §2.2]. The position error figure is the
largest semi-axis of the CRLB position ellipse, ``sqrt(λ_max(P_xy))``. Degenerate
geometry: three reflectors and the head on one circle (the critical circle of the
relative-angle method, [seed000 §2.2]), or reflectors in line with the head, make
``I`` singular; :func:`critical_distance` measures how far a pose is from it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvnav.layout.visibility import mutual_hiding
from agvnav.positioning.bounds import inv_sym3

__all__ = [
    "LayoutProblem",
    "Prediction",
    "critical_distance",
    "evaluate",
    "information",
    "information_terms",
    "moments",
    "pair_terms",
    "sigmas",
    "sigmas_rms",
    "spread",
]

_CHUNK = 4_000_000


@dataclass(frozen=True)
class LayoutProblem:
    """Arrays of one planning problem.

    ``head`` ``(K, 2)`` goniometer positions at the route poses (m); ``sites`` ``(E + C, 2)``:
    the ``n_existing`` existing reflectors first, then the candidates; ``vis`` ``(K, E + C)``
    range and wall visibility; ``bearing_std`` (rad); ``radius`` of the reflectors (m);
    ``max_pos_sigma`` (m) and ``max_heading_sigma`` (rad) are the target's 1σ limits;
    ``min_visible`` reflectors in view at every pose; ``fraction`` of poses that must meet the accuracy target;
    ``min_spread`` (m) the least spread of the visible reflectors across their best-fit line (not aligned).
    """

    head: NDArray[np.float64]
    sites: NDArray[np.float64]
    n_existing: int
    vis: NDArray[np.bool_]
    bearing_std: float
    radius: float
    max_pos_sigma: float
    max_heading_sigma: float
    min_visible: int
    fraction: float
    min_spread: float = 0.0


@dataclass(frozen=True)
class Prediction:
    """Per-pose prediction for a chosen set: ``visible`` ``(K, S)`` after mutual hiding, ``count`` ``(K,)``,
    ``sigma_pos`` (m) and ``sigma_heading`` (rad) (inf where unobservable), ``rms_pos`` = ``sqrt(trace P_xy)`` (m),
    ``critical`` distance to the
    critical circle (m), ``spread`` of the visible reflectors across their line (m), ``ok`` the pose meets
    the target."""

    visible: NDArray[np.bool_]
    count: NDArray[np.int64]
    sigma_pos: NDArray[np.float64]
    sigma_heading: NDArray[np.float64]
    rms_pos: NDArray[np.float64]
    critical: NDArray[np.float64]
    spread: NDArray[np.float64]
    ok: NDArray[np.bool_]

    @property
    def fraction_ok(self) -> float:
        """Fraction of poses meeting the target."""
        return float(self.ok.mean()) if self.ok.size else 1.0

    def meets(self, problem: LayoutProblem) -> bool:
        """The target holds: ``min_visible`` reflectors in view at every pose, accuracy at ``fraction`` of them."""
        return bool(self.count.min(initial=problem.min_visible) >= problem.min_visible) and (
            self.fraction_ok >= problem.fraction)


def information_terms(head: NDArray[np.float64], refl: NDArray[np.float64], bearing_std: float) -> NDArray[np.float64]:
    """Fisher terms ``(K, C, 6)`` = ``[Ixx, Ixy, Ixψ, Iyy, Iyψ, Iψψ]`` of each reflector at each head (1/m², 1/m, 1).

    One bearing of std ``bearing_std`` (rad) contributes ``J^T J / σ²`` [seed000 §2.2].
    """
    return pair_terms(head[:, None, :], refl[None, :, :], bearing_std)


def pair_terms(head: NDArray[np.float64], refl: NDArray[np.float64], bearing_std: float) -> NDArray[np.float64]:
    """Fisher terms ``(..., 6)`` of reflectors ``refl`` ``(..., 2)`` seen from ``head`` ``(..., 2)`` (broadcast)."""
    dx = refl[..., 0] - head[..., 0]
    dy = refl[..., 1] - head[..., 1]
    d2 = np.maximum(dx * dx + dy * dy, 1e-12)
    jx, jy = dy / d2, -dx / d2
    w = 1.0 / bearing_std**2
    return w * np.stack([jx * jx, jx * jy, -jx, jy * jy, -jy, np.ones_like(jx)], axis=-1)


def information(head: NDArray[np.float64], refl: NDArray[np.float64], vis: NDArray[np.bool_],
                bearing_std: float) -> NDArray[np.float64]:
    """Summed Fisher terms ``(K, 6)`` of the reflectors visible at each head (``vis`` ``(K, S)``); chunked."""
    k = head.shape[0]
    out = np.zeros((k, 6))
    step = max(1, _CHUNK // max(1, 6 * refl.shape[0]))
    for lo in range(0, k, step):
        sl = slice(lo, lo + step)
        out[sl] = np.einsum("ks,ksj->kj", vis[sl].astype(np.float64), information_terms(head[sl], refl, bearing_std))
    return out


def sigmas(info6: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(sigma_pos, sigma_heading)`` from Fisher terms ``(..., 6)``: sqrt of the largest eigenvalue of the CRLB
    position block (m) and of its heading variance (rad); inf where the information is singular."""
    sp, sh, _ = sigmas_rms(info6)
    return sp, sh


def sigmas_rms(info6: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`sigmas` and the predicted RMS position error ``sqrt(trace P_xy)`` (m)."""
    i6 = info6
    mat = np.stack([np.stack([i6[..., 0], i6[..., 1], i6[..., 2]], -1),
                    np.stack([i6[..., 1], i6[..., 3], i6[..., 4]], -1),
                    np.stack([i6[..., 2], i6[..., 4], i6[..., 5]], -1)], -2)
    cov, valid = inv_sym3(mat)
    a, b, c = cov[..., 0, 0], cov[..., 0, 1], cov[..., 1, 1]
    lam = 0.5 * (a + c) + np.sqrt(0.25 * (a - c) ** 2 + b * b)
    with np.errstate(invalid="ignore"):
        sp = np.where(valid & (lam > 0), np.sqrt(np.abs(lam)), np.inf)
        sh = np.where(valid & (cov[..., 2, 2] > 0), np.sqrt(np.abs(cov[..., 2, 2])), np.inf)
        rms = np.where(valid & (a + c > 0), np.sqrt(np.abs(a + c)), np.inf)
    return sp, sh, rms


def moments(refl: NDArray[np.float64], vis: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Moment sums ``(K, 6)`` = ``[n, Σx, Σy, Σx², Σxy, Σy²]`` of the reflectors visible at each pose (additive)."""
    x, y = refl[:, 0], refl[:, 1]
    cols = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=1)
    return np.asarray(vis.astype(np.float64) @ cols)


def spread(mom: NDArray[np.float64]) -> NDArray[np.float64]:
    """Spread (m) of a reflector set across its best-fit line from :func:`moments` ``(..., 6)``: the square root of
    the smaller eigenvalue of the position scatter. Zero for aligned reflectors: the absolute-angle method
    needs "three reflectors not aligned" [seed000 §2.2]."""
    n = np.maximum(mom[..., 0], 1.0)
    mx, my = mom[..., 1] / n, mom[..., 2] / n
    a = mom[..., 3] / n - mx * mx
    b = mom[..., 4] / n - mx * my
    c = mom[..., 5] / n - my * my
    lam = 0.5 * (a + c) - np.sqrt(0.25 * (a - c) ** 2 + b * b)
    return np.sqrt(np.maximum(lam, 0.0))


def critical_distance(head: NDArray[np.float64], refl: NDArray[np.float64], visible: NDArray[np.bool_]) -> NDArray[
        np.float64]:
    """Distance (m) from each head to the circle through its three nearest visible reflectors [seed000 §2.2].

    Three reflectors in line have no circle: the distance is then that of the head
    from their line (the collinear degeneracy). NaN with fewer than three visible.
    """
    d = np.hypot(refl[None, :, 0] - head[:, None, 0], refl[None, :, 1] - head[:, None, 1])
    d = np.where(visible, d, np.inf)
    out = np.full(head.shape[0], np.nan)
    if refl.shape[0] < 3:
        return out
    idx = np.argsort(d, axis=1, kind="stable")[:, :3]
    have = np.isfinite(np.take_along_axis(d, idx, axis=1)).all(axis=1)
    a, b, c = refl[idx[:, 0]], refl[idx[:, 1]], refl[idx[:, 2]]
    ux, uy = b - a, c - a
    den = 2.0 * (ux[:, 0] * uy[:, 1] - ux[:, 1] * uy[:, 0])
    lu, lv = (ux**2).sum(1), (uy**2).sum(1)
    line = np.abs(den) < 1e-9 * (lu + lv)
    safe = np.where(line, 1.0, den)
    cx = (uy[:, 1] * lu - ux[:, 1] * lv) / safe
    cy = (ux[:, 0] * lv - uy[:, 0] * lu) / safe
    r = np.hypot(cx, cy)
    to_circle = np.abs(np.hypot(head[:, 0] - a[:, 0] - cx, head[:, 1] - a[:, 1] - cy) - r)
    n = np.hypot(ux[:, 0], ux[:, 1])
    to_line = np.abs(ux[:, 0] * (head[:, 1] - a[:, 1]) - ux[:, 1] * (head[:, 0] - a[:, 0])) / np.maximum(n, 1e-12)
    out[have] = np.where(line, to_line, to_circle)[have]
    return out


def evaluate(problem: LayoutProblem, chosen: NDArray[np.int64]) -> Prediction:
    """Predict the accuracy at every route pose for the site indices ``chosen`` (into ``problem.sites``).

    Visibility: range and walls (``problem.vis``), then reflectors hiding each other
    (:func:`~agvnav.layout.visibility.mutual_hiding`).
    """
    chosen = np.asarray(chosen, dtype=np.int64)
    refl = problem.sites[chosen]
    vis = mutual_hiding(problem.head, refl, problem.radius, problem.vis[:, chosen])
    sp, sh, rms = sigmas_rms(information(problem.head, refl, vis, problem.bearing_std))
    count = vis.sum(axis=1).astype(np.int64)
    spr = spread(moments(refl, vis))
    ok = (count >= problem.min_visible) & (sp <= problem.max_pos_sigma) & (sh <= problem.max_heading_sigma)
    ok &= spr >= problem.min_spread
    return Prediction(vis, count, sp, sh, rms, critical_distance(problem.head, refl, vis), spr, ok)
