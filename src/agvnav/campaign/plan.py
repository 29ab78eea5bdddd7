"""The runs of a campaign: swept parameter values and a seed per run, all from the campaign seed.

Run ``i``'s seed is drawn from ``numpy.random.SeedSequence(campaign_seed,
spawn_key=(i,))``, the ``i``-th child that ``SeedSequence(campaign_seed).spawn``
would give, so any run's seed is computed alone, without the others, and the
same campaign seed always gives the same seeds. With ``common_seeds`` the
stream is the replicate number instead of the run index: every grid point then
sees the same random numbers (common random numbers, which sharpen the
comparison between grid points). Random parameters are drawn from the
independent child ``spawn_key=(i, 0)``.

Runs are ordered grid point major, replicate minor:
``index = point * replicates + replicate``.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np

from agvnav.campaign.spec import CampaignSpec, Distribution

__all__ = ["RunPlan", "plan_runs", "run_seed"]

_SEED_BITS = np.uint64(1)  # drop one bit: seeds fit a signed 64-bit Parquet column


@dataclass(frozen=True)
class RunPlan:
    """One run: its index, the swept parameter values (dotted key -> value) and its seed."""

    index: int
    params: dict[str, Any]
    seed: int


def run_seed(campaign_seed: int, stream: int) -> int:
    """The scenario seed of ``stream`` (run index or replicate), 0 <= seed < 2**63.

    Raises
    ------
    ValueError
        If ``campaign_seed`` or ``stream`` is negative.
    """
    if campaign_seed < 0 or stream < 0:
        raise ValueError(f"campaign seed and stream must be >= 0, got {campaign_seed} and {stream}")
    state = np.random.SeedSequence(campaign_seed, spawn_key=(stream,)).generate_state(1, np.uint64)[0]
    return int(state >> _SEED_BITS)


def _draw(dist: Distribution, rng: np.random.Generator) -> Any:
    if dist.uniform is not None:
        return float(rng.uniform(*dist.uniform))
    if dist.normal is not None:
        return float(rng.normal(*dist.normal))
    values = dist.choice or []
    return values[int(rng.integers(len(values)))]


def _random_params(spec: CampaignSpec, index: int) -> dict[str, Any]:
    if not spec.random:
        return {}
    rng = np.random.default_rng(np.random.SeedSequence(spec.seed, spawn_key=(index, 0)))
    return {key: _draw(dist, rng) for key, dist in spec.random.items()}


def plan_runs(spec: CampaignSpec) -> list[RunPlan]:
    """Every run of ``spec``, in index order (deterministic for the campaign seed)."""
    points = list(itertools.product(*spec.grid.values())) if spec.grid else [()]
    reps = spec.replicates
    plans = []
    for p, point in enumerate(points):
        for rep in range(reps):
            index = p * reps + rep
            params = {**dict(zip(spec.grid, point, strict=True)), **_random_params(spec, index)}
            seed = run_seed(spec.seed, rep if spec.common_seeds else index)
            plans.append(RunPlan(index, params, seed))
    return plans
