"""What happened in a run, when: faults, positioning, reactive stops, detours and station stops (issue 29).

A run's figures say how well it went; the scenario-specific events say what the scenario is
about (a 12 s blackout, a person crossing, the stations of a mission). They are made
available in three places from the same recorded signals:

* series columns (:func:`add_event_columns`): ``fault__<i>_<kind>`` (1 while injected fault
  ``i`` is active), ``obstacle_x__<id>``/``obstacle_y__<id>`` (m, the obstacle's centre; NaN
  while it is not there) and ``point_offset`` (m, the guided point ahead of base_link), so the
  plots and timeseries.csv show them;
* the ``events`` section of metrics.json (:func:`event_timeline`): time windows (s) of each
  kind, for the report;
* the summary table of ``agvnav simulate`` (:func:`agvnav.cli.simulate`), from that section.

Windows are ``[start_s, end_s)`` of consecutive samples, ``end_s`` the first sample after
the window (the run's last instant if it lasts to the end).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.navigation.guard import GUARD_LEVELS
from agvnav.world.obstacles import obstacle_from_spec
from agvnav.world.scenario import Scenario

__all__ = ["ESTIMATOR_STATUS", "add_event_columns", "event_timeline", "fault_column", "windows"]

#: ``est_status`` codes of the recorded series (docs/scenarios.md, timeseries.csv).
ESTIMATOR_STATUS = {0: "initialising", 1: "tracking", 2: "dead_reckoning", 3: "degraded", 4: "lost", -1: "other"}


def fault_column(index: int, kind: str) -> str:
    """The series column of injected fault ``index`` of ``kind``: ``fault__<index>_<kind>``."""
    return f"fault__{index}_{kind}"


def windows(t: ArrayLike, mask: ArrayLike) -> list[tuple[float, float]]:
    """``[(start_s, end_s), ...]`` of the runs of consecutive True samples of ``mask`` (s).

    ``t (n,)`` sample times (s), ``mask (n,)`` bool. ``end_s`` is the time of the first sample
    after the run, or ``t[-1]`` for a run that lasts to the end.
    """
    ts = np.asarray(t, dtype=np.float64)
    m = np.asarray(mask, dtype=bool)
    if ts.shape != m.shape or ts.ndim != 1:
        raise ValueError(f"t and mask must share one 1-D shape, got {ts.shape} and {m.shape}")
    if not m.any():
        return []
    edges = np.diff(np.concatenate([[0], m.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(float(ts[int(a)]), float(ts[min(int(b), ts.size - 1)])) for a, b in zip(starts, ends, strict=True)]


def add_event_columns(series: dict[str, NDArray[np.float64]], sc: Scenario, point_offset: float) -> None:
    """Add the event columns of scenario ``sc`` to ``series`` (module docstring); ``point_offset`` (m) is
    the tracked point's distance ahead of base_link, recorded unless a mission recorded its own."""
    t = np.asarray(series["t"], dtype=np.float64)
    for i, f in enumerate(sc.faults):
        end = math.inf if f.duration_s is None else f.start_s + f.duration_s
        on = (t >= f.start_s) & (t < end) if f.kind != "counter_wrap" else np.abs(t - f.start_s) < 0.5 * sc.step_s
        series[fault_column(i, f.kind)] = on.astype(np.float64)
    for spec in sc.obstacles or []:
        ob = obstacle_from_spec(spec)
        xy = ob.pose_at(t)[:, :2].copy()
        if ob.appears:
            xy[t < ob.start] = np.nan
        series[f"obstacle_x__{ob.id}"], series[f"obstacle_y__{ob.id}"] = xy[:, 0], xy[:, 1]
    if "point_offset" not in series:
        series["point_offset"] = np.full(t.shape, float(point_offset))


def _trigger_name(code: float, obstacle_ids: Sequence[str]) -> str | None:
    """The name of a recorded ``field_trigger`` code: an obstacle id, ``wall``, ``ranger`` or None."""
    k = int(code) if math.isfinite(code) else -1
    if 0 <= k < len(obstacle_ids):
        return obstacle_ids[k]
    return {-2: "wall", -3: "ranger"}.get(k)


def _level_windows(t: NDArray[np.float64], level: NDArray[np.float64], names: Sequence[str]) -> list[dict[str, Any]]:
    """Windows of each level above 0 of a recorded level signal, in time order."""
    out: list[dict[str, Any]] = []
    for code in range(1, len(names)):
        for a, b in windows(t, level == code):
            out.append({"level": names[code], "start_s": a, "end_s": b})
    return sorted(out, key=lambda w: w["start_s"])


