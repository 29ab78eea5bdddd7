"""The files of a fleet run (issue 28): metrics.json with a ``fleet`` section, one long CSV, the plots.

* ``metrics.json``: ``scenario``, ``seed``, ``outcome``, ``reason``, ``fleet`` (the fleet's figures,
  :func:`agvnav.sim.fleet.fleet_figures`, without timing), ``collisions``, ``vehicles`` (one row per
  vehicle: outcome, jobs, time slowed and stopped and why, minimum separation; under traffic control
  the jobs dispatched to it and the time it waited for traffic, per zone and per node) and ``runs``: per
  vehicle id its single-run document (:func:`agvnav.report.files.metrics_document`);
* ``timing.json``: CPU and wall time, real-time factor, cost per vehicle-step;
* ``timeseries.csv``: every vehicle's recorded series in long form, ``vehicle`` (its index in
  ``vehicles``) first, then the columns the vehicles share;
* ``layout.json``: the hall (walls, reflectors) for the report; ``report.html`` (``report=True``): the
  fleet's HTML report with its time slider (:mod:`agvnav.report.fleet_html`);
* ``fleet_tracks.png``: every vehicle's true track on the map; ``fleet_timeline.png``: per vehicle,
  when it drove, dwelt at a station, was slowed or stopped.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.report.files import _json, _plain, atomic_dir, metrics_document
from agvnav.report.fleet_html import render_fleet_html
from agvnav.report.plots import pyplot
from agvnav.report.series_csv import units_path, write_csv
from agvnav.sim.fleet import FleetResult

__all__ = ["FLEET_COLUMNS", "TIMING_FIGURES", "fleet_document", "fleet_layout", "fleet_series", "save_fleet",
           "timing_fleet"]

#: Columns of the long time series (those a vehicle lacks are NaN).
FLEET_COLUMNS = ("t", "x", "y", "psi", "est_x", "est_y", "est_psi", "est_status", "lateral_error", "guard_level",
                 "reaction_level", "dwelling", "leg", "traffic_hold")

#: Fleet figures that are timing (timing.json, never metrics.json: the metrics are deterministic).
TIMING_FIGURES = ("cpu_time_s", "wall_time_s", "real_time_factor_cpu", "us_per_vehicle_step")


def fleet_document(result: FleetResult) -> dict[str, Any]:
    """The content of metrics.json (deterministic for the scenario and seed)."""
    figures = {k: v for k, v in result.figures.items() if k not in TIMING_FIGURES}
    return _plain({
        "scenario": result.fleet.name,
        "seed": result.fleet.seed,
        "outcome": result.outcome,
        "reason": result.reason,
        "fleet": figures,
        "collisions": result.collisions,
        "vehicles": result.vehicles,
        "runs": {vid: metrics_document(r) for vid, r in zip(result.ids, result.results, strict=True)},
    })


def timing_fleet(result: FleetResult) -> dict[str, Any]:
    """The content of timing.json: CPU and wall time (s), real-time factor (CPU), µs per vehicle-step."""
    return _plain({k: result.figures[k] for k in TIMING_FIGURES})


def fleet_series(result: FleetResult) -> dict[str, NDArray[np.float64]]:
    """Every vehicle's series in long form: ``vehicle`` (index), then :data:`FLEET_COLUMNS`."""
    parts: dict[str, list[NDArray[np.float64]]] = {"vehicle": [], **{c: [] for c in FLEET_COLUMNS}}
    for i, r in enumerate(result.results):
        n = r.series["t"].size
        parts["vehicle"].append(np.full(n, float(i)))
        for c in FLEET_COLUMNS:
            parts[c].append(np.asarray(r.series.get(c, np.full(n, np.nan)), dtype=np.float64))
    return {k: np.concatenate(v) for k, v in parts.items()}


def fleet_layout(result: FleetResult) -> dict[str, Any]:
    """The content of layout.json: the hall the fleet drove in, ``reflectors`` [[x, y, radius], ...] and
    ``walls`` [[[x0, y0], [x1, y1]], ...] (m), for the HTML report."""
    w = result.results[0].world
    return {
        "scenario": result.fleet.name,
        "reflectors": np.column_stack([w.reflector_xy, w.reflector_radius]).round(6).tolist(),
        "walls": np.asarray(w.wall_segments).reshape(-1, 2, 2).round(6).tolist(),
    }


