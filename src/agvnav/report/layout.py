"""Heat map of a reflector layout: predicted 3σ position error and visible-reflector count over the hall.

matplotlib (Agg) is imported lazily through :func:`agvnav.report.plots.pyplot`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from agvnav._json import json_text
from agvnav.layout.field import hall_field
from agvnav.layout.plan import LayoutPlan, summary_rows
from agvnav.layout.prediction import LayoutProblem, Prediction
from agvnav.report.files import atomic_dir
from agvnav.report.plots import pyplot
from agvnav.world import save_map

__all__ = ["LAYOUT_MARKER", "plan_record", "plot_layout_heatmap", "write_layout"]


def plot_layout_heatmap(plan: LayoutPlan, out: str | Path, worst: int = 10) -> Path:
    """Write a two-panel PNG: predicted 3σ position error (mm, log colour) and visible count, with the hall,
    routes, planned reflectors and the ``worst`` route points (largest predicted σ) marked. Returns ``out``."""
    plt = pyplot()
    from matplotlib.colors import LogNorm  # noqa: PLC0415  (matplotlib stays lazy)

    field = hall_field(plan)
    three_sigma_mm = 3e3 * field.sigma_pos
    finite = np.isfinite(three_sigma_mm)
    cap = 10 * 3e3 * plan.problem.max_pos_sigma
    shown = np.where(finite, np.minimum(three_sigma_mm, cap), np.where(field.count >= 0, cap, np.nan))
    x0, y0, x1, y1 = plan.hall.outer.bounds
    fig, axes = plt.subplots(2, 1, figsize=(10, 2 * 10 * (y1 - y0) / (x1 - x0) + 1.5), constrained_layout=True)
    extent = (float(field.x[0]), float(field.x[-1]), float(field.y[0]), float(field.y[-1]))
    lo = max(float(np.nanmin(shown)), 1e-3) if np.isfinite(shown).any() else 1e-3
    im = axes[0].imshow(shown, origin="lower", extent=extent, cmap="viridis", norm=LogNorm(vmin=lo, vmax=cap))
    fig.colorbar(im, ax=axes[0], label=f"predicted 3σ position error (mm; top colour: ≥ {cap:.0f} or unobservable)")
    counts = np.where(field.count >= 0, field.count, np.nan).astype(float)
    im2 = axes[1].imshow(counts, origin="lower", extent=extent, cmap="magma", vmin=0)
    fig.colorbar(im2, ax=axes[1], label="visible reflectors")
    refl = plan.problem.sites[plan.result.chosen]
    order = np.argsort(plan.prediction.sigma_pos)[::-1][:worst]
    for ax, title in zip(axes, ("predicted 3σ position error", "visible reflectors"), strict=True):
        _draw_hall(ax, plan)
        for r in np.unique(plan.poses.route):
            m = plan.poses.route == r
            ax.plot(plan.poses.pose[m, 0], plan.poses.pose[m, 1], color="white", lw=1.0)
        ax.plot(refl[:, 0], refl[:, 1], "^", color="red", ms=6, mec="black", label="reflectors")
        ax.plot(plan.poses.pose[order, 0], plan.poses.pose[order, 1], "x", color="orange", ms=9, mew=2,
                label=f"{worst} worst route points")
        ax.set_title(f"{plan.spec.name}: {title} ({plan.result.chosen.size} reflectors)")
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    axes[0].legend(loc="upper right", fontsize=7)
    out = Path(out)
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out


def _draw_hall(ax: object, plan: LayoutPlan) -> None:
    polys = [plan.hall.outer, *plan.hall.occluders.values()]
    for poly in polys:
        c = np.asarray(poly.exterior.coords)
        ax.plot(c[:, 0], c[:, 1], color="black", lw=1.2)  # type: ignore[attr-defined]


def plan_record(plan: LayoutPlan) -> dict[str, Any]:
    """The plan as a JSON-ready dict: target, table rows, bound, reflectors, failing route points (and why)."""
    pred = plan.prediction
    fail = np.flatnonzero(~pred.ok)
    prob = plan.problem
    return {
        "name": plan.spec.name,
        "target": plan.spec.target.model_dump(),
        "sigma_definition": "sigma_pos: largest semi-axis of the CRLB position ellipse of one revolution (m); "
                            "the target is 3 sigma",
        "table": summary_rows(plan),
        "baseline_spacing_m": plan.baseline_spacing_m,
        "greedy_cover": plan.result.n_greedy,
        "lower_bound_new_reflectors": plan.result.lower_bound,
        "guarantee": plan.result.guarantee,
        "runtime_s": plan.runtime_s,
        "route_points": int(pred.ok.size),
        "reflectors": [r.to_dict() for r in plan.world.reflectors],
        "points_missing_target": [
            {"route": plan.spec.routes[int(plan.poses.route[k])].name, "s_m": float(plan.poses.s[k]),
             "x": float(plan.poses.pose[k, 0]), "y": float(plan.poses.pose[k, 1]), "visible": int(pred.count[k]),
             "sigma_pos_m": _finite(pred.sigma_pos[k]), "critical_distance_m": _finite(pred.critical[k]),
             "spread_m": float(pred.spread[k]), "why": _why(prob, pred, int(k))}
            for k in fail
        ],
    }


def _why(prob: LayoutProblem, pred: Prediction, k: int) -> list[str]:
    """Which parts of the target route pose ``k`` misses (names as in the layout file's ``target:``)."""
    out = []
    if pred.count[k] < prob.min_visible:
        out.append("min_visible")
    if not pred.sigma_pos[k] <= prob.max_pos_sigma:
        out.append("position_3sigma_m")
    if not pred.sigma_heading[k] <= prob.max_heading_sigma:
        out.append("heading_3sigma_deg")
    if not pred.spread[k] >= prob.min_spread:
        out.append("min_spread_m")
    return out


def _finite(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


#: The file that makes a folder an ``agvnav layout`` result (:func:`agvnav.report.files.check_out_dir`).
LAYOUT_MARKER = "plan.json"


def write_layout(plan: LayoutPlan, out_dir: str | Path, force: bool = False) -> dict[str, Path]:
    """Write ``map.yaml`` (loads in ``agvnav simulate``), ``heatmap.png`` and ``plan.json`` into ``out_dir``.

    Atomically, as a run (:func:`agvnav.report.files.atomic_dir`): the files are written to a
    temporary folder beside ``out_dir`` and renamed into place together. A folder holding another
    layout (a ``plan.json``) is refused unless ``force``, then replaced as a whole; a non-empty folder
    without one is never written into (:class:`agvnav.report.files.OutputFolderError`).
    """
    out = Path(out_dir)
    names = {"map": "map.yaml", "heatmap": "heatmap.png", "plan": LAYOUT_MARKER}
    with atomic_dir(out, force, marker=LAYOUT_MARKER, what="layout") as tmp:
        save_map(plan.world, tmp / names["map"])
        plot_layout_heatmap(plan, tmp / names["heatmap"])
        (tmp / names["plan"]).write_text(json_text(plan_record(plan), indent=1) + "\n", encoding="utf-8")
    return {k: out / v for k, v in names.items()}
