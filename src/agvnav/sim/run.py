"""Run a scenario end to end and keep what it produced: series, events, outcome, metrics.

The guidance errors reported as truth are computed after the run, in one
vectorised call, from the recorded *true* pose: ``lateral_error`` of the
tracked point and ``heading_error`` of the vehicle against the path (tangent,
plus the yaw offset of a holonomic vehicle); for steered vehicles also the
seed-000 Fig. 5 errors ``eps_c``/``xi_r`` (with the true wheel angle, via
:func:`agvnav.guidance.errors.tracking_errors`). The controller's own view, from
the estimated pose, is recorded as ``lateral_error_est``/``heading_error_est``.

The outcome is judged on the truth: ``completed`` when the autopilot finished
and the true tracked point ended within ``end_tolerance`` of the path's end;
otherwise ``failed`` with a reason (:data:`FAILURE_REASONS`): ``collision`` (the
footprint touched a wall, :mod:`agvnav.sim.collision`), ``jackknife`` or another
plant failure, ``infeasible`` (the follower could not command the path),
``positioning_lost`` (the time limit came while the vehicle stood stopped by the
positioning guard, :mod:`agvnav.navigation.guard`), ``timeout``, ``off_path_at_end``.
The integrity figures (:mod:`agvnav.sim.integrity`) go with the metrics.

Headline figures summarise the detailed ones (issue 29): a mission's errors are those of
the point the controller guides at each instant (C cruising, O manoeuvring after point
switching) against the run it drove (:func:`agvnav.sim.mission.guided_errors`), over the
samples its per-edge figures count, so ``max_abs_lateral_error_m`` is the largest
``max_lateral_m.<kind>``. The heading figures name what each vehicle has: a wheel heading
error only for a steered vehicle, and for every vehicle the body heading against the path's
reference heading outside the reorientation after each step of it (:func:`reference_steps`).
The scenario-specific events (faults, positioning, reactive stops, stations) become series
columns and ``SimResult.timeline`` (:mod:`agvnav.sim.events`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import wrap_angle, wrap_angle_scalar
from agvnav.guidance import Path
from agvnav.guidance.errors import tracking_errors
from agvnav.sim.build import Built, build
from agvnav.sim.engine import LoopOutput
from agvnav.sim.events import add_event_columns, event_timeline
from agvnav.sim.integrity import integrity_figures
from agvnav.sim.metrics import RunMetrics, TransientSpec, compute_metrics, reorientation_mask, transient_end_index
from agvnav.sim.reactive import reactive_figures
from agvnav.vehicles import SteeredGeometry
from agvnav.world import WorldMap
from agvnav.world.scenario import Scenario

__all__ = [
    "END_TOLERANCE_M", "FAILURE_REASONS", "REFERENCE_STEP_RAD", "SimResult", "reference_steps", "result_of", "simulate",
]

#: Reasons a run fails (``off_path_at_end`` carries its miss distance in parentheses).
FAILURE_REASONS = ("collision", "jackknife", "infeasible", "positioning_lost", "timeout", "off_path_at_end")

#: The transient definition of :mod:`agvnav.sim.metrics` used by default.
DEFAULT_TRANSIENT = TransientSpec()

#: How close (m) the true tracked point must end to the path's end for ``completed``.
END_TOLERANCE_M = 0.1


@dataclass
class SimResult:
    """One run: the scenario, every recorded series, the sensor events, outcome and metrics."""

    scenario: Scenario
    series: dict[str, NDArray[np.float64]]
    events: dict[str, dict[str, NDArray[np.float64]]]
    metrics: RunMetrics
    path: Path
    world: WorldMap
    transient_end_s: float | None
    outcome: str
    reason: str | None
    extra: dict[str, float]
    integrity: dict[str, Any] = field(default_factory=dict)
    reactive: dict[str, Any] = field(default_factory=dict)
    """stops, time stopped, clearance and encounter per obstacle (issue 18: ``sim.reactive.reactive_figures``)."""
    timeline: dict[str, Any] = field(default_factory=dict)
    """the scenario-specific events (faults, positioning, reactive stops, station stops; ``sim.events.event_timeline``):
    the ``events`` section of metrics.json."""

    @property
    def completed(self) -> bool:
        """True when the run completed its path (judged on the true pose)."""
        return self.outcome == "completed"

    def path_polyline(self, spacing: float = 0.02) -> NDArray[np.float64]:
        """The planned path sampled every ``spacing`` m, ``(k, 2)``."""
        n = max(2, int(np.ceil(self.path.length / spacing)) + 1)
        return np.asarray(self.path.point_at(np.linspace(0.0, self.path.length, n)))


def simulate(
    scenario: Scenario,
    progress: Callable[[float], None] | None = None,
    spec: TransientSpec = DEFAULT_TRANSIENT,
    built: Built | None = None,
) -> SimResult:
    """Build and run ``scenario`` (a vehicle following a path); deterministic for its seed.

    A route scenario (the seed-004 square) runs laps instead: :func:`agvnav.sim.laps.simulate_tracked`.

    ``progress(t)`` receives the simulated time about a hundred times. ``built`` is
    ``build(scenario)`` when the caller has built it already and not run it (``agvnav simulate``
    builds first to check the scenario): the same run, without building it twice.
    """
    if built is None:
        built = build(scenario)
    out = built.loop.run(built.duration, scenario.end_hold_s, progress)
    return result_of(scenario, built, out, spec)


def result_of(scenario: Scenario, built: Built, out: LoopOutput, spec: TransientSpec = DEFAULT_TRANSIENT) -> SimResult:
    """The :class:`SimResult` of ``built``'s loop output ``out`` (a run of :func:`simulate`, or one
    vehicle of a fleet stepped in lockstep: :mod:`agvnav.sim.fleet`)."""
    series = out.series
    _add_true_errors(series, built)
    mission_module: Any = None
    if built.mission is not None:  # the guided point (C or O after point switching) against its own run
        from agvnav.sim import mission as mission_module  # noqa: PLC0415 - routes load only for missions (start-up)

        wheelbase = float(getattr(built.plant.geometry, "wheelbase", 0.0))
        series.update(mission_module.guided_errors(series, built.mission, built.plant.family, wheelbase))
    add_event_columns(series, scenario, built.point_offset)
    e = series["lateral_error"]
    k0 = transient_end_index(e, spec)
    true_pose = np.column_stack([series["x"], series["y"], series["psi"]])
    est_pose = np.column_stack([series["est_x"], series["est_y"], series["est_psi"]])
    outcome, reason = _outcome(out.finished, out.failure or built.autopilot.failure, series, built)
    docking: dict[str, float] = {}
    if scenario.docking is not None and scenario.mission is None:  # issue 32: judged on the true station
        outcome, reason, docking = _docking_outcome(scenario, series, built, outcome, reason)
    refl = out.events.get("reflections", {})
    steered = built.plant.family == "steered"
    counted = None if mission_module is None else mission_module.moving_mask(series)
    steps = reference_steps(built.path, built.plant.family == "holonomic")
    distance = _distance(series)
    metrics = compute_metrics(
        series["t"],
        e,
        series["xi"] if steered else series["heading_error"],
        distance,
        true_pose,
        est_pose,
        series["est_status"] >= 1.0,
        path_completed=outcome == "completed",
        wall_time_s=out.wall_time_s,
        reflections=len(refl.get("t", ())),
        spec=spec,
        wheel_heading_error=series["xi_r"] if steered else None,
        counted=counted,
        reorienting=reorientation_mask(series["s_true"], distance, steps),
        heading_reorientations=len(steps),
    )
    series["est_valid"] = (series["est_status"] >= 1.0).astype(np.float64)
    off = series["point_offset"]  # nominal: where the vehicle believes its guided point is
    series["est_x_C"] = series["est_x"] + off * np.cos(series["est_psi"])
    series["est_y_C"] = series["est_y"] + off * np.sin(series["est_psi"])
    t_end = None if k0 is None else float(series["t"][k0])
    extra = _extra_figures(series)
    extra.update(docking)
    stops = getattr(built.autopilot, "stops", [])
    if mission_module is not None:  # stop errors, mission time, lateral error per edge kind (issue 14)
        extra.update(mission_module.mission_figures(series, built.mission, stops, counted))
    integrity = integrity_figures(series, distance, scenario.traction.max_decel_m_s2)
    reactive = {} if "reaction_level" not in series else reactive_figures(  # issue 18
        series, [o.id for o in scenario.obstacles or []], reason, int(getattr(built.loop.plant, "hit", -1)))
    timeline = event_timeline(series, scenario, stops, extra)
    return SimResult(
        scenario, series, out.events, metrics, built.path, built.world, t_end, outcome, reason, extra, integrity,
        reactive, timeline,
    )


#: Smallest step (rad) of the reference heading between two segments that counts as a reorientation.
REFERENCE_STEP_RAD = math.radians(1.0)


def reference_steps(path: Path, yaw_offsets: bool) -> NDArray[np.float64]:
    """Path abscissas (m) of the joints where the reference heading steps by more than :data:`REFERENCE_STEP_RAD`.

    The reference heading is the tangent, + pi on a reverse segment, + the segment's yaw offset
    when ``yaw_offsets`` (a holonomic vehicle): a step is a reorientation the body makes over
    some distance (:func:`agvnav.sim.metrics.reorientation_mask`), not a guidance error.
    """
    segs = path.segments

    def ref(seg: Any, heading: float) -> float:
        yaw = float(getattr(seg, "yaw_offset", 0.0)) if yaw_offsets else 0.0
        return heading + (math.pi if seg.direction < 0 else 0.0) + yaw

    out = [
        float(s)
        for a, b, s in zip(segs[:-1], segs[1:], path.segment_starts[1:-1], strict=True)
        if abs(wrap_angle_scalar(ref(b, float(b.heading_at(0.0))) - ref(a, float(a.end_heading)))) > REFERENCE_STEP_RAD
    ]
    return np.asarray(out, dtype=np.float64)


def _distance(series: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    """Distance travelled by the vehicle's reference wheel or point, as its plant records it (m)."""
    for name in ("distance_C", "distance_O", "distance"):
        if name in series:
            return series[name]
    raise KeyError("the plant records no distance signal")


