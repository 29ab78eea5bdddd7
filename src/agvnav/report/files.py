"""Write a run's results: metrics.json, timing.json, the time series and events as CSV, and the plots.

Units: SI and radians; the CSV columns are named in :mod:`agvnav.sim` terms and
documented in docs/scenarios.md. Every CSV ``NAME.csv`` comes with a sidecar
``NAME.units.csv`` (``column,unit,meaning``, from :mod:`agvnav.report.reference`), so
the data files keep the plain column names every reader relies on while the units
travel with them.

Outputs are safe to trust (issue 12 §4): :func:`atomic_dir` writes every file into
a hidden temporary folder beside the target and renames it into place at the end,
so the folder always holds one complete run (a crash or Ctrl-C leaves the old
folder untouched). A folder that already holds a run (it has a metrics.json) is
refused unless ``force``; it is then replaced as a whole. A non-empty folder
without a metrics.json is never replaced. metrics.json holds only figures that
are deterministic for the seed; wall time and real-time factor go to timing.json,
so two runs with the same seed write byte-identical files except timing.json.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from agvnav._json import json_text
from agvnav.jit import mode as kernel_mode
from agvnav.report.html import write_html_report
from agvnav.report.plots import write_plots
from agvnav.report.reference import EVENT_COLUMNS
from agvnav.report.series_csv import units_path, write_csv

if TYPE_CHECKING:
    from agvnav.report.plot_worker import PlotWorker
    from agvnav.sim.run import SimResult

__all__ = [
    "RUN_MARKER",
    "TIMING_KEYS",
    "OutputFolderError",
    "atomic_dir",
    "check_out_dir",
    "layout_document",
    "metrics_document",
    "reactive_document",
    "replace_dir",
    "save_result",
    "timing_document",
    "units_path",
    "write_csv",
]

#: The file that makes a folder a simulate run's (:func:`check_out_dir`).
RUN_MARKER = "metrics.json"

#: Figures that depend on the machine, not the seed: timing.json, never metrics.json.
TIMING_KEYS = ("wall_time_s", "real_time_factor")


class OutputFolderError(ValueError):
    """The output folder holds another run (or other files) and may not be replaced."""


def metrics_document(result: SimResult) -> dict[str, Any]:
    """The content of metrics.json: outcome, the metrics, integrity figures, how the transient was defined.

    Deterministic for the scenario, seed and kernel mode (``kernels``, :func:`agvnav.jit.mode`; no timing:
    see :func:`timing_document`).
    A run with reactive control adds a ``reactive`` section (:func:`reactive_document`);
    any other run's document is as before, without it.
    """
    figures = {k: v for k, v in result.metrics.to_dict().items() if k not in TIMING_KEYS}
    doc: dict[str, Any] = {
        "scenario": result.scenario.name,
        "vehicle": result.scenario.vehicle.model,
        "seed": result.scenario.seed,
        "kernels": kernel_mode(),  # seeded runs repeat bit for bit within one mode (agvnav.jit)
        "outcome": result.outcome,
        "reason": result.reason,
        **figures,
        **result.extra,
        "transient": "ends at the first sample with |lateral error| <= max(10% of its initial value, 5 mm)",
        "transient_end_s": result.transient_end_s,
        "integrity": result.integrity,
    }
    timeline = getattr(result, "timeline", None)  # issue 29: faults, positioning, stops (sim.events)
    if timeline:
        doc["events"] = _plain(timeline)
    reactive = reactive_document(result)
    if reactive is not None:
        doc["reactive"] = reactive
    return doc


def reactive_document(result: SimResult) -> dict[str, Any] | None:
    """The ``reactive`` section of metrics.json (issue 18), or None when the run had no reactive control.

    ``stops`` (emergency stops), ``time_stopped_s`` (s), ``detours``, ``max_corridor_excess_m``
    (m; null without a corridor) and ``obstacles``: per obstacle id its ``min_clearance_m``
    (m, true footprint to obstacle; null if never computed) and encounter ``result``
    (``collision``, ``avoid``, ``stop``, ``slow`` or ``none``). The figures of
    :attr:`agvnav.sim.run.SimResult.reactive` as plain JSON values (NaN as null), from the
    recorded signals only: deterministic for the seed.
    """
    figures = getattr(result, "reactive", None)  # a result-like object without the field has none
    if not figures:
        return None
    return {str(k): _plain(v) for k, v in figures.items()}


def _plain(value: Any) -> Any:
    """``value`` as plain JSON: numpy scalars as Python numbers, NaN and infinities as None, containers walked."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def timing_document(result: SimResult) -> dict[str, Any]:
    """The content of timing.json: wall time (s) and real-time factor of the run."""
    figures = result.metrics.to_dict()
    return {k: figures[k] for k in TIMING_KEYS}


def check_out_dir(out: str | Path, force: bool = False, marker: str = RUN_MARKER, what: str = "run") -> None:
    """Refuse ``out`` when it holds another result of this kind (unless ``force``) or files that are not one.

    A folder is agvnav's own when it holds ``marker`` (``metrics.json`` for a run, ``plan.json``
    for a layout, ``campaign.json`` for a campaign); ``what`` names the kind in the messages.
    Absent or empty: fine. Its own: refused unless ``force`` (then replaced as a whole by
    :func:`atomic_dir`). Anything else (a file, a folder of other files): refused even with
    ``force``, since replacing it would delete files agvnav did not write. Raises
    :class:`OutputFolderError` (a ValueError) saying which and what to do.
    """
    p = Path(out)
    if not p.exists():
        return
    if not p.is_dir():
        raise OutputFolderError(f"--out {p}: it is a file, not a folder")
    entries = [e.name for e in p.iterdir()]
    if not entries:
        return
    if marker not in entries:
        raise OutputFolderError(
            f"--out {p}: the folder holds files that are not an agvnav {what} (no {marker}); choose another folder"
        )
    if not force:
        raise OutputFolderError(f"--out {p}: the folder holds another {what}'s results; use --force to replace them")


