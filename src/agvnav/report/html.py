"""One self-contained HTML report of a run folder (``agvnav report RUN_DIR``, ``agvnav simulate --report``).

The file needs no network: the plots are PNGs inlined as base64, the driving
animation is inline SVG moved by a time slider and a few lines of inline
JavaScript; there are no external scripts, styles or fonts. It shows the
scenario and outcome, the metrics with units (the seed's figures only for a
scenario that reproduces a seed experiment), the map with the driven and
estimated paths and covariance ellipses at intervals, the errors against time
with the path's segment joins marked, the positioning error histogram and the
estimator status against time. It reads metrics.json, timeseries.csv and, when
present, layout.json (path and map, :func:`agvnav.report.files.layout_document`).
"""

from __future__ import annotations

import base64
import html
import io
import json
import math
import os
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav._display import display_unit, format_number
from agvnav.geometry import lateral_position_error, wrap_angle
from agvnav.report.fleet_html import is_fleet_folder, render_fleet_html
from agvnav.report.plots import pyplot
from agvnav.report.series_csv import read_csv

__all__ = [
    "REPORT_HEADER",
    "SEED_FIGURES",
    "RunFolder",
    "check_report_file",
    "covariance_ellipse",
    "is_agvnav_report",
    "load_run",
    "metrics_table",
    "plot_positioning_errors",
    "plot_status",
    "point_covariance",
    "render_html",
    "tracked_points",
    "write_html_report",
]

F64 = NDArray[np.float64]

#: Scenario name prefix -> the seed's figures it reproduces: metric key -> (value in mm or deg, source).
SEED_FIGURES: dict[str, dict[str, tuple[str, str]]] = {
    "seed000_guidance": {
        "initial_lateral_error_m": ("110", "seed 000 §4.3"),
        "max_abs_lateral_error_m": ("16.5", "seed 000 §4.3"),
        "max_abs_wheel_heading_error_rad": ("3.8", "seed 000 §4.3"),
    },
    "guidance_test": {
        "initial_lateral_error_m": ("110", "seed 000 §4.3"),
        "max_abs_lateral_error_m": ("16.5", "seed 000 §4.3"),
        "max_abs_wheel_heading_error_rad": ("3.8", "seed 000 §4.3"),
    },
    "seed000_positioning": {
        "positioning_lateral_mean_abs_m": ("9.7", "seed 000 Fig. 8"),
        "positioning_lateral_std_m": ("6.6", "seed 000 Fig. 8"),
        "positioning_lateral_max_abs_m": ("23", "seed 000 Fig. 8"),
    },
}

#: Status codes of timeseries.csv's est_status.
STATUS_NAMES = {-1: "other", 0: "initialising", 1: "tracking", 2: "dead reckoning", 3: "degraded", 4: "lost"}


@dataclass
class RunFolder:
    """What a run folder holds: metrics.json, the series of timeseries.csv, layout.json (or None)."""

    path: Path
    metrics: dict[str, Any]
    series: dict[str, F64]
    layout: dict[str, Any] | None


def load_run(run_dir: str | Path) -> RunFolder:
    """Read a run folder written by ``agvnav simulate``; ValueError names a missing or damaged file."""
    d = Path(run_dir)
    try:
        metrics = json.loads((d / "metrics.json").read_text(encoding="utf-8"))
        series = read_csv(d / "timeseries.csv")
    except (OSError, ValueError) as exc:
        raise ValueError(f"{d}: not a readable agvnav run folder ({exc})") from None
    layout_file = d / "layout.json"
    layout = json.loads(layout_file.read_text(encoding="utf-8")) if layout_file.is_file() else None
    return RunFolder(d, metrics, series, layout)


def _png(fig: Any) -> str:
    """The figure as an ``<img>`` with an inline base64 PNG; closes the figure."""
    plt = pyplot()
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    return f'<img alt="plot" src="data:image/png;base64,{base64.b64encode(buf.getvalue()).decode("ascii")}">'