def event_timeline(
    series: dict[str, NDArray[np.float64]],
    sc: Scenario,
    stops: Sequence[Any] = (),
    extra: dict[str, float] | None = None,
) -> dict[str, Any]:
    """The ``events`` section of metrics.json: the scenario-specific events of a run (times in s).

    Only the kinds that happened are present:

    * ``faults``: per injected fault its ``kind`` and window ``start_s``/``end_s`` (the scenario's,
      cut at the run's end);
    * ``estimator``: windows where the estimator was not tracking, with its ``status``;
    * ``positioning_guard`` (when it acted, or faults were injected): ``windows`` where the
      positioning guard slowed (``slow``) or stopped (``stop``) the vehicle (:mod:`agvnav.navigation.guard`),
      ``stops``, ``time_slow_s``, ``time_stop_s``, the largest estimated 3σ lateral
      ``max_lateral_3sigma_m`` (m; while a fault is active, when faults were injected) and the
      scenario's limits ``lateral_3sigma_slow_m``/``_stop_m``;
    * ``reactive``: windows where the safety fields slowed or stopped the vehicle, with the
      ``trigger`` (obstacle id, ``wall``, ``ranger`` or null) at the window's start;
    * ``detours``: local-avoidance windows with the ``obstacle`` passed;
    * ``station_stops``: per mission stop its ``station``, time ``t_s`` and, from ``extra``
      (:func:`agvnav.sim.mission.mission_figures`), ``stop_error_m`` and ``stop_heading_error_rad``.
    """
    t = np.asarray(series["t"], dtype=np.float64)
    t_end = float(t[-1])
    out: dict[str, Any] = {}
    if sc.faults:
        out["faults"] = [
            {"index": i, "kind": f.kind, "start_s": float(f.start_s),
             "end_s": min(t_end, f.start_s + f.duration_s) if f.duration_s is not None else t_end}
            for i, f in enumerate(sc.faults)
        ]
    status = np.asarray(series["est_status"], dtype=np.float64)
    est = [{"status": ESTIMATOR_STATUS.get(int(status[t == a][0]), "other"), "start_s": a, "end_s": b}
           for a, b in windows(t, status != 1.0)]
    if est:
        out["estimator"] = est
    if "guard_level" in series:
        level = np.asarray(series["guard_level"], dtype=np.float64)
        guard = _level_windows(t, level, GUARD_LEVELS)
        if guard or sc.faults:
            dt = np.diff(t, append=t[-1])
            sigma = np.asarray(series.get("lateral_3sigma_est", np.full(t.shape, np.nan)), dtype=np.float64)
            during = np.zeros(t.shape, dtype=bool)
            for i, f in enumerate(sc.faults):
                during |= np.asarray(series[fault_column(i, f.kind)]) > 0.5
            sigma = sigma[np.isfinite(sigma) & (during if during.any() else True)]
            out["positioning_guard"] = {
                "windows": guard,
                "stops": sum(1 for w in guard if w["level"] == "stop"),
                "time_slow_s": float(np.sum(dt[level == 1.0])),
                "time_stop_s": float(np.sum(dt[level >= 2.0])),
                "max_lateral_3sigma_m": float(sigma.max()) if sigma.size else math.nan,
                "lateral_3sigma_slow_m": float(sc.safety.lateral_3sigma_slow_m),
                "lateral_3sigma_stop_m": float(sc.safety.lateral_3sigma_stop_m),
            }
    ids = [o.id for o in sc.obstacles or []]
    if "reaction_level" in series:
        level = np.asarray(series["reaction_level"], dtype=np.float64)
        trig = np.asarray(series["field_trigger"], dtype=np.float64)
        react = _level_windows(t, level, ("clear", "slow", "stop"))
        for w in react:
            w["trigger"] = _trigger_name(float(trig[np.searchsorted(t, w["start_s"])]), ids)
        if react:
            out["reactive"] = react
        avoiding = np.asarray(series["avoiding"], dtype=np.float64) > 0.5
        target = np.asarray(series["detour_target"], dtype=np.float64)
        detours = [{"start_s": a, "end_s": b, "obstacle": _trigger_name(float(target[np.searchsorted(t, a)]), ids)}
                   for a, b in windows(t, avoiding)]
        if detours:
            out["detours"] = detours
    if stops:
        figures = extra or {}
        out["station_stops"] = [
            {"index": i, "station": st.station, "t_s": float(st.t),
             "stop_error_m": figures.get(f"stop_error_m[{i}]"),
             "stop_heading_error_rad": figures.get(f"stop_heading_error_rad[{i}]")}
            for i, st in enumerate(stops)
        ]
    return out
