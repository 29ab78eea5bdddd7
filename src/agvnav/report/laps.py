"""Seed 004 Tables I-II and Figs. 10-11 for a tracked-robot run: per-lap table and driven squares."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from rich.table import Table

from agvnav.report.plots import pyplot

__all__ = ["lap_table", "path_table", "plot_laps", "plot_path_follow", "summary_table"]


def _cm(value: float | None) -> str:
    return "-" if value is None or not np.isfinite(value) else f"{100.0 * value:.1f}"


def lap_table(result: Any) -> Any:
    """A rich Table in the form of seed 004 Tables I-II: lap, error per lap with / without landmarks (cm).

    Also the distance of each lap end from the route start (cumulative), and the mean row.
    """
    sc = result.scenario
    terrain = sc.terrain.truth if isinstance(sc.terrain.truth, str) else "custom"
    t = Table(title=f"{sc.name}: error per lap, {sc.route.side_m:g} m square, {terrain} (seed {sc.seed})")
    modes = sorted(result.runs, reverse=True)
    t.add_column("lap", justify="right")
    for mode in modes:
        t.add_column(f"{'with' if mode else 'without'} landmarks [cm/lap]", justify="right")
    for mode in modes:
        t.add_column(f"{'with' if mode else 'without'}: from start [cm]", justify="right")
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


def path_table(result: Any) -> Any:
    """A rich Table of a Kanayama path-following run (true errors to the path)."""
    m = result.metrics()
    t = Table(title=f"{result.scenario.name}: tracked robot, Kanayama path follower (seed {result.scenario.seed})")
    t.add_column("metric")
    t.add_column("value", justify="right")
    t.add_row("max |lateral error| (mm)", f"{1e3 * m['max_lateral_error_m']:.1f}")
    t.add_row("RMS lateral error (mm)", f"{1e3 * m['rms_lateral_error_m']:.1f}")
    t.add_row("final position error (mm)", f"{1e3 * m['final_position_error_m']:.1f}")
    t.add_row("final heading error (deg)", f"{np.degrees(m['final_heading_error_rad']):.2f}")
    t.add_row("path completed", "yes" if m["path_completed"] else "no")
    t.add_row("simulated time (s)", f"{m['sim_time_s']:.1f}")
    t.add_row("wall time (s)", f"{m['wall_time_s']:.2f}")
    return t


def summary_table(result: Any) -> Any:
    """The per-lap table (hybrid automaton) or the path-following table (Kanayama)."""
    return lap_table(result) if hasattr(result, "runs") else path_table(result)


def plot_path_follow(result: Any, out: str | Path) -> Path:
    """PNG of the planned path and the true driven path of a Kanayama run."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    s = np.linspace(0.0, result.path.length, max(2, int(result.path.length / 0.02)))
    planned = result.path.point_at(s)
    ax.plot(planned[:, 0], planned[:, 1], "k--", lw=1.0, label="path")
    ax.plot(result.series["x"], result.series["y"], color="tab:blue", lw=0.8, label="driven (truth)")
    ax.plot(result.series["est_x"], result.series["est_y"], color="tab:orange", lw=0.8, label="dead reckoning")
    _draw_walls(ax, result.world)
    return _save_plan_view(plt, fig, ax, out)


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
