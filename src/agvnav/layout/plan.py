"""The layout planner end to end: spec -> problem -> optimised and baseline layouts -> map and table.

:func:`plan_layout` validates the geometry (:mod:`agvnav.layout.hall`), builds the
poses x sites visibility (:mod:`agvnav.layout.visibility`), checks that the target
can be met at all (:func:`coverage_limits`: a route pose that no choice of sites
can serve is reported with its reason — out of range, occluded or degenerate —
and the plan refused), optimises (:mod:`agvnav.layout.optimise`) and tunes the
regular-spacing baseline (:mod:`agvnav.layout.baseline`) against the same target.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.layout.baseline import tune_baseline
from agvnav.layout.hall import (
    Candidates,
    Hall,
    RoutePoses,
    build_candidates,
    build_hall,
    check_site,
    route_poses,
    routes_as_paths,
)
from agvnav.layout.optimise import PlanResult, optimise
from agvnav.layout.prediction import LayoutProblem, Prediction, evaluate, information, sigmas
from agvnav.layout.schema import LayoutSpec
from agvnav.layout.visibility import mutual_hiding, visibility
from agvnav.positioning import encoder_bearing_std
from agvnav.world import Reflector, WorldMap

__all__ = ["LayoutPlan", "TargetUnreachable", "build_problem", "coverage_limits", "plan_layout", "summary_rows"]


class TargetUnreachable(ValueError):
    """No choice of candidate sites meets the target: ``points`` lists the route poses that cannot be covered."""

    def __init__(self, message: str, points: list[dict[str, Any]]) -> None:
        super().__init__(message)
        self.points = points


@dataclass(frozen=True)
class LayoutPlan:
    """A finished plan: inputs, the chosen and baseline site indices, predictions, the output map."""

    spec: LayoutSpec
    hall: Hall
    candidates: Candidates
    poses: RoutePoses
    problem: LayoutProblem
    result: PlanResult
    prediction: Prediction
    baseline: NDArray[np.int64]
    baseline_spacing_m: float
    baseline_prediction: Prediction
    runtime_s: float

    @property
    def world(self) -> WorldMap:
        """The planned reflector map with the hall walls (loads in ``agvnav simulate``)."""
        return self.world_of(self.result.chosen)

    def world_of(self, chosen: NDArray[np.int64]) -> WorldMap:
        """A map with the hall walls and the sites ``chosen`` (existing reflectors keep their ids)."""
        r = self.spec.goniometer.reflector_radius_m
        refl = []
        for i in chosen:
            if i < self.problem.n_existing:
                e = self.spec.existing[int(i)]
                refl.append(Reflector(e.id, e.x, e.y, r))
            else:
                x, y = self.problem.sites[int(i)]
                refl.append(Reflector(f"L{int(i) - self.problem.n_existing + 1}", float(x), float(y), r))
        return self.hall.world(refl)


def bearing_std(spec: LayoutSpec) -> float:
    """Bearing noise std (rad): the given one, else the encoder quantisation [seed000 §4.1]."""
    g = spec.goniometer
    return math.radians(g.bearing_std_deg) if g.bearing_std_deg is not None else encoder_bearing_std(g.pulses_per_rev)


#: Spacing (m) of the fine check of the visible count (the simulator checks its paths every 0.1 m).
FINE_SPACING_M = 0.1


def fine_cover(spec: LayoutSpec, hall: Hall, problem: LayoutProblem, chosen: NDArray[np.int64]) -> NDArray[np.int64]:
    """Add sites until ``min_visible`` reflectors are in sight every :data:`FINE_SPACING_M` m of the routes.

    The planning poses are ``route_spacing_m`` apart; a rack corner can hide a reflector
    between two of them. At the fine poses that see too few, the site that fills most of
    the shortfall is added (greedy cover), until none is short.
    """
    fine = route_poses(spec, hall, routes_as_paths(spec), FINE_SPACING_M)
    g, m = spec.goniometer, problem.min_visible
    chosen = np.asarray(chosen, dtype=np.int64)
    for _ in range(problem.sites.shape[0]):
        vis = mutual_hiding(fine.head, problem.sites[chosen], problem.radius,
                            visibility(fine.head, problem.sites[chosen], hall.segments, g.min_range_m, g.max_range_m))
        short = np.flatnonzero(vis.sum(axis=1) < m)
        if short.size == 0:
            break
        need = (m - vis[short].sum(axis=1)).astype(np.float64)
        cand = visibility(fine.head[short], problem.sites, hall.segments, g.min_range_m, g.max_range_m)
        cand[:, chosen] = False
        gain = np.minimum(cand, need[:, None] > 0).astype(np.float64).T @ need
        if gain.max() <= 0:
            break
        chosen = np.append(chosen, int(np.argmax(gain)))
    return np.sort(chosen)


def build_problem(spec: LayoutSpec) -> tuple[Hall, Candidates, RoutePoses, LayoutProblem]:
    """Validated geometry and the arrays of the planning problem (existing reflectors first)."""
    hall = build_hall(spec)
    paths = routes_as_paths(spec)
    poses = route_poses(spec, hall, paths)
    cands = build_candidates(spec, hall)
    g = spec.goniometer
    for i, e in enumerate(spec.existing):
        check_site(spec, hall, ("existing", i), (e.x, e.y), g.reflector_radius_m)
    existing = np.array([[e.x, e.y] for e in spec.existing], dtype=np.float64).reshape(-1, 2)
    sites = np.concatenate([existing, cands.xy])
    vis = visibility(poses.head, sites, hall.segments, g.min_range_m, g.max_range_m)
    t = spec.target
    problem = LayoutProblem(poses.head, sites, existing.shape[0], vis, bearing_std(spec), g.reflector_radius_m,
                            t.position_3sigma_m / 3.0, math.radians(t.heading_3sigma_deg) / 3.0, t.min_visible,
                            t.fraction, t.min_spread_m)
    return hall, cands, poses, problem


def coverage_limits(spec: LayoutSpec, poses: RoutePoses, problem: LayoutProblem) -> list[dict[str, Any]]:
    """Route poses that no choice of sites can bring to the target, each with why.

    ``out of range``: fewer than ``min_visible`` sites within the goniometer's range;
    ``occluded``: enough in range but fewer in line of sight; ``degenerate``: enough
    visible, but even all of them miss the CRLB target (critical circle, collinear or too far).
    """
    g = spec.goniometer
    d = np.hypot(*(problem.sites[None, :, :] - poses.head[:, None, :]).transpose(2, 0, 1))
    in_range = ((d >= g.min_range_m) & (d <= g.max_range_m)).sum(axis=1)
    n_vis = problem.vis.sum(axis=1)
    sp, sh = sigmas(information(problem.head, problem.sites, problem.vis, problem.bearing_std))
    bad_crlb = (sp > problem.max_pos_sigma) | (sh > problem.max_heading_sigma)
    m = problem.min_visible
    out = []
    for k in np.flatnonzero((n_vis < m) | bad_crlb):
        reason = "out of range" if in_range[k] < m else ("occluded" if n_vis[k] < m else "degenerate")
        out.append({"route": spec.routes[int(poses.route[k])].name, "s_m": float(poses.s[k]),
                    "x": float(poses.pose[k, 0]), "y": float(poses.pose[k, 1]), "reason": reason,
                    "in_range": int(in_range[k]), "visible": int(n_vis[k])})
    return out


def _unreachable_message(bad: list[dict[str, Any]], total: int, fraction: float) -> str:
    blind = [b for b in bad if b["reason"] != "degenerate"]
    if blind:
        f = blind[0]
        return (f"target cannot be met: {len(blind)} of {total} route points cannot see "
                f"{'enough' if f['visible'] else 'any'} candidate sites ({_reasons(blind)}); first: route "
                f"{f['route']!r} at s = {f['s_m']:.2f} m ({f['x']:.2f}, {f['y']:.2f}): {f['reason']} "
                f"({f['in_range']} sites in range, {f['visible']} in sight)")
    f = bad[0]
    return (f"target cannot be met: {len(bad)} of {total} route points ({100 * len(bad) / total:.1f} %, more than "
            f"the allowed {100 * (1 - fraction):.1f} %) miss the accuracy with every candidate site ({_reasons(bad)}); "
            f"first: route {f['route']!r} at s = {f['s_m']:.2f} m ({f['x']:.2f}, {f['y']:.2f}): {f['reason']} "
            f"({f['in_range']} sites in range, {f['visible']} in sight)")


def _reasons(bad: list[dict[str, Any]]) -> str:
    counts: dict[str, int] = {}
    for b in bad:
        counts[b["reason"]] = counts.get(b["reason"], 0) + 1
    return ", ".join(f"{n} {r}" for r, n in sorted(counts.items()))


def plan_layout(spec: LayoutSpec, time_budget_s: float = 40.0) -> LayoutPlan:
    """Plan the reflector layout of ``spec``; TargetUnreachable (a ValueError) when no candidate set can meet it."""
    t0 = time.perf_counter()
    hall, cands, poses, problem = build_problem(spec)
    bad = coverage_limits(spec, poses, problem)
    total = poses.head.shape[0]
    blind = [b for b in bad if b["reason"] != "degenerate"]
    if blind or 1.0 - len(bad) / total < spec.target.fraction:
        raise TargetUnreachable(_unreachable_message(bad, total, spec.target.fraction), bad)
    result = optimise(problem, spec.seed, time_budget_s)
    result = dataclasses.replace(result, chosen=fine_cover(spec, hall, problem, result.chosen))
    runtime = time.perf_counter() - t0
    min_spacing = min((s.spacing_m for s in spec.candidates.sites), default=1.0)
    base, spacing = tune_baseline(problem, cands, spec.goniometer.max_range_m, min_spacing)
    return LayoutPlan(spec, hall, cands, poses, problem, result, evaluate(problem, result.chosen), base, spacing,
                      evaluate(problem, base), runtime)


def summary_rows(plan: LayoutPlan) -> list[dict[str, Any]]:
    """The table: planned and baseline layouts side by side (reflectors, % meeting target, σ figures)."""
    rows = []
    for name, chosen, pred in (("planned", plan.result.chosen, plan.prediction),
                               ("baseline", plan.baseline, plan.baseline_prediction)):
        sp = pred.sigma_pos
        finite = sp[np.isfinite(sp)]
        rows.append({
            "layout": name,
            "reflectors": int(chosen.size),
            "new_reflectors": int(np.sum(chosen >= plan.problem.n_existing)),
            "meeting_target_pct": round(100.0 * pred.fraction_ok, 2),
            "sigma_pos_p50_mm": round(1e3 * float(np.percentile(finite, 50)), 3) if finite.size else None,
            "sigma_pos_p99_mm": round(1e3 * float(np.percentile(sp, 99)), 3) if np.isfinite(sp).all() else None,
            "sigma_pos_worst_mm": round(1e3 * float(sp.max()), 3) if np.isfinite(sp).all() else None,
            "sigma_heading_worst_deg": round(math.degrees(float(pred.sigma_heading.max())), 5),
            "min_visible": int(pred.count.min()),
        })
    return rows
