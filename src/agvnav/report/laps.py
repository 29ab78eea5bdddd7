"""Seed 004 Tables I-II and Figs. 10-11 for a tracked-robot run: per-lap table and driven squares."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from rich.markup import escape
from rich.table import Table

from agvnav._json import json_text
from agvnav.report.plots import pyplot
from agvnav.report.series_csv import write_csv

__all__ = ["lap_table", "plot_laps", "save_laps", "summary_table"]


def _cm(value: float | None) -> str:
    return "-" if value is None or not np.isfinite(value) else f"{100.0 * value:.1f}"


def lap_table(result: Any) -> Any:
    """A rich Table in the form of seed 004 Tables I-II: lap, error per lap with / without landmarks (cm).

    Every error column names its unit in the header (cm, as the seed's tables). Also the
    distance of each lap end from the route start (cumulative), and the mean row.
    """
    sc = result.scenario
    truth = sc.vehicle.terrain.truth
    terrain = truth if isinstance(truth, str) else "custom"
    t = Table(title=f"{sc.name}: error per lap, {sc.route.side_m:g} m square, {terrain} (seed {sc.seed})")
    modes = sorted(result.runs, reverse=True)
    t.add_column("lap", justify="right")
    # headers are rich markup: a unit in square brackets ("[cm]") would be taken for a style tag and vanish
    for mode in modes:
        t.add_column(escape(f"{'with' if mode else 'without'} landmarks (cm/lap)"), justify="right")
    for mode in modes:
        t.add_column(escape(f"{'with' if mode else 'without'}: from start (cm)"), justify="right")
    for row in result.lap_rows():
        cells = [str(row["lap"])]
        cells += [_cm(row[f"{'with' if m else 'without'}_landmarks_per_lap_m"]) for m in modes]
        cells += [_cm(row[f"{'with' if m else 'without'}_landmarks_from_start_m"]) for m in modes]
        t.add_row(*cells)
    means = ["mean"]
    means += [_cm(float(np.mean(result.runs[m].laps.per_lap_m)) if result.runs[m].laps.laps else None) for m in modes]
    means += ["" for _ in modes]
    t.add_row(*means)
    return t


def plot_laps(result: Any, out: str | Path) -> Path:
    """PNG of the driven squares (true paths per mode), the route and the landmark walls (seed 004 Figs. 10-11)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    corners = np.vstack([result.route.corners, result.route.corners[:1]])
    ax.plot(corners[:, 0], corners[:, 1], "k--", lw=1.0, label="route")
    _draw_walls(ax, result.world)
    colours = {True: "tab:blue", False: "tab:red"}
    for mode, run in sorted(result.runs.items(), reverse=True):
        xy = run.true_xy
        label = f"{'with' if mode else 'without'} landmarks ({run.laps.laps} laps)"
        ax.plot(xy[:, 0], xy[:, 1], color=colours[mode], lw=0.8, label=label)
        if run.laps.laps:
            ax.plot(run.laps.end_xy[:, 0], run.laps.end_xy[:, 1], "o", color=colours[mode], ms=3)
    ax.set_title(f"{result.scenario.name}: driven squares (walls grey)")
    return _save_plan_view(plt, fig, ax, out)


def summary_table(result: Any) -> Any:
    """The per-lap table of a route run (seed 004 Tables I-II)."""
    return lap_table(result)


def save_laps(result: Any, out_dir: str | Path, plots: bool = True) -> list[Path]:
    """Write ``metrics.json``, ``laps.json``, ``laps.csv``, ``timeseries_<mode>.csv`` and (optionally) ``laps.png``.

    ``result`` is a :class:`agvnav.sim.laps.TrackedResult`; errors in m.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = result.lap_rows()
    modes = result.mode_summary()
    for mode, run in result.runs.items():
        tag = "with_landmarks" if mode else "without_landmarks"
        modes[tag]["transitions"] = [
            [tr.t, tr.source.value, tr.target.value, tr.cause] for tr in run.controller.transitions
        ]
    summary = {
        "scenario": result.scenario.name,
        "seed": result.scenario.seed,
        "per_lap": "distance between consecutive true lap end points (the route start before lap 1)",
        "from_start": "distance of the true lap end point from the route start",
        "laps": rows,
        "modes": modes,
    }
    metrics = {"scenario": result.scenario.name, "seed": result.scenario.seed, "modes": result.mode_summary()}
    written = []
    for name, doc in (("metrics.json", metrics), ("laps.json", summary)):
        p = out / name
        p.write_text(json_text(doc, indent=2) + "\n", encoding="utf-8")
        written.append(p)
    cols = list(rows[0]) if rows else ["lap"]
    table = {c: np.array([np.nan if r[c] is None else r[c] for r in rows], dtype=np.float64) for c in cols}
    written.append(write_csv(out / "laps.csv", table))
    for mode, run in result.runs.items():
        written.append(write_csv(out / f"timeseries_{'with' if mode else 'without'}_landmarks.csv", run.series))
    if plots:
        written.append(plot_laps(result, out / "laps.png"))
    return written


def _draw_walls(ax: Any, world: Any) -> None:
    """The map's wall segments (the seed-004 landmarks) as thick grey lines, in m."""
    for seg in world.wall_segments:
        ax.plot(seg[:, 0], seg[:, 1], color="0.4", lw=3.0, solid_capstyle="butt")


def _save_plan_view(plt: Any, fig: Any, ax: Any, out: str | Path) -> Path:
    """Finish a plan view (equal axes in m, legend, grid), write it as PNG to ``out`` and close it."""
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="best", fontsize=8)
    ax.grid(True, lw=0.3)
    path = Path(out)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path
