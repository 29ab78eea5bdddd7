"""Reflector layout planner (issue 15): planned against regular spacing, predicted against simulated RMS.

Two halls: the shipped 60 x 40 m warehouse and the generated 100 x 60 m hall with
about 2 km of routes and 1,936 candidate sites (:mod:`agvnav.layout.generate`, shipped
as ``generated_100x60``). ``runtime_s`` is the planning time (validation, visibility,
optimisation), without the baseline tuning and the simulation.

Both halls are driven in the closed loop on their planned maps
(:func:`agvnav.layout.verify.verify_plan`: a differential vehicle whose wheels slip
``verify.wheel_slip_k``, an EKF told that slip, an exact map), each route up to
``verify.max_length_m``. ``simulated_rms_m`` and ``predicted_rms_m`` are one definition,
the RMS of the base_link position-error norm over the driven stretches: measured at
every moving control step, predicted by the EKF's own covariance recursion
along the same stretches (:mod:`agvnav.layout.filtered`, time-averaged ``trace P_xy``
of the actual error). ``crlb_rms_m`` is the single-revolution CRLB of the base_link
pose on the same definition (one fix, no filtering). ``sim_over_pred`` is the pooled
ratio of simulated to predicted RMS (target: within 25 %) and ``sim_over_pred_ci95`` its
95 % interval over the runs (route x seed): one run's RMS scatters widely, the error being
correlated over metres of route (:func:`ratio_with_interval`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from agvnav.layout import LayoutSpec, load_layout, plan_layout
from agvnav.layout.generate import generated_hall
from agvnav.layout.verify import verify_plan

__all__ = ["PRIORITY", "TITLE", "ratio_with_interval", "run"]

TITLE = "Reflector layout planner: reflectors planned vs regular spacing, predicted vs simulated RMS"

#: Columns a narrow terminal keeps, most important first.
PRIORITY = (
    "hall", "reflectors_planned", "reflectors_baseline", "fewer_than_baseline_pct", "route_fraction_meeting_target",
    "predicted_rms_m", "simulated_rms_m", "sim_over_pred", "runtime_s", "route_km", "candidates",
)


def _weighted_rms(rows: list[dict[str, Any]], key: str) -> float | None:
    use = [r for r in rows if r[key] is not None]
    n = sum(r["samples"] for r in use)
    return math.sqrt(sum(r["samples"] * r[key] ** 2 for r in use) / n) if n else None


def ratio_with_interval(rows: list[dict[str, Any]]) -> tuple[float | None, tuple[float, float] | None]:
    """Simulated over predicted RMS pooled over the runs of ``rows`` and its 95 % jackknife interval.

    Per run (route and seed) the sample-weighted sums of measured and predicted mean squares;
    the ratio is ``sqrt(Σ measured / Σ predicted)``. One run's error is strongly correlated
    along the route (the filter's memory), so the interval comes from leaving out one *run*
    at a time: ``R ± 1.96 sqrt((n-1)/n Σ (R_(i) - mean)²)`` (None with fewer than 3 runs).
    """
    runs: dict[tuple[str, int], list[float]] = {}
    for r in rows:
        if r["predicted_rms_m"] is None:
            continue
        acc = runs.setdefault((r["route"], r["seed"]), [0.0, 0.0])
        acc[0] += r["samples"] * r["measured_rms_m"] ** 2
        acc[1] += r["samples"] * r["predicted_rms_m"] ** 2
    if not runs:
        return None, None
    m = [v[0] for v in runs.values()]
    p = [v[1] for v in runs.values()]
    ratio = math.sqrt(sum(m) / sum(p))
    n = len(m)
    if n < 3:
        return ratio, None
    loo = [math.sqrt((sum(m) - m[i]) / (sum(p) - p[i])) for i in range(n)]
    mean = sum(loo) / n
    half = 1.96 * math.sqrt((n - 1) / n * sum((x - mean) ** 2 for x in loo))
    return ratio, (ratio - half, ratio + half)


def _record(hall: str, spec: LayoutSpec, routes: Sequence[int], seeds: int, budget: float,
            seed: int) -> dict[str, Any]:
    plan = plan_layout(spec.copy_attached({"seed": seed}), time_budget_s=budget)
    rows = [row for k in range(seeds) for row in verify_plan(plan, seed=seed + 1000 * k, routes=routes)]
    both = [r for r in rows if r["predicted_rms_m"] is not None]
    done = sum(1 for run in {(r["route"], r["seed"], r["outcome"]) for r in rows} if run[2] == "completed")
    sim, pred = _weighted_rms(both, "measured_rms_m"), _weighted_rms(both, "predicted_rms_m")
    ratio, ci = ratio_with_interval(rows)
    driven = seeds * sum(min(float(plan.poses.s[plan.poses.route == i].max()), spec.verify.max_length_m)
                         for i in routes)
    return {
        "hall": hall,
        "route_km": round(sum(float(plan.poses.s[plan.poses.route == i].max()) for i in range(len(spec.routes))) / 1e3,
                          3),
        "candidates": int(plan.problem.sites.shape[0] - plan.problem.n_existing),
        "reflectors_planned": int(plan.result.chosen.size),
        "reflectors_baseline": int(plan.baseline.size),
        "fewer_than_baseline_pct": round(100.0 * (1.0 - plan.result.chosen.size / plan.baseline.size), 1),
        "lower_bound_new": plan.result.lower_bound,
        "route_fraction_meeting_target": round(plan.prediction.fraction_ok, 4),
        "driven_km": round(driven / 1e3, 3),
        "predicted_rms_m": pred,
        "simulated_rms_m": sim,
        "sim_over_pred": round(ratio, 3) if ratio is not None else None,
        "sim_over_pred_ci95": f"{ci[0]:.2f}-{ci[1]:.2f}" if ci is not None else None,
        "crlb_rms_m": _weighted_rms(both, "crlb_rms_m"),
        "relocalisations": sum({(r["route"], r["seed"]): r["relocalisations"] for r in rows}.values()),
        "runs_completed": f"{done}/{seeds * len(routes)}",
        "runtime_s": round(plan.runtime_s, 2),
    }


def run(quick: bool, seed: int) -> list[dict[str, Any]]:
    """One record per hall: planned and baseline counts, target fraction, predicted and simulated RMS, runtime.

    Quick: the warehouse's aisle 1 and cross aisle with 3 seeds each; the generated hall's two perimeter
    loops only (planned, and driven 100 m each with 2 seeds). Full: every route of the warehouse with 4 seeds,
    every route of the generated hall (cut at 100 m) once.
    """
    warehouse = load_layout("warehouse")
    gen = generated_hall(quick)
    return [
        _record("warehouse_60x40", warehouse, [1, 4] if quick else range(len(warehouse.routes)), 3 if quick else 4,
                10.0 if quick else 30.0, seed),
        _record("generated_100x60" + (" (loops only)" if quick else ""), gen, range(len(gen.routes)),
                2 if quick else 1, 5.0 if quick else 20.0, seed),
    ]
