"""Run a scenario end to end and keep what it produced: series, events, metrics.

The guidance errors reported as truth (``eps_c``, ``xi_r``, ...) are computed
after the run, in one vectorised call, from the recorded *true* pose and wheel
angle (seed 000 Fig. 5 via :func:`agvnav.guidance.errors.tracking_errors`); the
controller's own view of them, from the estimated pose, is recorded as
``eps_c_est``/``xi_r_est``.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path as FsPath
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.sim.metrics import RunMetrics, TransientSpec, compute_metrics, transient_end_index
from agvnav.world.scenario import Scenario

__all__ = ["SimResult", "save_result", "simulate"]


@dataclass
class SimResult:
    """One run: the scenario, every recorded series, the sensor events and the metrics."""

    scenario: Scenario
    series: dict[str, NDArray[np.float64]]
    events: dict[str, dict[str, NDArray[np.float64]]]
    metrics: RunMetrics
    path: Any
    world: Any
    transient_end_s: float | None

    def path_polyline(self, spacing: float = 0.02) -> NDArray[np.float64]:
        """The planned path sampled every ``spacing`` m, ``(k, 2)``."""
        n = max(2, int(np.ceil(self.path.length / spacing)) + 1)
        return self.path.point_at(np.linspace(0.0, self.path.length, n))


def simulate(
    scenario: Scenario,
    progress: Callable[[float], None] | None = None,
    spec: TransientSpec = TransientSpec(),
) -> SimResult:
    """Build and run ``scenario``; return the :class:`SimResult` (deterministic for its seed).

    ``progress(t)`` receives the simulated time about a hundred times.
    """
    from agvnav.sim.build import build

    if hasattr(scenario, "route"):  # issue 6: the seed-004 tracked robot
        from agvnav.sim.tracked_build import simulate_tracked

        return simulate_tracked(scenario, progress)  # type: ignore[arg-type,return-value]
    built = build(scenario)
    out = built.loop.run(built.duration, scenario.end_hold_s, progress)
    series = out.series
    _add_true_errors(series, built)
    e = series["eps_c"]
    k0 = transient_end_index(e, spec)
    true_pose = np.column_stack([series["x"], series["y"], series["psi"]])
    est_pose = np.column_stack([series["est_x"], series["est_y"], series["est_psi"]])
    refl = out.events.get("reflections", {})
    metrics = compute_metrics(
        series["t"],
        e,
        series["xi_r"],
        series["distance_C"],
        true_pose,
        est_pose,
        series["est_status"] >= 1.0,
        path_completed=out.finished,
        wall_time_s=out.wall_time_s,
        reflections=len(refl.get("t", ())),
        spec=spec,
    )
    series["est_valid"] = (series["est_status"] >= 1.0).astype(np.float64)
    L = built.plant.L  # nominal: where the vehicle believes C is
    series["est_x_C"] = series["est_x"] + L * np.cos(series["est_psi"])
    series["est_y_C"] = series["est_y"] + L * np.sin(series["est_psi"])
    t_end = None if k0 is None else float(series["t"][k0])
    return SimResult(scenario, series, out.events, metrics, built.path, built.world, t_end)


def _add_true_errors(series: dict[str, NDArray[np.float64]], built: Any) -> None:
    from agvnav.guidance.errors import tracking_errors

    pose = np.column_stack([series["x"], series["y"], series["psi"]])
    hint = np.nan_to_num(series["s_est"], nan=0.0)
    err = tracking_errors(
        built.path, pose, series["gamma"], built.plant.L_true, built.point, s_hint=hint, window=1.0
    )
    for name in ("eps_c", "eps_o", "xi", "xi_r", "s"):
        series[name if name != "s" else "s_true"] = np.asarray(getattr(err, name), dtype=np.float64)


def save_result(result: SimResult, out_dir: str | FsPath, plots: bool = True) -> list[FsPath]:
    """Write metrics.json, timeseries.csv, reflections.csv and (optionally) the PNG plots.

    Returns the written paths. Units: SI, radians (column names carry no degrees).
    """
    if hasattr(result.scenario, "route"):  # issue 6: the seed-004 tracked robot
        from agvnav.sim.tracked_build import save_tracked

        return save_tracked(result, out_dir, plots)  # type: ignore[arg-type]
    out = FsPath(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    meta = {
        "scenario": result.scenario.name,
        "seed": result.scenario.seed,
        "transient": "ends at the first sample with |eps_c| <= max(10% of |eps_c(0)|, 5 mm)",
        "transient_end_s": result.transient_end_s,
    }
    p = out / "metrics.json"
    p.write_text(json.dumps({**result.metrics.to_dict(), **meta}, indent=2) + "\n", encoding="utf-8")
    written.append(p)
    written.append(_write_csv(out / "timeseries.csv", result.series))
    refl = result.events.get("reflections")
    if refl is not None:
        written.append(_write_csv(out / "reflections.csv", refl))
    if plots:
        from agvnav.report import write_plots

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


def _write_csv(path: FsPath, columns: dict[str, NDArray[np.float64]]) -> FsPath:
    names = list(columns)
    data = np.column_stack([np.asarray(columns[n], dtype=np.float64) for n in names])
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt="%.10g")
    return path
