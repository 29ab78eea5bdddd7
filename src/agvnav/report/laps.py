"""Seed 004 Tables I-II and Figs. 10-11 for a tracked-robot run: per-lap table and driven squares."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["lap_table", "plot_laps"]


def _cm(value: float | None) -> str:
    return "-" if value is None or not np.isfinite(value) else f"{100.0 * value:.1f}"


def lap_table(result: Any) -> Any:
    """A rich Table in the form of seed 004 Tables I-II: lap, error per lap with / without landmarks (cm).

    Also the distance of each lap end from the route start (cumulative), and the mean row.
    """
    from rich.table import Table

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
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    corners = np.vstack([result.route.corners, result.route.corners[:1]])
    ax.plot(corners[:, 0], corners[:, 1], "k--", lw=1.0, label="route")
    for seg in result.world.wall_segments:
        ax.plot(seg[:, 0], seg[:, 1], color="0.4", lw=3.0, solid_capstyle="butt")
    colours = {True: "tab:blue", False: "tab:red"}
    for mode, run in sorted(result.runs.items(), reverse=True):
        xy = run.true_xy
        label = f"{'with' if mode else 'without'} landmarks ({run.laps.laps} laps)"
        ax.plot(xy[:, 0], xy[:, 1], color=colours[mode], lw=0.8, label=label)
        if run.laps.laps:
            ax.plot(run.laps.end_xy[:, 0], run.laps.end_xy[:, 1], "o", color=colours[mode], ms=3)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{result.scenario.name}: driven squares (walls grey)")
    ax.legend(loc="best", fontsize=8)
    ax.grid(True, lw=0.3)
    path = Path(out)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path
