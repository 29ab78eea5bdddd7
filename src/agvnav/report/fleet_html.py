"""The HTML report of a fleet run folder (issue 28): every vehicle on the map, moved by one time slider.

Self-contained like the single run's report (:mod:`agvnav.report.html`): inline SVG, inline
JavaScript, the plots as base64 PNGs, nothing fetched. It shows the scenario, the outcome and
its reason, the fleet's figures, one row per vehicle (outcome, jobs, time slowed and stopped and
why, closest approach), then the hall (walls, reflectors from ``layout.json``) with each vehicle's
true track and its body at the slider's instant, labelled by id (a vehicle whose run has ended
stands where it stopped), and the tracks and timeline plots when the folder has them. It reads
``metrics.json`` (its ``fleet`` and ``vehicles`` sections), ``timeseries.csv`` in long form (column
``vehicle`` the vehicle's index) and ``layout.json`` (:func:`fleet_layout`).
"""

from __future__ import annotations

import base64
import html
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav._display import format_number
from agvnav.report.series_csv import read_csv

__all__ = ["SLIDER_SAMPLES", "fleet_slider_data", "is_fleet_folder", "render_fleet_html"]

F64 = NDArray[np.float64]

#: Instants the slider steps through (at most).
SLIDER_SAMPLES = 400
#: Colours of the vehicles, in turn.
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f")


