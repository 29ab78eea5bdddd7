"""The regular-spacing baseline: reflectors every ``s`` metres along every candidate face, ``s`` tuned to the target.

This is what an installer does without a planner: one spacing for all walls and
rack faces. The spacing is scanned from the goniometer range down to the site
spacing (geometric steps of 5 %); the largest spacing whose layout meets the same
target (same :class:`~agvnav.layout.prediction.LayoutProblem`) is the baseline.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agvnav.layout.hall import Candidates
from agvnav.layout.prediction import LayoutProblem, evaluate

__all__ = ["regular_layout", "tune_baseline"]


def regular_layout(cands: Candidates, spacing: float) -> NDArray[np.int64]:
    """Candidate indices nearest to every ``spacing`` m along each face entry (``cands.along``), no explicit ones."""
    if not spacing > 0.0:
        raise ValueError(f"spacing must be positive, got {spacing}")
    out: list[int] = []
    for site in np.unique(cands.site[cands.site >= 0]):
        idx = np.flatnonzero(cands.site == site)
        a = cands.along[idx]
        length = float(a.max() - a.min())
        n = max(1, math.ceil(length / spacing))
        marks = a.min() + (np.arange(n) + 0.5) * (length / n) if n > 1 else np.array([a.min() + 0.5 * length])
        pick = np.unique(np.abs(a[None, :] - marks[:, None]).argmin(axis=1))
        out.extend(idx[pick].tolist())
    return np.asarray(sorted(out), dtype=np.int64)


def tune_baseline(problem: LayoutProblem, cands: Candidates, max_spacing: float,
                  min_spacing: float) -> tuple[NDArray[np.int64], float]:
    """``(chosen site indices including the existing ones, spacing m)`` of the sparsest regular layout meeting the
    target; the densest one tried if none does."""
    existing = np.arange(problem.n_existing, dtype=np.int64)
    spacing = max_spacing
    chosen = existing
    while spacing >= min_spacing * 0.999:
        chosen = np.concatenate([existing, problem.n_existing + regular_layout(cands, spacing)])
        if evaluate(problem, chosen).meets(problem):
            return chosen, spacing
        spacing /= 1.05
    return chosen, spacing * 1.05
