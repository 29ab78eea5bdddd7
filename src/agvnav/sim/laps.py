"""The seed-004 tracked robot on its square route: run the closed loop, measure the error per lap (Tables I-II).

A scenario with a ``route`` (the seed-004 square) is driven by the hybrid
automaton (:class:`agvnav.navigation.hybrid.HybridAutopilot` around
:class:`agvnav.guidance.hybrid.HybridController`), positioned by the wall
landmarks (:class:`~agvnav.positioning.wall_landmarks.WallLandmarkLocalizer`
fed by :class:`agvnav.sim.rangers.UltrasonicSensorRole`), on the tracked plant
of the registry (:data:`agvnav.vehicles.PLANT_BUILDERS`): the same
:class:`~agvnav.sim.engine.ClosedLoop` as every other run.
:func:`prepare_tracked` does the cross-part checks (walls, sensors outside the
body, the route passes a landmark); :func:`simulate_tracked` runs both modes
with the same seed when ``compare_landmarks``.

Seed 004 §III compares, lap by lap, the theoretical end point of the square
route (its start) with where the robot really stopped. Here a lap ends at the
automaton's transition into E4 (four turns counted); the true pose at that
instant gives two figures per lap ``n``:

* ``error_m[n]``: distance of the true end point from the route start (the
  cumulative error, which dead reckoning lets grow);
* ``per_lap_m[n]``: distance between the end points of laps ``n`` and ``n-1``
  (the start for lap 1): the drift added by that lap, the seed's "error /
  vuelta" (its no-landmark column stays near 50 cm lap after lap instead of
  growing, so it is per lap, not cumulative).

For the route start both coincide at lap 1.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.actuators import DriveGeometry
from agvnav.guidance.hybrid import HybridController, HybridParams, PolygonRoute
from agvnav.navigation.hybrid import HybridAutopilot
from agvnav.positioning.landmark_params import LandmarkParams, check_route_passes_landmarks
from agvnav.positioning.wall_landmarks import WallLandmarkLocalizer
from agvnav.sensors.ultrasonic import UltrasonicArray
from agvnav.sim.build import build_world, guard, ultrasonic_array, wall_ids
from agvnav.sim.engine import ClosedLoop, LoopOutput
from agvnav.sim.rangers import UltrasonicSensorRole
from agvnav.vehicles import build_plant
from agvnav.world import WorldMap
from agvnav.world.scenario import Scenario
from agvnav.world.vehicle_specs import TrackedSpec

__all__ = [
    "LapErrors",
    "TrackedResult",
    "TrackedRun",
    "hybrid_params",
    "lap_errors",
    "prepare_tracked",
    "run_tracked",
    "simulate_tracked",
]


@dataclass(frozen=True)
class LapErrors:
    """Per-lap errors (m), arrays ``(n_laps,)``; ``end_xy (n_laps, 2)`` true end points; ``t`` lap end times (s)."""

    t: NDArray[np.float64]
    end_xy: NDArray[np.float64]
    error_m: NDArray[np.float64]
    per_lap_m: NDArray[np.float64]

    @property
    def laps(self) -> int:
        """Number of completed laps."""
        return int(self.t.size)


def lap_errors(transition_times: ArrayLike, t: ArrayLike, true_xy: ArrayLike, start_xy: ArrayLike) -> LapErrors:
    """Errors per lap from the E4 transition times ``(n,)`` (s) and the recorded truth.

    ``t (k,)`` sample times, ``true_xy (k, 2)`` true positions (m), ``start_xy
    (2,)`` the route start (the theoretical end of every lap). Each transition
    time is matched to the nearest sample (the automaton steps at sample times).
    """
    tt = np.asarray(transition_times, dtype=np.float64).reshape(-1)
    ts = np.asarray(t, dtype=np.float64).reshape(-1)
    xy = np.asarray(true_xy, dtype=np.float64).reshape(-1, 2)
    start = np.asarray(start_xy, dtype=np.float64).reshape(2)
    if ts.size != xy.shape[0]:
        raise ValueError(f"t has {ts.size} samples but true_xy has {xy.shape[0]}")
    if tt.size and ts.size == 0:
        raise ValueError("no samples to read the lap ends from")
    k = np.clip(np.searchsorted(ts, tt - 1e-9), 0, max(ts.size - 1, 0))
    ends = xy[k] if tt.size else np.zeros((0, 2))
    error = np.hypot(*(ends - start).T) if tt.size else np.zeros(0)
    previous = np.vstack([start[None, :], ends[:-1]]) if tt.size else np.zeros((0, 2))
    per_lap = np.hypot(*(ends - previous).T) if tt.size else np.zeros(0)
    return LapErrors(tt, ends, error, per_lap)


@dataclass(kw_only=True)
class TrackedRun(LoopOutput):
    """One closed-loop run of the tracked robot: the loop's output, the automaton, its estimator, lap errors."""

    controller: HybridController
    estimator: WallLandmarkLocalizer
    laps: LapErrors
    use_landmarks: bool

    @property
    def true_xy(self) -> NDArray[np.float64]:
        """Driven path ``(k, 2)`` (m)."""
        return np.column_stack([self.series["x"], self.series["y"]])


