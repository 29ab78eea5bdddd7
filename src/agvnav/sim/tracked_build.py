"""From a :class:`~agvnav.world.tracked_scenario.TrackedScenario` to runs and outputs (seed 004).

:func:`prepare_tracked` does the cross-part checks (map loads, walls have
length, sensors are outside the body, the route passes a landmark) and returns
the arguments of :func:`agvnav.sim.laps.run_tracked`; :func:`simulate_tracked`
runs the scenario (both modes, same seed, when ``compare_landmarks``);
:func:`save_tracked` writes ``laps.json``, ``laps.csv``, the time series and the
plot of the driven squares.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path as FsPath
from typing import Any

import numpy as np

from agvnav.sim.build import build_world
from agvnav.sim.laps import TrackedRun, run_tracked
from agvnav.world.tracked_scenario import TerrainFigures, TrackedScenario

__all__ = ["PathFollowResult", "TrackedResult", "prepare_tracked", "save_tracked", "simulate_tracked"]


def _guard(sc: TrackedScenario, key: tuple[str | int, ...], func: Any, *args: Any, **kwargs: Any) -> Any:
    try:
        return func(*args, **kwargs)
    except ValueError as exc:
        if hasattr(exc, "key"):
            raise
        raise sc.error(key, " ".join(str(exc).split())) from None


def _terrain(ref: Any) -> Any:
    from agvnav.kinematics.tracked import TrackTerrain, terrain_preset

    if isinstance(ref, TerrainFigures):
        return TrackTerrain(ref.slip_left, ref.slip_right, ref.icr_left, ref.icr_right, ref.x_icr_m, "scenario")
    return terrain_preset(ref)


def _layout(sc: TrackedScenario) -> Any:
    from agvnav.sensors.ultrasonic import UltrasonicArray, UltrasonicSensor, seed_004_layout

    us, veh = sc.ultrasonic, sc.vehicle
    base = UltrasonicSensor(
        half_angle=math.radians(us.half_angle_deg), max_incidence=math.radians(us.max_incidence_deg),
        min_range=us.min_range_m, max_range=us.max_range_m, noise_std=us.noise_std_m, p_miss=us.p_miss,
        rate_hz=us.rate_hz,
    )
    if us.sensors is None:
        return seed_004_layout(us.spacing_m, veh.body_length_m, veh.body_width_m, base)
    fields = {k: getattr(base, k) for k in base.__dataclass_fields__}
    q = 0.25 / us.rate_hz
    sensors = {
        s.name: UltrasonicSensor(**{**fields, "mount": (s.mount[0], s.mount[1], math.radians(s.mount[2])),
                                    "phase": (i % 4) * q})
        for i, s in enumerate(us.sensors)
    }
    return UltrasonicArray(sensors, veh.body_length_m, veh.body_width_m)


def _wall_ids(world: Any) -> list[str]:
    ids = []
    for w in world.walls:
        n = w.segments.shape[0]
        ids += [w.id] if n == 1 else [f"{w.id}[{i}]" for i in range(n)]
    return ids


def prepare_tracked(sc: TrackedScenario) -> dict[str, Any]:
    """Validate ``sc`` across its parts and return the keyword arguments of :func:`run_tracked`."""
    from agvnav.actuators import DriveGeometry
    from agvnav.guidance.hybrid import HybridParams, PolygonRoute
    from agvnav.positioning.wall_landmarks import LandmarkParams, WallLandmarkLocalizer, check_route_passes_landmarks

    veh, r = sc.vehicle, sc.route
    world = build_world(sc)
    if sc.controller.name == "hybrid" and world.wall_segments.shape[0] == 0:
        raise sc.error(("map",), "the map has no walls: the ultrasonic landmarks are walls")
    layout = _guard(sc, ("ultrasonic",), _layout, sc)
    route = _guard(sc, ("route",), PolygonRoute.square, r.side_m, (r.start[0], r.start[1], math.radians(r.start[2])),
                   r.turn)
    params = HybridParams()
    if sc.controller.name == "hybrid":
        params = _guard(sc, ("controller", "params"), lambda: HybridParams(**sc.hybrid_params_kwargs()))
    geometry = DriveGeometry(veh.sprocket_radius_m, veh.gauge_m)
    hybrid = sc.controller.name == "hybrid"
    if hybrid and (sc.controller.landmarks or sc.controller.compare_landmarks):  # the route must pass a landmark
        legs = [route.leg(k) for k in range(route.n_legs)]
        _guard(sc, ("map",), check_route_passes_landmarks, legs, world.wall_segments, layout.body_width,
               params.detect_range, params.parallel_tolerance)
        landmark = _guard(sc, ("controller", "params"), LandmarkParams, **params.landmark_kwargs())
        _guard(sc, ("ultrasonic",), WallLandmarkLocalizer, world.wall_segments, layout, landmark)  # names the pairs
    truth = _guard(sc, ("terrain", "truth"), _terrain, sc.terrain.truth)
    odometry = _guard(sc, ("terrain", "odometry"), _terrain, sc.terrain.odometry)
    return dict(
        route=route, walls=world.wall_segments, layout=layout, truth_terrain=truth, odometry_terrain=odometry,
        geometry=geometry,
        motor={"tau": veh.motor.time_constant_s, "asymmetry": veh.motor.asymmetry, "u_max": veh.motor.supply_v,
               "gain": (45.0 * 2.0 * math.pi / 60.0) / veh.motor.supply_v},
        pid={"kp": veh.pid.kp, "ki": veh.pid.ki, "kd": veh.pid.kd, "derivative_tau": veh.pid.derivative_time_constant_s},
        params=params, laps=sc.controller.laps, step=sc.step_s, substep=veh.substep_s,
        counts_per_rev=veh.encoder_counts_per_rev, slip_noise_std=sc.terrain.slip_noise_std, seed=sc.seed,
        wall_ids=_wall_ids(world), duration=sc.duration_s, world=world,
    )


@dataclass
class TrackedResult:
    """The runs of one tracked scenario: ``runs[True]`` with landmarks, ``runs[False]`` without."""

    scenario: TrackedScenario
    runs: dict[bool, TrackedRun]
    world: Any
    route: Any

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

    def metrics(self) -> dict[str, Any]:
        """metrics.json of a hybrid run: per mode the per-lap error summary (m) and timing.

        Per mode (``with_landmarks``/``without_landmarks``): ``mean_error_per_lap_m``,
        ``max_error_per_lap_m`` (distance between consecutive true lap end points,
        seed 004 Tables I-II), ``final_error_m``, ``laps``, ``sim_time_s``,
        ``wall_time_s`` and ``real_time_factor`` (sim time / wall time).
        """
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
        return {"scenario": self.scenario.name, "seed": self.scenario.seed, "modes": modes}


@dataclass
class PathFollowResult:
    """A tracked robot following a line/arc path with Kanayama's law (dead-reckoned pose)."""

    scenario: TrackedScenario
    series: dict[str, Any]
    path: Any
    world: Any
    finished: bool
    wall_time_s: float

    def metrics(self) -> dict[str, float]:
        """True lateral error to the path (max, RMS; m), final position and heading error, distance driven."""
        xy = np.column_stack([self.series["x"], self.series["y"]])
        proj = self.path.project(xy)
        lat = np.abs(np.asarray(proj.lateral, dtype=np.float64))
        end = np.asarray(self.path.point_at(self.path.length), dtype=np.float64).reshape(2)
        from agvnav.geometry import angle_diff

        end_heading = float(self.path.heading_at(self.path.length))
        return {
            "max_lateral_error_m": float(np.max(lat)),
            "rms_lateral_error_m": float(np.sqrt(np.mean(lat**2))),
            "final_position_error_m": float(np.hypot(*(xy[-1] - end))),
            "final_heading_error_rad": abs(float(angle_diff(self.series["psi"][-1], end_heading))),
            "distance_m": float(self.series["distance"][-1]),
            "path_completed": float(self.finished),
            "sim_time_s": float(self.series["t"][-1]),
            "wall_time_s": self.wall_time_s,
        }


