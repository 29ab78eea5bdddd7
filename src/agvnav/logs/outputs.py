"""The files ``agvnav localize`` writes: the estimate as CSV and MCAP, its figures, the plots.

The folder has the shape of a simulation's (metrics.json, timeseries.csv, layout.json), so
``--force`` replaces it as it replaces a run, and ``agvnav report`` reports it.

- ``timeseries.csv``: ``t``, ``est_x``, ``est_y``, ``est_psi``, ``est_status``, ``est_valid``, the six
  ``est_cov_*`` columns (as a simulation's, docs/scenarios.md), ``est_quality`` (0-1) and
  ``est_reflectors_used`` (NaN when the estimator reports none), and with truth ``x``, ``y``, ``psi``;
- ``estimate.mcap``: ``/agvnav/estimate`` (PoseWithCovarianceStamped), ``/agvnav/status``,
  ``/agvnav/reflector_map``, ``/agvnav/settings`` and, with truth, ``/agvnav/truth``;
- ``metrics.json``: the log's name, method, the verdict (:func:`agvnav.logs.localize.judge`:
  ``outcome``, ``reason``, ``tracking_s``, ``tracking_share``, ``reflections_used_share`` and, with
  truth, ``tracking_off_truth_s``), counts of reflections (delivered, accepted, late, before the
  start) and, with truth, the positioning RMS and largest errors (m, rad) over the rows the
  estimator reported valid (status tracking or later, as a simulation's);
- ``layout.json``: the log's path (when it has one), the map's reflectors and walls;
- ``map.png`` (reflectors, walls, path when the log has it, truth and estimate),
  ``estimator_status.png`` and, with truth, ``positioning_errors.png`` and
  ``positioning_histogram.png``.

Everything is written at once (:func:`agvnav.report.files.atomic_dir`); ``estimate.mcap`` only with
the ``logs`` extra installed (the rest needs none of it).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav._json import json_text
from agvnav.geometry import lateral_position_error, wrap_angle
from agvnav.logs import topics as tp
from agvnav.logs.localize import Localization, judge
from agvnav.logs.reader import RecordedLog
from agvnav.logs.runlog import covariance3, write_estimate_messages, write_reflector_map
from agvnav.logs.writer import LogWriter, logs_extra_installed
from agvnav.report.files import atomic_dir
from agvnav.report.html import plot_positioning_errors, plot_status
from agvnav.report.plots import plot_map, plot_positioning_histogram, pyplot
from agvnav.report.series_csv import write_csv

__all__ = ["localization_summary", "save_localization"]


def localization_summary(loc: Localization, log: RecordedLog, name: str = "log") -> dict[str, Any]:
    """The metrics.json document: method, verdict, tracking time, reflection counts and, with truth, the
    error figures (m, rad) over the rows the estimator reported valid (status >= tracking, as simulate)."""
    verdict = judge(loc, log)
    doc: dict[str, Any] = {
        "scenario": name, "method": loc.method, "outcome": verdict.outcome, "reason": verdict.reason,
        "duration_s": float(log.t[-1] - log.t[0]), "tracking_s": verdict.tracking_s,
        "tracking_share": verdict.tracking_share,
        "reflections": loc.n_reflections, "accepted": loc.n_accepted,
        "reflections_used_share": verdict.reflections_used_share,
        "late_rejected": loc.late_rejected, "before_start": loc.ignored_before_start,
    }
    if verdict.tracking_off_truth_s is not None:
        doc["tracking_off_truth_s"] = verdict.tracking_off_truth_s
    if log.truth is not None:
        s = loc.series
        est = np.column_stack([s["est_x"], s["est_y"], s["est_psi"]])
        ok = np.all(np.isfinite(est), axis=1) & (s["est_status"] >= 1.0)
        d = np.hypot(*(est[ok, :2] - log.truth[ok, :2]).T)
        dpsi = wrap_angle(est[ok, 2] - log.truth[ok, 2])
        e_lat = lateral_position_error(log.truth[ok], est[ok])
        doc.update(
            positioning_rms_m=_f(np.sqrt(np.mean(d**2))) if d.size else None,
            positioning_max_m=_f(np.max(d)) if d.size else None,
            positioning_lateral_max_abs_m=_f(np.max(np.abs(e_lat))) if d.size else None,
            positioning_rms_heading_rad=_f(np.sqrt(np.mean(dpsi**2))) if d.size else None,
        )
    return doc


def _f(v: Any) -> float | None:
    x = float(v)
    return x if math.isfinite(x) else None


def save_localization(
    loc: Localization, log: RecordedLog, world: Any, out_dir: str | Path, force: bool = False, plots: bool = True,
    name: str = "log",
) -> list[Path]:
    """Write the files of the module docstring into ``out_dir`` atomically; return their final paths.

    ``name`` (the log's file name) titles metrics.json and the plots.
    """
    final = Path(out_dir)
    with atomic_dir(final, force) as tmp:
        written = _write(loc, log, world, tmp, plots, name)
    return [final / p.name for p in written]


def _json(path: Path, doc: dict[str, Any]) -> Path:
    path.write_text(json_text(doc, indent=2) + "\n", encoding="utf-8")
    return path


def _write(loc: Localization, log: RecordedLog, world: Any, out: Path, plots: bool, name: str) -> list[Path]:
    columns = dict(loc.series)
    columns["est_valid"] = (columns["est_status"] >= 1.0).astype(np.float64)
    if log.truth is not None:
        columns.update(x=log.truth[:, 0], y=log.truth[:, 1], psi=log.truth[:, 2])
    layout = {
        "scenario": name, "method": loc.method, "segment_starts_m": [],
        "path_xy": [] if log.path_xy is None else np.round(log.path_xy, 6).tolist(),
        "reflectors": np.column_stack([world.reflector_xy, world.reflector_radius]).round(6).tolist(),
        "walls": np.asarray(world.wall_segments).reshape(-1, 2, 2).round(6).tolist(),
    }
    written = [
        _json(out / "metrics.json", localization_summary(loc, log, name)),
        write_csv(out / "timeseries.csv", columns),
        _json(out / "layout.json", layout),
    ]
    if logs_extra_installed():
        written.append(_write_mcap(loc, log, world, out / "estimate.mcap"))
    if plots:
        written += _plots(loc, log, world, out)
    return written


def _write_mcap(loc: Localization, log: RecordedLog, world: Any, path: Path) -> Path:
    s = loc.series
    with LogWriter(path) as w:
        w.write(tp.SETTINGS, {"data": json.dumps({**log.settings, "method": loc.method})}, 0.0)
        write_reflector_map(w, world)
        for k, tk in enumerate(s["t"].tolist()):
            pose = np.array([s["est_x"][k], s["est_y"][k], s["est_psi"][k]])
            write_estimate_messages(w, tk, np.nan_to_num(pose), np.nan_to_num(covariance3(s, k)))
            status = {"layout": {"dim": [{"label": ",".join(tp.STATUS_FIELDS), "size": 3, "stride": 3}]},
                      "data": [float(s["est_status"][k]), float(s["est_quality"][k]), math.nan]}
            w.write(tp.STATUS, status, tk)
            if log.truth is not None:
                w.write(tp.TRUTH, {"header": {"stamp": _stamp(tk), "frame_id": tp.FRAME_MAP},
                                   "pose": _pose(log.truth[k])}, tk)
    return path


def _stamp(t: float) -> dict[str, int]:
    ns = round(t * 1e9)
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def _pose(p: NDArray[np.float64]) -> dict[str, Any]:
    return {"position": {"x": float(p[0]), "y": float(p[1]), "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(0.5 * p[2]), "w": math.cos(0.5 * p[2])}}


def _plots(loc: Localization, log: RecordedLog, world: Any, out: Path) -> list[Path]:
    s = loc.series
    est = np.column_stack([s["est_x"], s["est_y"], s["est_psi"]])
    valid = s["est_status"] >= 1.0
    driven = log.truth[:, :2] if log.truth is not None else est[valid, :2]
    path_xy = log.path_xy if log.path_xy is not None else driven
    written = [plot_map(path_xy, driven, world.reflector_xy, world.wall_segments, out / "map.png", est[valid, :2],
                        f"localize ({loc.method})")]
    written.append(_save(plot_status(s["t"], s["est_status"]), out / "estimator_status.png"))
    if log.truth is not None:
        written.append(_save(plot_positioning_errors(s["t"], log.truth, est), out / "positioning_errors.png"))
        e_lat = lateral_position_error(log.truth[valid], est[valid])
        written.append(plot_positioning_histogram(e_lat, out / "positioning_histogram.png", f"localize ({loc.method})"))
    return written


def _save(fig: Any, path: Path) -> Path:
    plt = pyplot()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