def run_tracked(
    sc: Scenario,
    route: PolygonRoute,
    world: WorldMap,
    layout: UltrasonicArray,
    params: HybridParams,
    *,
    use_landmarks: bool = True,
    progress: Callable[[float], None] | None = None,
) -> TrackedRun:
    """Drive ``sc.controller.laps`` laps of ``route`` under the hybrid automaton (seed 004 Fig. 7), measure them.

    The map's walls are what the rangers see and, with ``use_landmarks``, the
    landmarks; ``layout`` is the :class:`~agvnav.sensors.ultrasonic.UltrasonicArray`.
    The plant is the registry's tracked robot of ``sc.vehicle``. ``sc.duration_s``
    defaults to 1.5 x the nominal lap time x laps. Deterministic for ``sc.seed``.

    The estimator of the loop is a
    :class:`~agvnav.positioning.wall_landmarks.WallLandmarkLocalizer` fed by the
    rangers (left out when not ``use_landmarks``: pure dead reckoning); the automaton reads it.
    """
    assert isinstance(sc.vehicle, TrackedSpec)
    segs = world.wall_segments
    landmark = LandmarkParams(**params.landmark_kwargs())
    if use_landmarks:
        legs = [route.leg(k) for k in range(route.n_legs)]
        check_route_passes_landmarks(legs, segs, layout.body_width, landmark.detect_range, landmark.parallel_tolerance)
    localizer = WallLandmarkLocalizer(segs, layout, landmark, pose=route.start_pose, wall_ids=wall_ids(world),
                                      strict=False)  # a running vehicle drops a bad reading and counts it
    geometry = DriveGeometry(sc.vehicle.sprocket_radius_m, sc.vehicle.gauge_m)
    laps = sc.controller.laps
    ctrl = HybridController(route, localizer, geometry, params, laps)
    plant = build_plant(sc.vehicle, route.start_pose.tolist())
    sensors = [UltrasonicSensorRole(layout, segs, localizer)] if use_landmarks else []
    engine = ClosedLoop(plant, sensors, localizer, HybridAutopilot(ctrl), sc.step_s, sc.seed)
    duration = sc.duration_s if sc.duration_s is not None else 1.5 * laps * nominal_lap_time(route, params) + 10.0
    out = engine.run(duration, end_hold=0.0, progress=progress)
    e4 = [tr.t for tr in ctrl.transitions if tr.target.value == "E4"]
    xy = np.column_stack([out.series["x"], out.series["y"]])
    le = lap_errors(e4, out.series["t"], xy, route.start_pose[:2])
    return TrackedRun(
        series=out.series,
        events=out.events,
        wall_time_s=out.wall_time_s,
        finished=out.finished,
        controller=ctrl,
        estimator=localizer,
        laps=le,
        use_landmarks=bool(use_landmarks),
    )


def nominal_lap_time(route: PolygonRoute, params: HybridParams) -> float:
    """Time (s) of one lap at cruise speed with turns at the turn rate and the dwell."""
    perimeter = sum(route.leg(k)[2] for k in range(route.n_legs))
    turning = route.n_legs * (math.pi / 2) / params.turn_rate
    return perimeter / params.cruise_speed + turning + params.dwell


def hybrid_params(params: dict[str, Any]) -> HybridParams:
    """:class:`~agvnav.guidance.hybrid.HybridParams` from ``controller.params``.

    Keys ending ``_deg``/``_deg_s`` are in degrees and become the radian fields.
    """
    out: dict[str, Any] = {}
    for key, value in params.items():
        for suffix in ("_deg_s", "_deg"):
            if key.endswith(suffix):
                out[key[: -len(suffix)]] = math.radians(float(value))
                break
        else:
            out[key] = value
    fields = [f.name for f in dataclasses.fields(HybridParams)]
    unknown = [key for key, name in zip(params, out, strict=True) if name not in fields]
    if unknown:
        raise ValueError(
            f"the hybrid controller takes no parameter {unknown[0]!r}; it takes: {', '.join(fields)} "
            "(angles in degrees as NAME_deg, turn rates as NAME_deg_s: docs/scenarios.md, Controllers)"
        )
    return HybridParams(**out)