@contextmanager
def atomic_dir(out: str | Path, force: bool = False, marker: str = RUN_MARKER, what: str = "run") -> Iterator[Path]:
    """Yield a temporary folder beside ``out``; on success it replaces ``out`` as a whole.

    ``out`` is checked with :func:`check_out_dir` first (``marker``, ``what``: the kind of
    result, as there). On any error (or Ctrl-C) the temporary folder is removed and ``out``
    is left as it was.
    """
    target = Path(out)
    check_out_dir(target, force, marker, what)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.partial-", dir=target.parent))
    try:
        yield tmp
        replace_dir(tmp, target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def replace_dir(new: Path, target: Path) -> None:
    """Rename the folder ``new`` to ``target``; an existing ``target`` is moved aside first and removed after.

    ``new`` and ``target`` must be on one file system (``new`` a sibling): each rename is atomic,
    so ``target`` is at every moment the old folder, absent for an instant, or the new one.
    """
    if not target.exists():
        os.replace(new, target)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{target.name}.old-", dir=target.parent))
    os.replace(target, old / target.name)
    os.replace(new, target)
    shutil.rmtree(old, ignore_errors=True)


def save_result(
    result: SimResult,
    out_dir: str | Path,
    plots: bool = True,
    force: bool = False,
    report: bool = False,
    plotter: PlotWorker | None = None,
) -> list[Path]:
    """Write metrics.json, timing.json, layout.json, the CSVs and (optionally) the plots atomically; return the paths.

    ``force`` replaces a folder holding another run (see :func:`check_out_dir`); ``report``
    adds report.html (:func:`agvnav.report.html.write_html_report`). With a ``plotter``
    (:class:`agvnav.report.plot_worker.PlotWorker`, started before the run) the run plots are
    drawn in its process while this one writes the data files; the files are the same.
    """
    final = Path(out_dir)
    with atomic_dir(final, force) as tmp:
        written = _write_all(result, tmp, plots, plotter)
        if report:
            written.append(write_html_report(tmp))
    return [final / p.name for p in written]


def layout_document(result: SimResult, spacing: float = 0.05) -> dict[str, Any]:
    """The content of layout.json: the planned path (polyline every ``spacing`` m, segment starts), the map.

    SI units: ``path_xy`` [[x, y], ...] (m), ``segment_starts_m`` (path abscissas of the
    segment joins), ``reflectors`` [[x, y, radius], ...] (m), ``walls`` [[[x0, y0], [x1, y1]], ...] (m),
    ``method`` the positioning method. The HTML report (:mod:`agvnav.report.html`) draws from it.
    """
    w = result.world
    return {
        "scenario": result.scenario.name,
        "method": result.scenario.positioning.method,
        "path_xy": result.path_polyline(spacing).round(6).tolist(),
        "segment_starts_m": [float(v) for v in result.path.segment_starts],
        "reflectors": np.column_stack([w.reflector_xy, w.reflector_radius]).round(6).tolist(),
        "walls": np.asarray(w.wall_segments).reshape(-1, 2, 2).round(6).tolist(),
    }


def _json(path: Path, document: dict[str, Any]) -> Path:
    """Write ``document`` as strict JSON (NaN and infinities as null: :func:`agvnav.bench.common.json_text`)."""
    path.write_text(json_text(document, indent=2) + "\n", encoding="utf-8")
    return path


def _write_all(result: SimResult, out: Path, plots: bool, plotter: PlotWorker | None = None) -> list[Path]:
    """Every result file of ``result`` into ``out`` (the run plots through ``plotter`` when given)."""
    pending = None
    if plots and plotter is not None:  # the child draws while this process writes the data files
        pending = plotter.submit(
            result.series, result.path_polyline(), result.world.reflector_xy, result.world.wall_segments, out,
            result.transient_end_s, result.scenario.name,
        )
    try:
        written = _write_data(result, out)
        if pending is not None:
            written += pending()
    finally:
        if pending is not None and plotter is not None:
            # success or not (a failed write, Ctrl-C), the drawing children are done before the caller
            # (atomic_dir) removes ``out``: none may write into it afterwards
            plotter.close()
    if pending is None and plots:
        written += write_plots(
            result.series,
            result.path_polyline(),
            result.world.reflector_xy,
            result.world.wall_segments,
            out,
            result.transient_end_s,
            result.scenario.name,
        )
    if plots and result.scenario.mission is not None:  # the route network, driven route and stops (issue 14)
        from agvnav.report.routes import write_mission_plots  # noqa: PLC0415  (lazy: mission runs only)

        written += write_mission_plots(result, out)
    return written


def _write_data(result: SimResult, out: Path) -> list[Path]:
    """metrics.json, timing.json, layout.json and the CSVs (with their units) of ``result`` into ``out``."""
    written = [
        _json(out / "metrics.json", metrics_document(result)),
        _json(out / "timing.json", timing_document(result)),
        _json(out / "layout.json", layout_document(result)),
        write_csv(out / "timeseries.csv", result.series),
        units_path(out / "timeseries.csv"),
    ]
    refl = result.events.get("reflections")
    if refl is not None:
        written += [write_csv(out / "reflections.csv", refl, EVENT_COLUMNS), units_path(out / "reflections.csv")]
    return written
