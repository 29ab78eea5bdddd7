"""Optimiser: a toy instance with a known optimum; prune; existing reflectors kept; determinism."""

from __future__ import annotations

import numpy as np

from agvnav.layout.optimise import greedy_cover, optimise, prune
from agvnav.layout.prediction import LayoutProblem, evaluate


def _toy(n_existing: int = 0) -> LayoutProblem:
    """Poses A (x < 0) see sites 0-3, poses B (x > 0) see sites 2-5; three needed: the optimum is 4 sites."""
    head = np.array([[-3.0, 0.0], [-2.0, 0.5], [2.0, 0.5], [3.0, 0.0]])
    sites = np.array([[-6.0, 5.0], [-6.0, -5.0], [0.0, 8.0], [0.0, -8.0], [6.0, 5.0], [6.0, -5.0]])
    vis = np.zeros((4, 6), dtype=bool)
    vis[:2, :4] = True
    vis[2:, 2:] = True
    return LayoutProblem(head, sites, n_existing, vis, 1e-4, 0.0, 1.0, 1.0, 3, 1.0)


def test_greedy_reaches_the_known_optimum() -> None:
    p = _toy()
    order = np.arange(6)
    cover = greedy_cover(p, np.zeros(0, dtype=np.int64), order)
    assert cover.size == 4 and {2, 3} <= set(cover.tolist())
    assert evaluate(p, cover).meets(p)
    res = optimise(p, seed=0)
    assert res.chosen.size == 4 and res.lower_bound <= 4


def test_prune_removes_redundant_sites_down_to_the_optimum() -> None:
    p = _toy()
    out = prune(p, np.arange(6), deadline=float("inf"))
    assert out.size == 4 and evaluate(p, out).meets(p)


def test_existing_reflectors_are_kept() -> None:
    p = _toy(n_existing=2)  # sites 0 and 1 already installed
    res = optimise(p, seed=5)
    assert {0, 1} <= set(res.chosen.tolist())
    assert evaluate(p, res.chosen).meets(p)


def test_same_seed_same_plan() -> None:
    p = _toy()
    assert np.array_equal(optimise(p, seed=7).chosen, optimise(p, seed=7).chosen)