def _simulate_path(sc: TrackedScenario, progress: Callable[[float], None] | None) -> PathFollowResult:
    """The Kanayama path follower on the tracked plant.

    Positioned by dead reckoning corrected by the map's walls as ultrasonic landmarks
    when the map has walls: the same estimator as the automaton's.
    """
    from agvnav.actuators import PID, MotorPair, WheelSpeedLoop
    from agvnav.guidance.kanayama import KanayamaController, KanayamaGains
    from agvnav.kinematics.tracked import TrackedVehicle
    from agvnav.positioning.wall_landmarks import LandmarkParams, WallLandmarkLocalizer
    from agvnav.sim.build import build_path
    from agvnav.sim.engine import ClosedLoop
    from agvnav.sim.tracked import KanayamaAutopilot, TrackedPlant, UltrasonicSensorRole

    kwargs = prepare_tracked(sc)
    path = build_path(sc)  # type: ignore[arg-type]
    params = sc.hybrid_params_kwargs()
    gains = KanayamaGains.from_distance(float(params.pop("convergence_distance", 0.5)))
    ctrl = _guard(sc, ("controller", "params"), KanayamaController, gains, geometry=kwargs["geometry"], **params)
    ctrl.set_path(path)
    g = kwargs["geometry"]
    start = np.asarray(path.start_pose, dtype=np.float64)
    vehicle = TrackedVehicle(g.track_width, g.wheel_radius, kwargs["truth_terrain"])
    m = kwargs["motor"]
    loop = WheelSpeedLoop(MotorPair(**m), PID(u_min=-m["u_max"], u_max=m["u_max"], **kwargs["pid"]))
    plant = TrackedPlant(vehicle, loop, kwargs["odometry_terrain"], kwargs["counts_per_rev"], start,
                         kwargs["substep"], kwargs["slip_noise_std"])
    walls, layout = kwargs["walls"], kwargs["layout"]
    landmark = LandmarkParams(**kwargs["params"].landmark_kwargs())
    localizer = WallLandmarkLocalizer(walls, layout, landmark, pose=start, wall_ids=kwargs["wall_ids"])
    sensors = [UltrasonicSensorRole(layout, walls)] if walls.shape[0] else []
    engine = ClosedLoop(plant, sensors, localizer, KanayamaAutopilot(ctrl), sc.step_s, sc.seed)
    duration = sc.duration_s or 1.5 * path.length / ctrl.cruise_speed + 10.0
    out = engine.run(duration, sc.end_hold_s, progress)
    return PathFollowResult(sc, out.series, path, kwargs["world"], out.finished, out.wall_time_s)