def covariance_ellipse(cov2: F64, k_sigma: float = 3.0, n: int = 48) -> F64:
    """``(n, 2)`` points of the ``k_sigma`` ellipse of a 2x2 position covariance (m), centred at 0."""
    vals, vecs = np.linalg.eigh(0.5 * (cov2 + cov2.T))
    a = np.linspace(0.0, 2 * math.pi, n)
    unit = np.column_stack([np.cos(a), np.sin(a)]) * (k_sigma * np.sqrt(np.maximum(vals, 0.0)))
    return np.asarray(unit @ vecs.T, dtype=np.float64)


def _draw_layout(ax: Any, layout: dict[str, Any] | None) -> None:
    if layout is None:
        return
    for seg in layout["walls"]:
        ax.plot([seg[0][0], seg[1][0]], [seg[0][1], seg[1][1]], color="0.4", lw=1.2)
    r = np.asarray(layout["reflectors"], dtype=np.float64).reshape(-1, 3)
    ax.plot(r[:, 0], r[:, 1], "o", ms=6, mfc="gold", mec="k", label="reflectors")
    p = np.asarray(layout["path_xy"], dtype=np.float64).reshape(-1, 2)
    ax.plot(p[:, 0], p[:, 1], "--", color="tab:blue", lw=1.2, label="planned path")


def tracked_points(s: dict[str, F64]) -> tuple[F64, F64, float]:
    """True and estimated tracked point ``(n, 2)`` each (m) and its offset ahead of base_link (m).

    The tracked point is the one the planned path is drawn for (C of a steered vehicle guiding
    C, else base_link): ``x_tracked``/``est_x_C`` when the series has them, else base_link.
    """
    est = np.column_stack([s.get("est_x_C", s["est_x"]), s.get("est_y_C", s["est_y"])])
    true = np.column_stack([s.get("x_tracked", s.get("x", est[:, 0])), s.get("y_tracked", s.get("y", est[:, 1]))])
    off = np.hypot(est[:, 0] - s["est_x"], est[:, 1] - s["est_y"])
    off = off[np.isfinite(off)]
    return true, est, float(np.median(off)) if off.size else 0.0


def point_covariance(cov3: F64, psi: float, offset: float) -> F64:
    """2x2 covariance (m²) of the point ``offset`` m ahead of base_link from the pose covariance ``cov3``.

    First order: ``J P J^T`` with ``J = [[1, 0, -offset sin psi], [0, 1, offset cos psi]]``.
    """
    j = np.array([[1.0, 0.0, -offset * math.sin(psi)], [0.0, 1.0, offset * math.cos(psi)]])
    return np.asarray(j @ cov3 @ j.T, dtype=np.float64)


def _ellipses(ax: Any, s: dict[str, F64], count: int = 14) -> None:
    """3-sigma ellipses of the estimated tracked point at ``count`` instants after the start, magnified (a
    power of ten, in the legend) so that the median one spans about a tenth of the drive."""
    if "est_cov_xx" not in s:
        return
    valid = np.flatnonzero(s.get("est_valid", s["est_status"] >= 1.0) > 0.5)
    if valid.size == 0:
        return
    _, est, off = tracked_points(s)
    idx = valid[np.linspace(0, valid.size - 1, count + 1).astype(int)[1:]]  # not the start's prior
    names = ("est_cov_xx", "est_cov_xy", "est_cov_xpsi", "est_cov_yy", "est_cov_ypsi", "est_cov_psipsi")
    covs = []
    for k in idx:
        xx, xy, xp, yy, yp, pp = (float(s[n][k]) for n in names)
        p3 = np.array([[xx, xy, xp], [xy, yy, yp], [xp, yp, pp]])
        covs.append(point_covariance(p3, float(s["est_psi"][k]), off))
    size = float(np.median([np.max(np.abs(covariance_ellipse(c))) for c in covs]))
    span = max(np.ptp(est[valid, 0]), np.ptp(est[valid, 1]), 1.0)
    gain = max(1.0, 10 ** math.floor(math.log10(0.1 * span / size))) if size > 0 else 1.0
    for j, (k, c) in enumerate(zip(idx, covs, strict=True)):
        e = gain * covariance_ellipse(c) + est[k]
        ax.plot(e[:, 0], e[:, 1], color="tab:purple", lw=0.9, label=f"3σ ellipse ×{gain:g}" if j == 0 else None)


