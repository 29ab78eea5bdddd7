"""Choose reflector sites: greedy on a submodular coverage surrogate, accuracy repair, then local improvement.

Stage 1 (greedy cover): ``f(S) = Σ_k min(n_k(S), m_k)`` counts, per route pose ``k``,
the chosen reflectors it sees, capped at the target count ``m_k`` (``min_visible``, or
fewer where fewer sites are visible at all). ``f`` is monotone submodular (a sum of
concave functions of modular counts), so Wolsey's bound holds: the greedy cover uses
at most ``H(Δ) · OPT`` sites, ``Δ = max_c f({c})``, which gives the lower bound
``OPT ≥ ⌈n_greedy / H(Δ)⌉`` reported in :class:`PlanResult` (with the trivial
``OPT ≥ m``). Stage 2 (repair): add the site that brings most failing poses under the
CRLB target (:mod:`agvnav.layout.prediction`). Stage 3 (local improvement): remove
sites while at least ``fraction`` of the poses still meet the target, then try swaps
of each site for a nearby one that frees another removal. Existing reflectors are
never removed. Ties are broken by a permutation drawn from the seed, so a seed
reproduces the plan exactly.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvnav.layout.prediction import (
    LayoutProblem,
    evaluate,
    information,
    information_terms,
    moments,
    pair_terms,
    sigmas,
    spread,
)

__all__ = ["PlanResult", "greedy_cover", "optimise", "prune", "repair", "swap_improve"]


@dataclass(frozen=True)
class PlanResult:
    """Chosen site indices (into ``problem.sites``, existing first), the greedy-cover size, and the lower bound."""

    chosen: NDArray[np.int64]
    n_greedy: int
    lower_bound: int
    guarantee: str


def _harmonic(n: int) -> float:
    return float(sum(1.0 / i for i in range(1, max(1, n) + 1)))


def greedy_cover(problem: LayoutProblem, start: NDArray[np.int64], order: NDArray[np.int64]) -> NDArray[np.int64]:
    """Greedy maximisation of the capped coverage ``Σ_k min(n_k, m_k)`` from ``start`` until it is full.

    ``order`` is a permutation of the sites used to break ties (first in ``order`` wins).
    """
    vis = problem.vis.astype(np.float32)
    cap = np.minimum(problem.vis.sum(axis=1), problem.min_visible)
    count = vis[:, start].sum(axis=1) if start.size else np.zeros(vis.shape[0], np.float32)
    chosen = list(start.tolist())
    free = np.ones(vis.shape[1], dtype=bool)
    free[start] = False
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    while True:
        need = (count < cap).astype(np.float32)
        if not need.any():
            break
        gain = np.where(free, need @ vis, -1.0)
        best = float(gain.max())
        if best <= 0.0:
            break
        c = int(np.flatnonzero(gain == best)[np.argmin(rank[gain == best])])
        chosen.append(c)
        free[c] = False
        count += vis[:, c]
    return np.asarray(chosen, dtype=np.int64)


def repair(problem: LayoutProblem, chosen: NDArray[np.int64], order: NDArray[np.int64],
           max_add: int = 200) -> NDArray[np.int64]:
    """Add sites one at a time, each the one that brings the most failing poses to the target.

    Only the (failing pose, free site) pairs in view change, so the gains are computed on
    those pairs alone.
    """
    chosen = np.asarray(chosen, dtype=np.int64)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    own = moments(problem.sites, np.eye(problem.sites.shape[0], dtype=bool))  # (C, 6): each site alone
    for _ in range(max_add):
        pred = evaluate(problem, chosen)
        if pred.fraction_ok >= 1.0:
            break
        fail = np.flatnonzero(~pred.ok)
        free = np.setdiff1d(np.arange(problem.sites.shape[0]), chosen)
        kk, cc = np.nonzero(problem.vis[np.ix_(fail, free)])
        if kk.size == 0:
            break
        info = information(problem.head[fail], problem.sites[chosen], pred.visible[fail], problem.bearing_std)
        mom = moments(problem.sites[chosen], pred.visible[fail])
        site = free[cc]
        sp, sh = sigmas(info[kk] + pair_terms(problem.head[fail[kk]], problem.sites[site], problem.bearing_std))
        fixed = (pred.count[fail[kk]] + 1 >= problem.min_visible) & (sp <= problem.max_pos_sigma)
        fixed &= (sh <= problem.max_heading_sigma) & (spread(mom[kk] + own[site]) >= problem.min_spread)
        gain = np.bincount(cc, weights=fixed.astype(np.float64), minlength=free.size)
        if gain.max() <= 0:
            break
        best = free[gain == gain.max()]
        chosen = np.append(chosen, best[np.argmin(rank[best])])
    return chosen


def _fraction_without(problem: LayoutProblem, info: NDArray[np.float64], count: NDArray[np.int64],
                      site: int, terms: NDArray[np.float64]) -> float:
    v = problem.vis[:, site]
    sp, sh = sigmas(info - v[:, None] * terms)
    left = count - v
    if left.min(initial=problem.min_visible) < problem.min_visible:
        return 0.0
    ok = (sp <= problem.max_pos_sigma) & (sh <= problem.max_heading_sigma)
    return float(ok.mean())


def prune(problem: LayoutProblem, chosen: NDArray[np.int64], deadline: float) -> NDArray[np.int64]:
    """Remove sites (least-needed first) while the target holds (:meth:`Prediction.meets`).

    A removal is screened on the additive information (no hiding) and confirmed by a full
    :func:`~agvnav.layout.prediction.evaluate`. Existing reflectors are kept.
    """
    chosen = np.asarray(chosen, dtype=np.int64)
    changed = True
    while changed and time.perf_counter() < deadline:
        changed = False
        vis = problem.vis[:, chosen]
        info = information(problem.head, problem.sites[chosen], vis, problem.bearing_std)
        count = vis.sum(axis=1).astype(np.int64)
        slack = (count[:, None] - problem.min_visible)[:, :] * vis
        movable = [i for i in np.argsort(slack.sum(axis=0) / np.maximum(vis.sum(axis=0), 1), kind="stable")[::-1]
                   if chosen[i] >= problem.n_existing]
        for i in movable:
            site = int(chosen[i])
            terms = information_terms(problem.head, problem.sites[site:site + 1], problem.bearing_std)[:, 0]
            if _fraction_without(problem, info, count, site, terms) < problem.fraction:
                continue
            trial = np.delete(chosen, i)
            if evaluate(problem, trial).meets(problem):
                chosen, changed = trial, True
                break
            if time.perf_counter() > deadline:
                break
    return chosen


def _swap_screen(problem: LayoutProblem, chosen: NDArray[np.int64], i: int,
                 near: NDArray[np.int64]) -> NDArray[np.int64]:
    """The sites of ``near`` that can replace ``chosen[i]`` with the target still met (additive information)."""
    keep = np.delete(chosen, i)
    vis = problem.vis[:, keep]
    info = information(problem.head, problem.sites[keep], vis, problem.bearing_std)
    count = vis.sum(axis=1)
    v = problem.vis[:, near]
    sp, sh = sigmas(info[:, None, :] + v[..., None] * information_terms(problem.head, problem.sites[near],
                                                                         problem.bearing_std))
    ok = (sp <= problem.max_pos_sigma) & (sh <= problem.max_heading_sigma)
    good = ((count[:, None] + v) >= problem.min_visible).all(axis=0) & (ok.mean(axis=0) >= problem.fraction)
    return near[good]


def swap_improve(problem: LayoutProblem, chosen: NDArray[np.int64], deadline: float,
                 radius: float = 8.0, tries: int = 2) -> NDArray[np.int64]:
    """Move each site to a nearby free site (within ``radius`` m) when that lets :func:`prune` drop another.

    Swaps are screened on the additive information; at most ``tries`` screened swaps per
    site go on to a full prune.
    """
    chosen = np.asarray(chosen, dtype=np.int64)
    i = 0
    while i < chosen.size and time.perf_counter() < deadline:
        site = int(chosen[i])
        if site < problem.n_existing:
            i += 1
            continue
        near = np.flatnonzero(np.hypot(*(problem.sites - problem.sites[site]).T) <= radius)
        near = np.setdiff1d(near[near >= problem.n_existing], chosen)
        for c in _swap_screen(problem, chosen, i, near)[:tries]:
            trial = chosen.copy()
            trial[i] = c
            if not evaluate(problem, trial).meets(problem):
                continue
            pruned = prune(problem, trial, deadline)
            if pruned.size < chosen.size:
                chosen = pruned
                break
        i += 1
    return chosen


def optimise(problem: LayoutProblem, seed: int, time_budget_s: float = 30.0) -> PlanResult:
    """Plan: greedy cover, repair, prune, swap; deterministic for ``seed`` (within the time budget)."""
    rng = np.random.default_rng(seed)
    order = rng.permutation(problem.sites.shape[0]).astype(np.int64)
    start = np.arange(problem.n_existing, dtype=np.int64)
    cover = greedy_cover(problem, start, order)
    n_greedy = int(cover.size - problem.n_existing)
    cap = np.minimum(problem.vis.sum(axis=1), problem.min_visible)
    delta = int((problem.vis[:, problem.n_existing:] & (cap > 0)[:, None]).sum(axis=0).max(initial=0))
    bound = max(problem.min_visible - problem.n_existing, math.ceil(n_greedy / _harmonic(delta)), 0)
    deadline = time.perf_counter() + time_budget_s
    chosen = repair(problem, cover, order)
    chosen = prune(problem, chosen, deadline)
    chosen = swap_improve(problem, chosen, deadline)
    guarantee = (f"greedy cover of {n_greedy} sites is within H({delta}) = {_harmonic(delta):.2f} x the smallest "
                 f"full cover (Wolsey 1982), so a full cover needs >= {bound} new reflectors")
    return PlanResult(np.sort(chosen), n_greedy, bound, guarantee)