def save_fleet(result: FleetResult, out_dir: str | Path, plots: bool = True, force: bool = False,
               report: bool = False) -> list[Path]:
    """Write the fleet's files (module docstring) atomically into ``out_dir``; return their paths.

    ``report``: also ``report.html``, the fleet's HTML report with its time slider
    (:mod:`agvnav.report.fleet_html`), drawn from the files just written."""
    final = Path(out_dir)
    with atomic_dir(final, force) as tmp:
        written = [
            _json(tmp / "metrics.json", fleet_document(result)),
            _json(tmp / "timing.json", timing_fleet(result)),
            write_csv(tmp / "timeseries.csv", fleet_series(result)),
            units_path(tmp / "timeseries.csv"),
            _json(tmp / "layout.json", fleet_layout(result)),
        ]
        if plots:
            written += [plot_tracks(result, tmp / "fleet_tracks.png"),
                        plot_timeline(result, tmp / "fleet_timeline.png")]
        if report:
            page = tmp / "report.html"
            page.write_text(render_fleet_html(tmp), encoding="utf-8")
            written.append(page)
    return [final / p.name for p in written]


def plot_tracks(result: FleetResult, out: Path) -> Path:
    """Every vehicle's true track on the map (walls, reflectors), start circle, end cross, labelled by id."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(10, 7))
    world = result.results[0].world
    walls = np.asarray(world.wall_segments, dtype=np.float64).reshape(-1, 2, 2)
    for w in walls:
        ax.plot(w[:, 0], w[:, 1], color="0.4", lw=1.0)
    refl = np.asarray(world.reflector_xy)
    if refl.size:
        ax.plot(refl[:, 0], refl[:, 1], "k.", ms=3, label="reflectors")
    for vid, r in zip(result.ids, result.results, strict=True):
        x, y = r.series["x"], r.series["y"]
        (line,) = ax.plot(x, y, lw=1.5, label=vid)
        ax.plot(x[:1], y[:1], "o", color=line.get_color(), ms=5)
        ax.plot(x[-1:], y[-1:], "x", color=line.get_color(), ms=7)
    for c in result.collisions:
        k = result.ids.index(c["vehicles"][0])
        s = result.results[k].series
        ax.plot(s["x"][-1:], s["y"][-1:], "r*", ms=14)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{result.fleet.name}: {len(result.ids)} vehicles ({result.outcome})")
    ax.legend(loc="upper right", fontsize=7)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def plot_timeline(result: FleetResult, out: Path) -> Path:
    """Per vehicle, one bar over time: moving, dwelling at a station, slowed, stopped (positioning or fields),
    held at a hold point (under traffic control: for traffic, or a job's release time)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(10, 0.5 * len(result.ids) + 1.5))
    colours = {"dwelling": "tab:blue", "slowed": "tab:orange", "stopped": "tab:red", "moving": "tab:green",
               "held": "tab:purple"}
    for row, r in enumerate(result.results):
        s = r.series
        t = s["t"]
        n = t.size
        guard = s.get("guard_level", np.zeros(n))
        react = s.get("reaction_level", np.zeros(n))
        state = np.full(n, "moving", dtype=object)
        state[np.maximum(guard, react) >= 1.0] = "slowed"
        state[np.maximum(guard, react) >= 2.0] = "stopped"
        if "dwelling" in s:
            state[s["dwelling"] > 0.5] = "dwelling"
        if "traffic_hold" in s:
            state[s["traffic_hold"] > 0.5] = "held"
        for name, colour in colours.items():
            mask = state == name
            if mask.any():
                widths = np.diff(t, append=t[-1])
                ax.broken_barh(list(zip(t[mask].tolist(), widths[mask].tolist(), strict=True)), (row - 0.4, 0.8),
                               color=colour)
    ax.set_yticks(range(len(result.ids)), result.ids)
    ax.set_xlabel("t (s)")
    held = any("traffic_hold" in r.series for r in result.results)
    ax.set_title(f"{result.fleet.name}: what each vehicle did (green moving, blue at a station, orange slowed, "
                 "red stopped" + (", purple held for traffic or a job's release)" if held else ")"), fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