def plot_map_figure(run: RunFolder) -> Any:
    """Map: walls, reflectors, planned path, driven (truth) and estimated paths of the tracked point, ellipses."""
    plt = pyplot()
    s = run.series
    fig, axes = plt.subplots(1, 2, figsize=(11, 5))
    valid = s.get("est_valid", s["est_status"] >= 1.0) > 0.5
    true, est, _ = tracked_points(s)
    for ax in axes:
        _draw_layout(ax, run.layout)
        if "x" in s:
            ax.plot(true[:, 0], true[:, 1], color="tab:red", lw=1.2, label="driven (truth)")
        ax.plot(est[valid, 0], est[valid, 1], color="tab:green", lw=0.9, label="estimated")
        _ellipses(ax, s)
        ax.set_aspect("equal")
        ax.set(xlabel="x [m]", ylabel="y [m]")
        ax.grid(True, alpha=0.3)
    xy = true[np.all(np.isfinite(true), axis=1)]
    if xy.size:
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        pad = 0.15 * float(np.max(hi - lo)) + 0.3
        axes[1].set(xlim=(lo[0] - pad, hi[0] + pad), ylim=(lo[1] - pad, hi[1] + pad))
    axes[0].set_title("map (tracked point)")
    axes[1].set_title("drive detail")
    axes[1].legend(loc="best", fontsize=8)
    return fig


def _join_times(run: RunFolder) -> list[float]:
    """Instants the true tracked point passes each segment join (from s_true and layout.json)."""
    s = run.series
    if run.layout is None or "s_true" not in s:
        return []
    out = []
    for s0 in run.layout.get("segment_starts_m", [])[1:-1]:
        hit = np.flatnonzero(s["s_true"] >= s0)
        if hit.size:
            out.append(float(s["t"][hit[0]]))
    return out


def plot_positioning_errors(t: F64, true_pose: F64, est_pose: F64, joins: list[float] | None = None) -> Any:
    """Positioning errors against time: lateral position error (mm) and heading error (deg) of the estimate."""
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    a1.plot(t, 1000.0 * lateral_position_error(true_pose, est_pose), color="tab:green")
    a1.set_ylabel("positioning e_lat [mm]")
    dpsi = wrap_angle(est_pose[:, 2] - true_pose[:, 2])
    a2.plot(t, np.rad2deg(dpsi), color="tab:olive")
    a2.set(ylabel="heading error [deg]", xlabel="time [s]")
    _mark(a1, a2, joins or [])
    a1.set_title("positioning errors (estimate - truth)")
    return fig


def _mark(a1: Any, a2: Any, joins: list[float]) -> None:
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
        for j, tj in enumerate(joins):
            ax.axvline(tj, color="0.3", ls=":", lw=0.9, label="segment join" if j == 0 and ax is a1 else None)
    if joins:
        a1.legend(loc="best", fontsize=8)


def plot_guidance_errors(run: RunFolder) -> Any:
    """True lateral error (mm) and heading error (deg) of the tracked point against time, joins marked."""
    plt = pyplot()
    s = run.series
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    a1.plot(s["t"], 1000.0 * s["lateral_error"], color="tab:blue")
    a1.set_ylabel("lateral error [mm]")
    a2.plot(s["t"], np.rad2deg(s["heading_error"]), color="tab:orange")
    a2.set(ylabel="heading error [deg]", xlabel="time [s]")
    _mark(a1, a2, _join_times(run))
    a1.set_title("guidance errors (truth)")
    return fig