@dataclass
class RouteParts:
    """The validated parts of a route scenario (see :func:`prepare_tracked`)."""

    route: PolygonRoute
    world: WorldMap
    layout: UltrasonicArray
    params: HybridParams


def prepare_tracked(sc: Scenario) -> RouteParts:
    """Check the route scenario ``sc`` across its parts.

    The map has walls, the rangers stand outside the body, the route passes a landmark.
    """
    if sc.route is None or not isinstance(sc.vehicle, TrackedSpec):
        raise sc.error(("route",), "the hybrid automaton drives the tracked robot on a route")
    r = sc.route
    world = build_world(sc)
    if world.wall_segments.shape[0] == 0:
        raise sc.error(("map",), "the map has no walls: the ultrasonic landmarks are walls")
    layout = ultrasonic_array(sc)
    route = guard(
        sc, ("route",), PolygonRoute.square, r.side_m, (r.start[0], r.start[1], math.radians(r.start[2])), r.turn
    )
    params = guard(sc, ("controller", "params"), hybrid_params, sc.controller.params)
    if sc.controller.landmarks or sc.controller.compare_landmarks:  # the route must pass a landmark
        legs = [route.leg(k) for k in range(route.n_legs)]
        guard(
            sc,
            ("map",),
            check_route_passes_landmarks,
            legs,
            world.wall_segments,
            layout.body_width,
            params.detect_range,
            params.parallel_tolerance,
        )
        landmark = guard(sc, ("controller", "params"), LandmarkParams, **params.landmark_kwargs())
        guard(sc, ("ultrasonic",), WallLandmarkLocalizer, world.wall_segments, layout, landmark)  # names the pairs
    return RouteParts(route, world, layout, params)


@dataclass
class TrackedResult:
    """The runs of one route scenario: ``runs[True]`` with landmarks, ``runs[False]`` without."""

    scenario: Scenario
    runs: dict[bool, TrackedRun]
    world: WorldMap
    route: PolygonRoute

    def lap_rows(self) -> list[dict[str, Any]]:
        """One row per lap: ``lap``, then per mode ``error_per_lap_m`` and ``error_from_start_m``."""
        n = max(run.laps.laps for run in self.runs.values())
        rows = []
        for k in range(n):
            row: dict[str, Any] = {"lap": k + 1}
            for mode, run in sorted(self.runs.items(), reverse=True):
                tag = "with" if mode else "without"
                ok = k < run.laps.laps
                row[f"{tag}_landmarks_per_lap_m"] = float(run.laps.per_lap_m[k]) if ok else None
                row[f"{tag}_landmarks_from_start_m"] = float(run.laps.error_m[k]) if ok else None
            rows.append(row)
        return rows

    def mode_summary(self) -> dict[str, dict[str, Any]]:
        """Per mode (``with_landmarks``/``without_landmarks``): per-lap error summary (m), laps, timing."""
        modes: dict[str, Any] = {}
        for mode, run in sorted(self.runs.items(), reverse=True):
            per_lap = np.asarray(run.laps.per_lap_m, dtype=np.float64)
            sim_t = float(run.series["t"][-1]) if len(run.series["t"]) else 0.0
            wall = float(run.wall_time_s)
            modes["with_landmarks" if mode else "without_landmarks"] = {
                "mean_error_per_lap_m": float(np.mean(per_lap)) if run.laps.laps else None,
                "max_error_per_lap_m": float(np.max(per_lap)) if run.laps.laps else None,
                "final_error_m": float(run.laps.error_m[-1]) if run.laps.laps else None,
                "laps": int(run.laps.laps),
                "sim_time_s": sim_t,
                "wall_time_s": wall,
                "real_time_factor": sim_t / wall if wall > 0.0 else None,
            }
        return modes


def simulate_tracked(sc: Scenario, progress: Callable[[float], None] | None = None) -> TrackedResult:
    """Run the route scenario ``sc`` (both modes with the same seed if ``compare_landmarks``); deterministic."""
    parts = prepare_tracked(sc)
    modes = [True, False] if sc.controller.compare_landmarks else [sc.controller.landmarks]
    runs = {
        mode: run_tracked(
            sc, parts.route, parts.world, parts.layout, parts.params, use_landmarks=mode, progress=progress
        )
        for mode in modes
    }
    return TrackedResult(sc, runs, parts.world, parts.route)