def is_fleet_folder(run_dir: str | Path) -> bool:
    """True when the folder's metrics.json is a fleet run's (a ``fleet`` section)."""
    try:
        doc = json.loads((Path(run_dir) / "metrics.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(doc, dict) and isinstance(doc.get("fleet"), dict)


def fleet_slider_data(series: dict[str, F64], n_vehicles: int, samples: int = SLIDER_SAMPLES) -> dict[str, Any]:
    """Poses of every vehicle on one time grid: ``t`` (s, ``(k,)``) and per vehicle ``x, y, psi`` lists.

    A vehicle's pose at a grid instant is its last recorded row at or before it (a vehicle whose
    run ended holds its last pose); rows are decimated as the run recorded them.
    """
    vid = series["vehicle"].astype(np.int64)
    t_end = float(np.nanmax(series["t"])) if series["t"].size else 0.0
    grid = np.linspace(0.0, t_end, max(2, min(samples, int(np.sum(vid == 0)) or samples)))
    out: dict[str, Any] = {"t": [round(float(v), 4) for v in grid], "x": [], "y": [], "psi": []}
    for i in range(n_vehicles):
        rows = np.flatnonzero(vid == i)
        t = series["t"][rows]
        k = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, max(rows.size - 1, 0))
        for name in ("x", "y", "psi"):
            col = series[name][rows][k] if rows.size else np.full(grid.size, np.nan)
            out[name].append([round(float(v), 4) if math.isfinite(float(v)) else None for v in col])
    return out


def _svg(layout: dict[str, Any] | None, series: dict[str, F64], rows: list[dict[str, Any]],
         data: dict[str, Any]) -> str:
    """The hall (y up), every vehicle's true track and a body per vehicle that the script moves."""
    pts = [np.column_stack([series["x"], series["y"]])]
    if layout is not None and layout.get("walls"):
        pts.append(np.asarray(layout["walls"], dtype=np.float64).reshape(-1, 2))
    allp = np.concatenate(pts)
    allp = allp[np.all(np.isfinite(allp), axis=1)]
    lo, hi = allp.min(axis=0) - 1.0, allp.max(axis=0) + 1.0
    w, h = hi - lo
    parts = [(f'<svg id="hall" viewBox="{lo[0]:.3f} {-hi[1]:.3f} {w:.3f} {h:.3f}" width="900" '
              f'height="{900 * h / w:.0f}" class="drive">')]
    if layout is not None:
        for seg in layout.get("walls", []):
            parts.append(f'<line x1="{seg[0][0]}" y1="{-seg[0][1]}" x2="{seg[1][0]}" y2="{-seg[1][1]}" '
                         'stroke="#666" stroke-width="0.08"/>')
        for x, y, r in layout.get("reflectors", []):
            parts.append(f'<circle cx="{x}" cy="{-y}" r="{max(r, 0.12)}" fill="gold" stroke="black" '
                         'stroke-width="0.02"/>')
    size = 0.012 * max(w, h)
    for i, row in enumerate(rows):
        colour = COLOURS[i % len(COLOURS)]
        trail = " ".join(f"{x:.3f},{-y:.3f}" for x, y in zip(data["x"][i], data["y"][i], strict=True)
                         if x is not None and y is not None)
        parts.append(f'<polyline points="{trail}" fill="none" stroke="{colour}" stroke-width="0.06" opacity="0.5"/>')
        parts.append(f'<g id="agv{i}"><polygon points="{size},0 {-size / 2},{size / 2} {-size / 2},{-size / 2}" '
                     f'fill="{colour}" stroke="black" stroke-width="0.03"/>'
                     f'<text x="{size:.3f}" y="{-size:.3f}" font-size="{1.4 * size:.3f}">'
                     f'{html.escape(str(row.get("id", i)))}</text></g>')
    parts.append("</svg>")
    return "".join(parts)


_STYLE = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1100px; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0; } td, th { border: 1px solid #ccc; padding: 2px 8px; }
td.num { text-align: right; font-variant-numeric: tabular-nums; } img { max-width: 100%; }
.failed { color: #b00; font-weight: bold; } .completed { color: #080; font-weight: bold; } .slider { width: 900px; }
svg.drive { background: #fafafa; border: 1px solid #ccc; }
"""

_SCRIPT = """
(function () {
  var d = JSON.parse(document.getElementById('fleet-data').textContent);
  var slider = document.getElementById('time'), label = document.getElementById('time-label');
  function show(k) {
    for (var i = 0; i < d.x.length; i++) {
      var x = d.x[i][k], y = d.y[i][k], psi = d.psi[i][k], g = document.getElementById('agv' + i);
      if (g && x !== null && y !== null && psi !== null) {
        g.setAttribute('transform', 'translate(' + x + ',' + (-y) + ')');  // the label stays upright
        g.firstChild.setAttribute('transform', 'rotate(' + (-psi * 180 / Math.PI) + ')');
      }
    }
    label.textContent = 't = ' + d.t[k].toFixed(2) + ' s, ' + d.x.length + ' vehicles';
  }
  slider.max = d.t.length - 1;
  slider.addEventListener('input', function () { show(parseInt(slider.value, 10)); });
  show(0);
})();
"""

#: Per-vehicle columns of the report's table: key, heading.
VEHICLE_COLUMNS = (
    ("id", "vehicle"), ("model", "model"), ("outcome", "outcome"), ("reason", "reason"),
    ("jobs_completed", "jobs done"), ("deliveries", "deliveries"), ("distance_m", "distance (m)"),
    ("time_stopped_positioning_s", "stopped, positioning (s)"), ("time_slowed_fields_s", "slowed, fields (s)"),
    ("time_stopped_fields_s", "stopped, fields (s)"), ("time_stopped_by_vehicle_s", "stopped by a vehicle (s)"),
    ("stopped_most_by", "mostly by"), ("min_separation_m", "closest (m)"), ("nearest_vehicle", "to"),
    ("traffic_wait_s", "waited for traffic (s)"), ("traffic_wait_most_at", "mostly at"),
)


def _cell(value: Any) -> str:
    if isinstance(value, bool) or value is None:
        return "-" if value is None else str(value)
    if isinstance(value, int):
        return str(value)  # counts stay whole
    if isinstance(value, int | float):
        return html.escape(format_number(float(value))) if math.isfinite(float(value)) else "-"
    return html.escape(str(value))


def _tables(metrics: dict[str, Any]) -> str:
    fleet = metrics.get("fleet", {})
    rows = "".join(f"<tr><td>{html.escape(k)}</td><td class=num>{_cell(v)}</td></tr>"
                   for k, v in fleet.items() if not isinstance(v, list | dict))
    head = "".join(f"<th>{html.escape(h)}</th>" for _, h in VEHICLE_COLUMNS)
    body = "".join("<tr>" + "".join(f"<td>{_cell(v.get(k))}</td>" for k, _ in VEHICLE_COLUMNS) + "</tr>"
                   for v in metrics.get("vehicles", []))
    waits = "".join(f"<tr><td>{html.escape(str(v.get('id')))}</td><td>{html.escape(z)}</td><td>{_cell(s)}</td></tr>"
                    for v in metrics.get("vehicles", []) for z, s in (v.get("traffic_wait_by_zone_s") or {}).items())
    traffic = (f"<h2>Waiting for traffic</h2><table><tr><th>vehicle</th><th>zone waited for</th><th>time (s)</th></tr>"
               f"{waits}</table>") if waits else ""
    return (f"<h2>Fleet</h2><table>{rows}</table><h2>Vehicles</h2>"
            f"<table><tr>{head}</tr>{body}</table>{traffic}")


def render_fleet_html(run_dir: str | Path) -> str:
    """The report of the fleet run folder ``run_dir`` as one HTML document (module docstring)."""
    d = Path(run_dir)
    try:
        metrics = json.loads((d / "metrics.json").read_text(encoding="utf-8"))
        series = read_csv(d / "timeseries.csv")
    except (OSError, ValueError) as exc:
        raise ValueError(f"{d}: not a readable agvnav fleet run folder ({exc})") from None
    layout_file = d / "layout.json"
    layout = json.loads(layout_file.read_text(encoding="utf-8")) if layout_file.is_file() else None
    rows = list(metrics.get("vehicles", []))
    data = fleet_slider_data(series, len(rows))
    name = html.escape(str(metrics.get("scenario", d.name)))
    outcome = str(metrics.get("outcome", "-"))
    reason = f" ({html.escape(str(metrics['reason']))})" if metrics.get("reason") else ""
    pngs = [(title, d / f) for title, f in (("Tracks", "fleet_tracks.png"), ("Timeline", "fleet_timeline.png"))
            if (d / f).is_file()]
    body = [
        f"<h1>agvnav fleet run: {name}</h1>",
        (f"<p>{len(rows)} vehicles, seed {html.escape(str(metrics.get('seed', '-')))}; outcome "
         f"<span class={html.escape(outcome)}>{html.escape(outcome)}</span>{reason}</p>"),
        _tables(metrics),
        "<h2>The hall</h2>", _svg(layout, series, rows, data),
        '<p><input type="range" id="time" min="0" max="0" value="0" class="slider"> <span id="time-label"></span></p>',
        *(f'<h2>{t}</h2><img alt="{t}" src="data:image/png;base64,{base64.b64encode(p.read_bytes()).decode()}">'
          for t, p in pngs),
    ]
    blob = json.dumps(data).replace("</", "<\\/")
    return (
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
        f"<title>agvnav report: {name}</title><style>{_STYLE}</style></head><body>"
        + "\n".join(body)
        + f'<script type="application/json" id="fleet-data">{blob}</script><script>{_SCRIPT}</script></body></html>\n'
    )