def plot_status(t: F64, status: F64, sigma3: F64 | None = None) -> Any:
    """Estimator status against time (codes named) and, when given, the 3-sigma lateral bound (mm)."""
    plt = pyplot()
    fig, a1 = plt.subplots(figsize=(9, 3.2))
    a1.step(t, status, where="post", color="tab:purple")
    a1.set_yticks(list(STATUS_NAMES), list(STATUS_NAMES.values()))
    a1.set(xlabel="time [s]", title="estimator status")
    a1.grid(True, alpha=0.3)
    if sigma3 is not None:
        a2 = a1.twinx()
        a2.plot(t, 1000.0 * sigma3, color="tab:gray", lw=0.8)
        a2.set_ylabel("3σ lateral [mm]")
    return fig


def _histogram(true_pose: F64, est_pose: F64) -> Any:
    plt = pyplot()
    e = 1000.0 * lateral_position_error(true_pose, est_pose)
    e = e[np.isfinite(e)]
    fig, ax = plt.subplots(figsize=(7, 3.6))
    if e.size:
        ax.hist(e, bins=min(40, max(5, e.size // 20)), color="tab:blue", edgecolor="k", alpha=0.8)
    ax.set(xlabel="positioning lateral error e_lat [mm]", ylabel="samples", title="positioning error histogram")
    ax.grid(True, alpha=0.3)
    return fig


#: metrics.json keys the report shows in its introduction, not in the metrics tables.
_INTRO_KEYS = ("scenario", "vehicle", "seed", "outcome", "reason", "transient")

#: Keys ``NAME[i]`` (one figure per station stop) and ``NAME.KIND`` (one per kind of path edge):
#: the title of the table that gathers them, by the shape of their qualifier.
_QUALIFIED_TITLES = {"[": "Per station stop", ".": "Per kind of path edge"}

_QUALIFIED = re.compile(r"^(?P<base>[A-Za-z0-9_]+?)(?:\[(?P<index>\d+)\]|\.(?P<name>[A-Za-z0-9_]+))$")


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _cell(key: str, values: list[Any]) -> tuple[str, str, list[str]]:
    """Label, display unit and shown values of the figure ``key`` (SI in metrics.json) holding ``values``.

    The unit comes from the key's suffix, like every table agvnav prints
    (:func:`agvnav.bench.common.display_unit`): lengths in mm below 1 m, else m; angles in
    degrees; times in s (ms below 1 s); the label is the key without its suffix, so a
    ``_m`` key never stands beside a value in mm. Numbers have about 4 significant
    figures and no exponent (:func:`agvnav.bench.common.format_number`).
    """
    header, unit, scale = display_unit(key, [v for v in values if _is_number(v)])
    label = header[: -len(unit) - 3] if unit else header
    shown = []
    for v in values:
        if _is_number(v) and not unit and float(v).is_integer() and math.isfinite(v):
            shown.append(format_number(int(v)))
        else:
            shown.append(format_number(v, scale) if v is None or _is_number(v) or isinstance(v, bool) else str(v))
    return label, unit, shown


def _seed_figures(name: str) -> dict[str, tuple[str, str]]:
    for prefix, figures in SEED_FIGURES.items():
        if name.startswith(prefix):
            return figures
    return {}


def _seed_unit(key: str) -> str:
    """The unit the seed papers give a figure in: mm for lengths, deg for angles."""
    return "mm" if key.endswith("_m") else "deg" if key.endswith("_rad") else ""


def metrics_table(metrics: dict[str, Any]) -> str:
    """HTML tables of a metrics.json document (SI), shown in display units.

    The first table has one row per figure: what it is, the value and its unit (mm or m,
    deg, s: :func:`_cell`), and the seed's figure when the scenario reproduces a seed
    experiment. Figures per station stop (``stop_error_m[i]``) and per kind of path edge
    (``max_lateral_m.line``) follow in tables of their own, one row per stop or edge
    kind and one column (with one unit) per figure. Sections (``integrity``,
    ``reactive``) follow as tables of their figures.
    """
    seed = _seed_figures(str(metrics.get("scenario", "")))
    plain: dict[str, Any] = {}
    pivots: dict[str, dict[str, dict[str, Any]]] = {}
    sections: dict[str, dict[str, Any]] = {}
    for key, value in metrics.items():
        if key in _INTRO_KEYS:
            continue
        if isinstance(value, dict):
            sections[key] = value
            continue
        m = _QUALIFIED.match(key)
        if m is not None:
            kind = "[" if m["index"] is not None else "."
            row = m["index"] if m["index"] is not None else m["name"]
            pivots.setdefault(kind, {}).setdefault(row, {})[m["base"]] = value
            continue
        plain[key] = value
    _heading_that_fits(plain)
    parts = [_figure_table([(k, "", v) for k, v in plain.items()], seed)]
    for kind, rows in pivots.items():
        parts.append(f"<h3>{_QUALIFIED_TITLES[kind]}</h3>" + _pivot_table(rows, "stop" if kind == "[" else "edge"))
    for name, section in sections.items():
        figures = _flatten(section)
        table = _figure_table(figures, {}) if figures else ""
        parts.append(f"<h3>{html.escape(name.replace('_', ' '))}</h3>" + table)
        for title, records in _record_lists(section):
            parts.append(f"<h4>{html.escape(title)}</h4>" + _records_table(records))
    return "\n".join(parts)


def _heading_that_fits(plain: dict[str, Any]) -> None:
    """Keep the heading figure that fits the vehicle, as ``agvnav simulate``'s table does (issue 29).

    A steered vehicle has seed 000's wheel heading error xi_r (``max_abs_wheel_heading_error_rad``):
    its body heading against the path tangent (``max_abs_heading_error_rad``, tens of degrees on a
    tight arc by design) is left out. Any other vehicle has no wheel heading error (null): that row
    is left out, its body heading figure stays.
    """
    wheel = plain.get("max_abs_wheel_heading_error_rad")
    if wheel is not None:
        plain.pop("max_abs_heading_error_rad", None)
        if not plain.get("heading_reorientations"):
            plain.pop("heading_reorientations", None)
    elif plain.get("max_abs_heading_error_rad") is not None:
        plain.pop("max_abs_wheel_heading_error_rad", None)


def _is_records(value: Any) -> bool:
    """A list of records (the ``events`` section's windows, stops, faults): one table row each."""
    return isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)


def _record_lists(section: dict[str, Any], outer: tuple[str, ...] = ()) -> list[tuple[str, list[dict[str, Any]]]]:
    """Every list of records in a section, nested mappings walked, with its path as a title."""
    found: list[tuple[str, list[dict[str, Any]]]] = []
    for key, value in section.items():
        path = (*outer, str(key))
        if isinstance(value, dict):
            found += _record_lists(value, path)
        elif _is_records(value):
            found.append((" ".join(path).replace("_", " "), value))
    return found


def _records_table(records: list[dict[str, Any]]) -> str:
    """One row per record, one column per field with its display unit in the header (like :func:`_pivot_table`)."""
    keys: list[str] = []
    for record in records:
        keys += [k for k in record if k not in keys]
    columns = {k: _cell(k, [r.get(k) for r in records]) for k in keys}
    head = "<tr>" + "".join(
        f"<th>{html.escape(label)}{f' ({unit})' if unit else ''}</th>" for label, unit, _ in columns.values()
    ) + "</tr>"
    body = ["<tr>" + "".join(f"<td class=num>{columns[k][2][i]}</td>" for k in keys) + "</tr>"
            for i in range(len(records))]
    return f"<table>{head}{''.join(body)}</table>"


def _flatten(section: dict[str, Any], outer: tuple[str, ...] = ()) -> list[tuple[str, str, Any]]:
    """A section's figures as ``(key, qualifier, value)``, nested mappings walked.

    The key giving the unit is the innermost one with a unit suffix (``time_in_status_s:
    {tracking: 3.0}`` -> ``("time_in_status_s", "tracking", 3.0)``; ``obstacles: {p1:
    {min_clearance_m: 0.4}}`` -> ``("min_clearance_m", "obstacles p1", 0.4)``).
    """
    rows: list[tuple[str, str, Any]] = []
    for key, value in section.items():
        path = (*outer, str(key))
        if isinstance(value, dict):
            rows += _flatten(value, path)
            continue
        if _is_records(value):  # a table of its own (:func:`_record_lists`)
            continue
        unit_at = next((i for i in range(len(path) - 1, -1, -1) if display_unit(path[i])[1]), len(path) - 1)
        qualifier = " ".join(p.replace("_", " ") for i, p in enumerate(path) if i != unit_at)
        rows.append((path[unit_at], qualifier, value))
    return rows


def _figure_table(figures: list[tuple[str, str, Any]], seed: dict[str, tuple[str, str]]) -> str:
    """One row per ``(key, qualifier, value)``: label, value, unit (and the seed's figure)."""
    head = "<tr><th>metric</th><th>value</th><th>unit</th>" + ("<th>seed</th>" if seed else "") + "</tr>"
    rows = []
    # one unit per figure: the rows of one key (``distance_in_status_m`` per status) share it, so a 0.7 m
    # row never shows in mm beside a 4.2 m row in m
    group: dict[str, list[Any]] = {}
    for key, _, value in figures:
        group.setdefault(key, []).append(value)
    cells = {key: _cell(key, values) for key, values in group.items()}
    seen: dict[str, int] = {}
    for key, qualifier, _ in figures:
        label, unit, shown_all = cells[key]
        i = seen[key] = seen.get(key, -1) + 1
        shown = shown_all[i]
        if qualifier:
            label = f"{label} ({qualifier})"
        ref = ""
        if seed:
            v, src = seed.get(key, ("", ""))
            ref = f"<td>{html.escape(v)} {_seed_unit(key)}, {html.escape(src)}</td>" if v else "<td></td>"
        rows.append(f"<tr><td>{html.escape(label)}</td><td class=num>{shown}</td><td>{unit}</td>{ref}</tr>")
    return f"<table>{head}{''.join(rows)}</table>"


def _pivot_table(rows: dict[str, dict[str, Any]], what: str) -> str:
    """One row per stop (or edge kind), one column per figure with its unit in the header."""
    bases: list[str] = []
    for figures in rows.values():
        bases += [b for b in figures if b not in bases]
    columns = {b: _cell(b, [rows[r].get(b) for r in rows]) for b in bases}
    head = f"<tr><th>{what}</th>" + "".join(
        f"<th>{html.escape(label)}{f' ({unit})' if unit else ''}</th>" for label, unit, _ in columns.values()
    ) + "</tr>"
    body = []
    for i, r in enumerate(rows):
        cells = "".join(f"<td class=num>{columns[b][2][i]}</td>" for b in bases)
        body.append(f"<tr><td>{html.escape(r.replace('_', ' '))}</td>{cells}</tr>")
    return f"<table>{head}{''.join(body)}</table>"


def _slider_data(run: RunFolder, samples: int = 400) -> dict[str, Any]:
    s = run.series
    idx = np.unique(np.linspace(0, s["t"].size - 1, min(samples, s["t"].size)).astype(int))
    true, est, _ = tracked_points(s)
    cols = {"t": s["t"], "x": true[:, 0], "y": true[:, 1], "psi": s.get("psi", s["est_psi"]),
            "ex": est[:, 0], "ey": est[:, 1], "el": s.get("lateral_error", np.zeros_like(s["t"]))}
    return {k: [round(float(v), 5) if math.isfinite(float(v)) else None for v in c[idx]] for k, c in cols.items()}


def _slider_svg(run: RunFolder) -> str:
    """An inline SVG of the map (y up) with a vehicle triangle; the slider's script moves it."""
    pts = [tracked_points(run.series)[0]]
    if run.layout is not None:
        pts.append(np.asarray(run.layout["path_xy"]).reshape(-1, 2))
        pts.append(np.asarray(run.layout["reflectors"]).reshape(-1, 3)[:, :2])
    allp = np.concatenate(pts)
    allp = allp[np.all(np.isfinite(allp), axis=1)]
    lo, hi = allp.min(axis=0) - 1.0, allp.max(axis=0) + 1.0
    w, h = hi - lo
    box = f"{lo[0]:.3f} {-hi[1]:.3f} {w:.3f} {h:.3f}"
    parts = [f'<svg id="drive" viewBox="{box}" width="720" height="{720 * h / w:.0f}" class="drive">']
    if run.layout is not None:
        for seg in run.layout["walls"]:
            parts.append(f'<line x1="{seg[0][0]}" y1="{-seg[0][1]}" x2="{seg[1][0]}" y2="{-seg[1][1]}" '
                         'stroke="#666" stroke-width="0.05"/>')
        for x, y, r in run.layout["reflectors"]:
            parts.append(f'<circle cx="{x}" cy="{-y}" r="{max(r, 0.08)}" fill="gold" stroke="black" '
                         'stroke-width="0.02"/>')
        path = " ".join(f"{x:.3f},{-y:.3f}" for x, y in run.layout["path_xy"])
        parts.append(f'<polyline points="{path}" fill="none" stroke="#1f77b4" stroke-width="0.03" '
                     'stroke-dasharray="0.1"/>')
    d = _slider_data(run)
    xy = zip(d["x"], d["y"], strict=True)
    trail = " ".join(f"{x:.3f},{-y:.3f}" for x, y in xy if x is not None and y is not None)
    parts.append(f'<polyline points="{trail}" fill="none" stroke="#d62728" stroke-width="0.025"/>')
    parts.append('<circle id="est" r="0.06" fill="#2ca02c"/>')
    size = 0.025 * max(w, h)
    parts.append(f'<polygon id="agv" points="{size},0 {-size / 2},{size / 2} {-size / 2},{-size / 2}" fill="#d62728"/>')
    parts.append("</svg>")
    return "".join(parts)


_SCRIPT = """
(function () {
  var d = JSON.parse(document.getElementById('drive-data').textContent);
  var slider = document.getElementById('time'), label = document.getElementById('time-label');
  var agv = document.getElementById('agv'), est = document.getElementById('est');
  function show(i) {
    var x = d.x[i], y = d.y[i], psi = d.psi[i];
    if (x !== null && y !== null && psi !== null) {
      agv.setAttribute('transform', 'translate(' + x + ',' + (-y) + ') rotate(' + (-psi * 180 / Math.PI) + ')');
    }
    if (d.ex[i] !== null && d.ey[i] !== null) { est.setAttribute('cx', d.ex[i]); est.setAttribute('cy', -d.ey[i]); }
    var el = d.el[i] === null ? '-' : (1000 * d.el[i]).toFixed(1);
    label.textContent = 't = ' + d.t[i].toFixed(2) + ' s, lateral error ' + el + ' mm';
  }
  slider.max = d.t.length - 1;
  slider.addEventListener('input', function () { show(parseInt(slider.value, 10)); });
  show(0);
})();
"""

_STYLE = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 980px; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0; } td, th { border: 1px solid #ccc; padding: 2px 8px; }
td.num { text-align: right; font-variant-numeric: tabular-nums; } img { max-width: 100%; }
.failed { color: #b00; font-weight: bold; } .slider { width: 720px; }
svg.drive { background: #fafafa; border: 1px solid #ccc; } .completed { color: #080; font-weight: bold; }
"""


def _intro(run: RunFolder, outcome: str, reason: str) -> str:
    m = run.metrics
    method = (run.layout or {}).get("method") or "default"
    return (
        f"<p>vehicle <b>{html.escape(str(m.get('vehicle', '-')))}</b>, seed {html.escape(str(m.get('seed', '-')))}, "
        f"positioning {html.escape(str(method))}; outcome "
        f"<span class={html.escape(outcome)}>{html.escape(outcome)}</span>{reason}</p>"
    )


def render_html(run: RunFolder) -> str:
    """The report of ``run`` as one HTML document (see the module docstring)."""
    m, s = run.metrics, run.series
    name = html.escape(str(m.get("scenario", run.path.name)))
    outcome = str(m.get("outcome", "-"))
    reason = f" ({html.escape(str(m['reason']))})" if m.get("reason") else ""
    has_truth = "x" in s
    true_pose = np.column_stack([s["x"], s["y"], s["psi"]]) if has_truth else None
    est_pose = np.column_stack([s["est_x"], s["est_y"], s["est_psi"]])
    valid = s.get("est_valid", s["est_status"] >= 1.0) > 0.5
    figs = [("Map", _png(plot_map_figure(run)))]
    if "lateral_error" in s:
        figs.append(("Guidance errors against time", _png(plot_guidance_errors(run))))
    if true_pose is not None:
        figs.append(("Positioning errors against time",
                     _png(plot_positioning_errors(s["t"], true_pose, est_pose, _join_times(run)))))
        figs.append(("Positioning error histogram", _png(_histogram(true_pose[valid], est_pose[valid]))))
    figs.append(("Estimator status", _png(plot_status(s["t"], s["est_status"], s.get("lateral_3sigma_est")))))
    body = [
        f"<h1>agvnav run: {name}</h1>",
        _intro(run, outcome, reason),
        "<h2>Metrics</h2>", metrics_table(m),
        "<h2>Drive</h2>", _slider_svg(run),
        '<p><input type="range" id="time" min="0" max="0" value="0" class="slider"> <span id="time-label"></span></p>',
    ]
    body += [f"<h2>{title}</h2>{img}" for title, img in figs]
    data = json.dumps(_slider_data(run)).replace("</", "<\\/")
    return (
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
        f"<title>agvnav report: {name}</title><style>{_STYLE}</style></head><body>"
        + "\n".join(body)
        + f'<script type="application/json" id="drive-data">{data}</script><script>{_SCRIPT}</script></body></html>\n'
    )


#: How a report agvnav wrote begins (:func:`render_html`): an existing file that does not is someone else's.
REPORT_HEADER = "<!DOCTYPE html><html lang=en><head><meta charset=utf-8><title>agvnav report:"


def is_agvnav_report(path: str | Path) -> bool:
    """True when ``path`` is a file that begins with :data:`REPORT_HEADER` (a report agvnav wrote)."""
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            return fh.read(len(REPORT_HEADER)) == REPORT_HEADER
    except OSError:
        return False


def check_report_file(path: str | Path, force: bool = False, option: str = "--out") -> None:
    """Refuse to write a report to ``path`` when that would replace a file agvnav did not write.

    Absent, or a report agvnav wrote: fine (a report is replaced by the newer one). A folder, or a
    missing parent folder: always refused. Any other file: refused unless ``force``. Raises a
    ValueError naming ``option`` and the file.
    """
    p = Path(path)
    if p.is_dir():
        raise ValueError(f"{option} {p}: it is a folder, not a file")
    if not p.parent.is_dir():
        raise ValueError(f"{option} {p}: the folder {p.parent} does not exist")
    if p.exists() and not force and not is_agvnav_report(p):
        raise ValueError(f"{option} {p}: the file exists and is not a report agvnav wrote; choose another file, "
                         "or use --force to overwrite it")


def write_html_report(run_dir: str | Path, out: str | Path | None = None, force: bool = False) -> Path:
    """Write the report of the run folder ``run_dir`` to ``out`` (default ``run_dir/report.html``); a fleet's
    folder gets the fleet's report (:mod:`agvnav.report.fleet_html`).

    An existing file that is not a report agvnav wrote is refused unless ``force``
    (:func:`check_report_file`). Atomic: the report is written to a temporary file beside the
    target and renamed over it, so the target is the old file or the whole new one, never a part.
    """
    target = Path(out) if out is not None else Path(run_dir) / "report.html"
    check_report_file(target, force)
    text = render_fleet_html(run_dir) if is_fleet_folder(run_dir) else render_html(load_run(run_dir))
    fd, name = tempfile.mkstemp(prefix=f".{target.name}.partial-", suffix=".html", dir=target.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)
    return target
