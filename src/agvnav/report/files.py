"""Write a run's results: metrics.json, the time series and events as CSV, and the plots.

Units: SI and radians; the CSV columns are named in :mod:`agvnav.sim` terms and
documented in docs/scenarios.md.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from agvnav.sim.run import SimResult

__all__ = ["metrics_document", "save_result", "write_csv"]


def metrics_document(result: SimResult) -> dict[str, Any]:
    """The content of metrics.json: outcome, the metrics, and how the transient was defined."""
    return {
        "scenario": result.scenario.name,
        "vehicle": result.scenario.vehicle.model,
        "seed": result.scenario.seed,
        "outcome": result.outcome,
        "reason": result.reason,
        **result.metrics.to_dict(),
        **result.extra,
        "transient": "ends at the first sample with |lateral error| <= max(10% of its initial value, 5 mm)",
        "transient_end_s": result.transient_end_s,
    }


def save_result(result: SimResult, out_dir: str | Path, plots: bool = True) -> list[Path]:
    """Write metrics.json, timeseries.csv, reflections.csv and (optionally) the PNG plots; return the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    p = out / "metrics.json"
    p.write_text(json.dumps(metrics_document(result), indent=2) + "\n", encoding="utf-8")
    written = [p, write_csv(out / "timeseries.csv", result.series)]
    refl = result.events.get("reflections")
    if refl is not None:
        written.append(write_csv(out / "reflections.csv", refl))
    if plots:
        from agvnav.report.plots import write_plots

        written += write_plots(
            result.series,
            result.path_polyline(),
            result.world.reflector_xy,
            result.world.wall_segments,
            out,
            result.transient_end_s,
            result.scenario.name,
        )
    return written


def write_csv(path: Path, columns: dict[str, NDArray[np.float64]]) -> Path:
    """One column per series, a header row of names, ``%.10g`` values."""
    names = list(columns)
    data = np.column_stack([np.asarray(columns[n], dtype=np.float64) for n in names])
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt="%.10g")
    return path