def simulate_tracked(
    sc: TrackedScenario, progress: Callable[[float], None] | None = None
) -> TrackedResult | PathFollowResult:
    """Run ``sc`` (both modes with the same seed if ``compare_landmarks``); deterministic for its seed.

    With ``controller.name: kanayama`` the robot follows ``path`` instead (:class:`PathFollowResult`).
    """
    if sc.controller.name == "kanayama":
        return _simulate_path(sc, progress)
    kwargs = prepare_tracked(sc)
    world = kwargs.pop("world")
    modes = [True, False] if sc.controller.compare_landmarks else [sc.controller.landmarks]
    runs = {mode: run_tracked(**kwargs, use_landmarks=mode, progress=progress) for mode in modes}
    return TrackedResult(sc, runs, world, kwargs["route"])


def save_tracked(result: TrackedResult, out_dir: str | FsPath, plots: bool = True) -> list[FsPath]:
    """Write ``metrics.json``, ``laps.json``, ``laps.csv``, ``timeseries_<mode>.csv`` and (optionally) ``laps.png``."""
    from agvnav.report.files import write_csv as _write_csv

    out = FsPath(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if isinstance(result, PathFollowResult):
        p = out / "metrics.json"
        meta = {"scenario": result.scenario.name, "seed": result.scenario.seed}
        p.write_text(json.dumps({**result.metrics(), **meta}, indent=2) + "\n", encoding="utf-8")
        written = [p, _write_csv(out / "timeseries.csv", result.series)]
        if plots:
            from agvnav.report.laps import plot_path_follow

            written.append(plot_path_follow(result, out / "path.png"))
        return written
    rows = result.lap_rows()
    summary = {
        "scenario": result.scenario.name,
        "seed": result.scenario.seed,
        "per_lap": "distance between consecutive true lap end points (the route start before lap 1)",
        "from_start": "distance of the true lap end point from the route start",
        "laps": rows,
        "modes": {
            ("with_landmarks" if mode else "without_landmarks"): {
                "mean_error_per_lap_m": float(np.mean(run.laps.per_lap_m)) if run.laps.laps else None,
                "max_error_per_lap_m": float(np.max(run.laps.per_lap_m)) if run.laps.laps else None,
                "final_error_m": float(run.laps.error_m[-1]) if run.laps.laps else None,
                "laps_completed": run.laps.laps,
                "wall_time_s": run.wall_time_s,
                "transitions": [[tr.t, tr.source.value, tr.target.value, tr.cause] for tr in run.controller.transitions],
            }
            for mode, run in result.runs.items()
        },
    }
    written = []
    p = out / "metrics.json"
    p.write_text(json.dumps(result.metrics(), indent=2) + "\n", encoding="utf-8")
    written.append(p)
    p = out / "laps.json"
    p.write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    written.append(p)
    cols = list(rows[0]) if rows else ["lap"]
    table = {c: np.array([np.nan if r[c] is None else r[c] for r in rows], dtype=np.float64) for c in cols}
    written.append(_write_csv(out / "laps.csv", table))
    for mode, run in result.runs.items():
        written.append(_write_csv(out / f"timeseries_{'with' if mode else 'without'}_landmarks.csv", run.series))
    if plots:
        from agvnav.report.laps import plot_laps

        written.append(plot_laps(result, out / "laps.png"))
    return written