#: Slack (m) of the truth's progress between two samples beyond twice the distance its
#: reference point travelled: a larger step is a projection that followed a wrong hint.
PROGRESS_SLACK_M = 0.05


def _add_true_errors(series: dict[str, NDArray[np.float64]], built: Built) -> None:
    """Lateral and heading errors of the true pose against the path (see the module docstring).

    The projection searches 1 m around a hint, the estimate's progress ``s_est``. Where
    the truth's progress then jumps further than its reference point travelled (the
    estimate relocalised wrongly, or the autopilot's progress ran on while positioning
    was lost), those samples are projected again one by one around the truth's own
    progress at the previous sample, until the two projections agree again: a wrong
    estimate never moves the truth's projection onto another part of the path.
    """
    pose = np.column_stack([series["x"], series["y"], series["psi"]])
    hint = np.nan_to_num(series["s_est"], nan=0.0)
    path, off = built.path, built.point_offset
    if off and built.plant.family == "steered":  # the true C is the true wheelbase ahead of O
        off = float(getattr(built.plant, "L_true", off))
    point = pose[:, :2] + off * np.column_stack([np.cos(pose[:, 2]), np.sin(pose[:, 2])])
    series["x_tracked"], series["y_tracked"] = point[:, 0].copy(), point[:, 1].copy()
    steered = built.plant.family == "steered"
    g = built.plant.geometry
    L_true = float(getattr(built.plant, "L_true", g.wheelbase)) if isinstance(g, SteeredGeometry) else 0.0
    gamma = (series["gamma"] if "gamma" in series else series["phi"]) if steered else None

    def errors(k: slice, s_hint: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
        if gamma is not None:
            err = tracking_errors(path, pose[k], gamma[k], L_true, built.point, s_hint=s_hint, window=1.0)
            out = {name: np.asarray(getattr(err, name), dtype=np.float64) for name in ("eps_c", "eps_o", "xi", "xi_r")}
            out.update(s_true=np.asarray(err.s, dtype=np.float64), lateral_error=out["eps_c"])
            out["heading_error"] = out["xi_r"]
            return out
        proj = path.project(point[k], s_hint=s_hint, window=1.0)
        reverse = np.where(np.asarray(proj.direction) < 0, math.pi, 0.0)
        yaw = np.asarray(path.yaw_offset_at(proj.s)) if built.plant.family == "holonomic" else 0.0
        return {
            "s_true": np.asarray(proj.s, dtype=np.float64),
            "lateral_error": np.asarray(proj.lateral, dtype=np.float64),
            "heading_error": np.asarray(wrap_angle(pose[k, 2] - proj.heading - reverse - yaw), dtype=np.float64),
        }

    found = errors(slice(None), hint)
    s_true, step = found["s_true"], np.abs(np.diff(_distance(series)))
    jumps = np.flatnonzero(np.abs(np.diff(s_true)) > 2.0 * step + PROGRESS_SLACK_M) + 1
    i, n = 0, s_true.size
    for j in jumps:
        i = max(i, int(j))
        while i < n:  # re-project around the truth's own progress until the first pass agrees
            one = errors(slice(i, i + 1), s_true[i - 1:i].copy())
            agrees = abs(float(one["s_true"][0]) - float(s_true[i])) < 1e-9
            for name, values in one.items():
                found[name][i] = values[0]
            i += 1
            if agrees:
                break
    series.update(found)


def _outcome(
    finished: bool, failure: str | None, series: dict[str, NDArray[np.float64]], built: Built
) -> tuple[str, str | None]:
    """``("completed", None)`` or ``("failed", reason)``, judged on the true pose."""
    if failure is not None:
        return "failed", failure
    if not finished:
        stopped = "guard_level" in series and series["guard_level"][-1] >= 2.0
        return "failed", "positioning_lost" if stopped else "timeout"
    end = built.path.point_at(built.path.length)
    x, y = float(series["x_tracked"][-1]), float(series["y_tracked"][-1])
    miss = math.hypot(x - float(end[0]), y - float(end[1]))
    if miss > END_TOLERANCE_M:
        return "failed", f"off_path_at_end ({miss:.3f} m from the path end)"
    return "completed", None


def _docking_outcome(scenario: Scenario, series: dict[str, NDArray[np.float64]], built: Built, outcome: str,
                     reason: str | None) -> tuple[str, str | None, dict[str, float]]:
    """A docking reported finished fails when its true error exceeds the tolerance (issue 32)."""
    from agvnav.navigation.docking import DockingAutopilot  # noqa: PLC0415 - docking runs only
    from agvnav.sim.docking import docking_figures  # noqa: PLC0415

    pilot = built.autopilot
    assert isinstance(pilot, DockingAutopilot) and scenario.docking is not None
    figs = docking_figures(scenario, series, pilot)
    tol, tol_h = scenario.docking.tolerance_mm * 1e-3, math.radians(scenario.docking.heading_tolerance_deg)
    if outcome == "completed" and (figs["dock_error_m"] > tol or figs["dock_heading_error_rad"] > tol_h):
        return "failed", (f"docking_error ({figs['dock_error_m'] * 1e3:.2f} mm, "
                          f"{math.degrees(figs['dock_heading_error_rad']):.3f} deg on the true station)"), figs
    return outcome, reason, figs


def _extra_figures(series: dict[str, NDArray[np.float64]]) -> dict[str, float]:
    """Figures of particular vehicles: the trailer's off-tracking and largest hitch angle."""
    extra: dict[str, float] = {}
    if "hitch_angle" in series:
        extra["max_abs_hitch_angle_rad"] = float(np.max(np.abs(series["hitch_angle"])))
    return extra
