"""From a validated :class:`~agvnav.world.scenario.Scenario` to a running closed loop, for every vehicle.

Building is where the cross-part checks happen (the schema alone cannot see
them): the map must load, the path must have no gap and be feasible for the
vehicle (steering limit, reverse, hitch angle), the controller must fit the
vehicle and its gains be stable (Routh-Hurwitz, [seed000 eq18] [seed000 eq19]),
and with a goniometer at least three reflectors must be in view all along the
path. Every failure is a :class:`~agvnav.world.scenario.ScenarioError` naming
the key and its line.

The registries do the dispatch: the vehicle kind's spec class (its family, whether it
reverses; :data:`agvnav.world.vehicle_specs.VEHICLE_KINDS`) and
:func:`agvnav.vehicles.build_plant` (vehicle spec -> truth vehicle), :func:`agvnav.guidance.make_follower`
(controller name and vehicle family -> path follower),
:func:`agvnav.positioning.make_estimator` (method -> estimator).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path as FsPath
from typing import TYPE_CHECKING, ParamSpec, TypeVar

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import Point, Polygon

from agvnav.actuators import SpeedProfile
from agvnav.guidance import (
    FOLLOWERS,
    ArcSegment,
    GuidanceError,
    LineSegment,
    Path,
    PathFollower,
    check_path_feasible,
    follower_parameters,
    make_follower,
)
from agvnav.guidance.errors import feedforward_steering
from agvnav.kinematics import TractorTrailer
from agvnav.navigation.docking import DockingAutopilot, DockingEstimate, DockingTolerances
from agvnav.navigation.fine_positioning import fine_positioner
from agvnav.navigation.guard import EstimatorWatch, GuardLimits, PositioningGuard
from agvnav.navigation.path import PathAutopilot
from agvnav.odometry import OdometryNoise, steered_noise
from agvnav.positioning import make_estimator
from agvnav.positioning.ekf import EkfEstimator
from agvnav.positioning.estimator import StreamingEstimator
from agvnav.positioning.station import StationEstimator
from agvnav.positioning.wall_landmarks import WallLandmarkLocalizer
from agvnav.roles import Plant, RangeEstimator, Sensor
from agvnav.sensors.goniometer import Goniometer
from agvnav.sensors.ultrasonic import UltrasonicArray, UltrasonicSensor, seed_004_layout
from agvnav.sim import docking
from agvnav.sim.collision import CollisionWatch, WallCollider
from agvnav.sim.engine import ClosedLoop
from agvnav.sim.faults import PLANT_FAULTS, FaultyPlant, FaultySensor, world_with_faults
from agvnav.sim.rangers import UltrasonicSensorRole
from agvnav.sim.reactive import wire_reactive
from agvnav.sim.roles import GoniometerSensor
from agvnav.vehicles import build_plant
from agvnav.vehicles.builders import Plant as VehiclePlant
from agvnav.world import WorldMap, builtin_map_names, load_builtin_map, load_map
from agvnav.world.docking import DockingTarget
from agvnav.world.scenario import KeyPath, Scenario, ScenarioError
from agvnav.world.vehicle_specs import TractorTrailerSpec

if TYPE_CHECKING:  # mission parts: imported at run time only for a mission scenario (see build)
    from agvnav.navigation.mission import MissionAutopilot
    from agvnav.routes.mission import MissionPlan

__all__ = [
    "DEFAULT_FOLLOWERS",
    "Built",
    "PositioningEstimator",
    "build",
    "build_docking",
    "build_path",
    "build_world",
    "guard",
    "reflectors_in_view",
    "surveyed_truth",
    "ultrasonic_array",
    "wall_ids",
]

#: The follower a vehicle family gets when the scenario names none.
DEFAULT_FOLLOWERS = {"steered": "seed_simple", "unicycle": "kanayama", "holonomic": "holonomic"}

T = TypeVar("T")
P = ParamSpec("P")

#: The estimators a scenario builds: a streaming estimator of the goniometer (and, the EKF, of the
#: rangers), or the wall-landmark localizer (seed 004; pure dead reckoning without walls).
PositioningEstimator = StreamingEstimator | WallLandmarkLocalizer


@dataclass
class Built:
    """The wired parts of one run."""

    loop: ClosedLoop
    world: WorldMap
    path: Path
    plant: VehiclePlant
    autopilot: PathAutopilot | MissionAutopilot | DockingAutopilot
    estimator: PositioningEstimator
    duration: float
    point: str
    point_offset: float
    mission: MissionPlan | None = None
    """the planned mission (:class:`agvnav.routes.mission.MissionPlan`) of a mission scenario."""
    docking: DockingEstimate | None = None
    """a mission scenario with a ``docking`` section: the global and the (idle) station estimator the loop
    feeds, for a docking at the target's node (:func:`docking_autopilot`; the VDA 5050 ``finePositioning``)."""


def guard(sc: Scenario, key: KeyPath, func: Callable[P, T], *args: P.args, **kwargs: P.kwargs) -> T:
    """Call ``func``; a ValueError becomes a ScenarioError at ``key`` (with its line)."""
    try:
        return func(*args, **kwargs)
    except ScenarioError:
        raise
    except ValueError as exc:
        raise sc.error(key, " ".join(str(exc).split())) from None


def build_world(sc: Scenario) -> WorldMap:
    """The map: a shipped name (``lab``), a file path (relative to the scenario), or inline."""
    spec = sc.map
    if isinstance(spec, dict):
        return guard(sc, ("map",), WorldMap.from_dict, spec)
    if spec in builtin_map_names():
        return load_builtin_map(spec)
    p = FsPath(spec)
    if not p.is_absolute() and sc.base_dir is not None:
        p = sc.base_dir / p
    if not p.is_file():
        raise sc.error(("map",), f"{spec!r} is neither a shipped map ({', '.join(builtin_map_names())}) nor a file")
    return guard(sc, ("map",), load_map, p)


def build_path(sc: Scenario) -> Path:
    """The planned path of the tracked point from the chained segment specs; gaps are errors."""
    spec = sc.path
    if spec is None:
        raise sc.error(("path",), "this vehicle follows a path: give the path key")
    pos = np.array(spec.start[:2], dtype=np.float64)
    heading = math.radians(spec.start[2])
    segs: list[LineSegment | ArcSegment] = []
    for i, seg in enumerate(spec.segments):
        key: KeyPath = ("path", "segments", i)
        if seg.start is not None:
            gap = float(np.hypot(*(np.asarray(seg.start) - pos)))
            if i > 0 and gap > spec.gap_tolerance_m:
                raise sc.error((*key, "start"), f"gap in the path: starts {gap:.4g} m from the end of segment {i - 1}")
            pos = np.asarray(seg.start, dtype=np.float64)
        if seg.heading_deg is not None:
            heading = math.radians(seg.heading_deg)
        d = 1 if seg.direction == "forward" else -1
        yaw = math.radians(seg.yaw_offset_deg)
        obj: LineSegment | ArcSegment
        if seg.type == "line":
            obj = guard(sc, key, LineSegment, pos.copy(), heading, seg.length_m, d, yaw_offset=yaw)
        else:
            obj = guard(
                sc, key, ArcSegment, pos.copy(), heading, seg.radius_m, math.radians(seg.sweep_deg), d, yaw_offset=yaw
            )
        segs.append(obj)
        pos, heading = np.asarray(obj.end, dtype=np.float64), float(obj.end_heading)
    return guard(sc, ("path",), Path, segs)


def reflectors_in_view(
    world: WorldMap, head_xy: NDArray[np.float64], min_range: float, max_range: float
) -> NDArray[np.int64]:
    """Number of reflectors in range and in line of sight from each head position ``(k, 2)``.

    A wall segment blocks a reflector when it properly crosses the segment from the
    head to the reflector centre (vectorised over positions, reflectors and walls).
    """
    p = np.asarray(head_xy, dtype=np.float64)[:, None, :]  # (k, 1, 2)
    r = np.asarray(world.reflector_xy, dtype=np.float64)[None, :, :]  # (1, N, 2)
    d = np.hypot(*(r - p).transpose(2, 0, 1))  # (k, N)
    ok = (d >= min_range) & (d <= max_range)
    w = np.asarray(world.wall_segments, dtype=np.float64)
    if w.shape[0]:
        a, b = w[:, 0, :], w[:, 1, :]  # (M, 2)
        pr = (r - p)[:, :, None, :]  # (k, N, 1, 2)
        p4 = p[:, :, None, :]
        ab = (b - a)[None, None]  # (1, 1, M, 2)

        def cross(u: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
            return np.asarray(u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0])

        d1 = cross(pr, a[None, None] - p4)
        d2 = cross(pr, b[None, None] - p4)
        d3 = cross(ab, p4 - a[None, None])
        d4 = cross(ab, p4 + pr - a[None, None])
        blocked = np.any((d1 * d2 < 0) & (d3 * d4 < 0), axis=-1)  # (k, N)
        ok &= ~blocked
    return np.asarray(ok.sum(axis=1), dtype=np.int64)


def _base_link_along_path(path: Path, offset: float, spacing: float = 0.1) -> tuple[NDArray[np.float64], ...]:
    """Path abscissae ``s``, and base_link poses when the tracked point ``offset`` m ahead is on the path."""
    n = max(2, math.ceil(path.length / spacing) + 1)
    s = np.linspace(0.0, path.length, n)
    pts = path.point_at(s)
    heading = path.heading_at(s) + np.where(path.direction_at(s) < 0, math.pi, 0.0)
    # for C on the path, O is `offset` behind it (exact on lines, close on arcs)
    pts = pts - offset * np.column_stack([np.cos(heading), np.sin(heading)])
    return s, pts, heading


def _check_visibility(sc: Scenario, world: WorldMap, path: Path, offset: float) -> None:
    """At least ``min_reflectors_in_view`` reflectors visible from the head all along the path."""
    g = sc.goniometer
    if g is None:
        return
    s, pts, heading = _base_link_along_path(path, offset)
    mx, my = g.mount[0], g.mount[1]
    c, si = np.cos(heading), np.sin(heading)
    head = np.column_stack([pts[:, 0] + c * mx - si * my, pts[:, 1] + si * mx + c * my])
    counts = reflectors_in_view(world, head, g.min_range_m, g.max_range_m)
    bad = np.flatnonzero(counts < sc.min_reflectors_in_view)
    if bad.size:
        k = bad[0]
        raise sc.error(
            ("map",),
            f"only {counts[k]} reflector(s) in view at s = {s[k]:.2f} m of the path "
            f"(x = {pts[k, 0]:.2f}, y = {pts[k, 1]:.2f}); positioning needs at least {sc.min_reflectors_in_view}",
        )


def _check_start(sc: Scenario, size: float) -> None:
    """Refuse a start farther from the path than ``max(2 m, 2 vehicle sizes)``.

    Guidance (seed 000 §3) corrects small initial errors (110 mm in §4.3); from
    farther away the projection on the path is meaningless and progress along
    it cannot be tracked.
    """
    limit = max(2.0, 2.0 * size)
    off = sc.start.lateral_offset_m
    if abs(off) > limit:
        raise sc.error(
            ("start", "lateral_offset_m"),
            f"start {off:g} m off the path is too far: at most {limit:g} m (2 m or two vehicle lengths) is supported",
        )


def _check_feasible(sc: Scenario, path: Path, family: str, geometry: object, point: str) -> None:
    """The follower's feasibility check; an infeasible segment is named with its line."""
    try:
        check_path_feasible(path, family, geometry, sc.vehicle.reverses, point=point)
    except GuidanceError as exc:
        segment = getattr(exc, "segment", None)
        key: KeyPath = ("path", "segments", segment) if segment is not None else ("path",)
        if segment is not None and "radius" in str(exc):
            key = (*key, "radius_m")
        raise sc.error(key, " ".join(str(exc).split())) from None
    if isinstance(sc.vehicle, TractorTrailerSpec):
        _check_hitch(sc, sc.vehicle, path)


def _check_hitch(sc: Scenario, v: TractorTrailerSpec, path: Path) -> None:
    """A trailer on an arc settles at a hitch angle; refuse arcs that need one beyond the limit [seed003 §3.2.7]."""
    trailer = TractorTrailer(v.trailer_length_m, v.hitch_offset_m, math.radians(v.max_hitch_angle_deg))
    for i, seg in enumerate(path.segments):
        kappa = float(getattr(seg, "curvature", 0.0))
        if kappa == 0.0:
            continue
        phi = float(trailer.equilibrium_hitch_angle(kappa))
        if not math.isfinite(phi) or abs(phi) >= trailer.max_hitch_angle:
            raise sc.error(
                ("path", "segments", i),
                f"the trailer would need a hitch angle of {math.degrees(phi):.1f} deg on this arc "
                f"(limit {v.max_hitch_angle_deg:g} deg)",
            )


def _check_mount(sc: Scenario, plant: Plant) -> None:
    """The goniometer head must stand on the vehicle: its mount inside (or on) the body footprint."""
    g = sc.goniometer
    if g is None:
        return
    body = Polygon(np.asarray(plant.footprint, dtype=np.float64))
    if not body.covers(Point(g.mount[0], g.mount[1])):
        lo, hi = np.min(plant.footprint, axis=0), np.max(plant.footprint, axis=0)
        raise sc.error(
            ("goniometer", "mount"),
            f"the head at ({g.mount[0]:g}, {g.mount[1]:g}) m is outside the vehicle body "
            f"(x {lo[0]:.3g}..{hi[0]:.3g} m, y {lo[1]:.3g}..{hi[1]:.3g} m in base_link)",
        )


def _point(sc: Scenario, family: str) -> str:
    """The tracked point: C (steered wheel) or O (base_link); only steered vehicles may choose."""
    point = sc.controller.point
    if family != "steered":
        if point == "C":
            raise sc.error(("controller", "point"), "only steered vehicles guide point C; this vehicle guides O")
        return "O"
    return point or "C"


def _initial_state(sc: Scenario, path: Path, offset: float, family: str) -> NDArray[np.float64]:
    """True ``[x, y, heading, steering]`` of base_link: the tracked point displaced left of the path start."""
    start = path.start_pose
    d = int(path.direction_at(0.0))
    psi = float(start[2]) + (math.pi if d < 0 else 0.0) + math.radians(sc.start.heading_offset_deg)
    psi += float(path.yaw_offset_at(0.0)) if family == "holonomic" else 0.0
    normal = np.array([-math.sin(start[2]), math.cos(start[2])])
    p = start[:2] + sc.start.lateral_offset_m * normal
    if offset:
        p = p - offset * np.array([math.cos(psi), math.sin(psi)])
    gamma = 0.0
    if family == "steered" and sc.start.steering_deg == "feedforward":
        L = sc.vehicle.wheelbase_m  # type: ignore[union-attr]
        gamma = float(feedforward_steering(float(path.curvature_at(0.0)), L, "C" if offset else "O", d)[0])
    elif family == "steered":
        gamma = math.radians(float(sc.start.steering_deg))
    return np.array([p[0], p[1], psi, gamma])


def _follower_params(sc: Scenario, name: str, family: str, cruise: float) -> tuple[KeyPath, dict[str, object]]:
    """Keyword arguments of the follower from the controller spec, and the key to blame on error."""
    spec = sc.controller
    kwargs: dict[str, object] = dict(spec.params)
    key: KeyPath = ("controller",)
    if family == "steered":
        if name in ("seed_general", "pure_pursuit"):
            kwargs["point"] = spec.point or "C"
        elif (spec.point or "C") != "C":
            raise sc.error(("controller", "point"), f"{name} guides point C only")
        if name in ("pure_pursuit", "stanley"):
            kwargs.setdefault("v_nominal", cruise)
    if spec.poles_per_m is not None:
        kwargs["poles_per_m"] = list(spec.poles_per_m)
        key = ("controller", "poles_per_m")
    if spec.gains is not None:
        key = ("controller", "gains")
        order = ("a", "b", "c") if name == "seed_general" else ("a", "b")
        if name in ("seed_general", "seed_simple"):
            unknown = set(spec.gains) - set(order)
            missing = [k for k in order if k not in spec.gains]
            if unknown or missing:
                raise sc.error(key, f"{name} needs gains {', '.join(order)}")
            kwargs["gains"] = tuple(spec.gains[k] for k in order)
            if name == "seed_general":
                kwargs.setdefault("v_max", cruise)
        else:
            kwargs.update(spec.gains)
    return key, kwargs


def _follower(sc: Scenario, path: Path, family: str, geometry: object) -> PathFollower:
    name = sc.controller.name or DEFAULT_FOLLOWERS[family]
    if name not in FOLLOWERS[family]:
        raise sc.error(
            ("controller", "name"),
            f"{name} does not fit a {sc.vehicle.model} vehicle ({family}); choose from: {', '.join(FOLLOWERS[family])}",
        )
    key, kwargs = _follower_params(sc, name, family, sc.traction.speed_m_s)
    known = {p.name for p in follower_parameters(name, family)}
    unknown = [k for k in sc.controller.params if k not in known]
    if unknown:  # blame the misspelt or foreign key's own line; make_follower's error names the valid ones
        key = ("controller", "params", unknown[0])
    return guard(sc, key, make_follower, name, family, path, geometry, **kwargs)


def surveyed_truth(world: WorldMap, survey_std: float, seed: int) -> WorldMap:
    """The world as it really is: reflectors moved from their surveyed map positions.

    Each reflector is displaced by an independent Gaussian error of ``survey_std`` (m)
    per axis, drawn from a generator of its own derived from the scenario ``seed``
    (so the survey error does not shift any other random stream). ``survey_std = 0``
    returns ``world`` itself.
    """
    if survey_std <= 0.0:
        return world
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(0x5EED,)))
    moved = [
        dataclasses.replace(r, x=r.x + dx, y=r.y + dy)
        for r, (dx, dy) in zip(world.reflectors, rng.normal(0.0, survey_std, (len(world.reflectors), 2)), strict=True)
    ]
    return dataclasses.replace(world, reflectors=tuple(moved))


def _goniometer(sc: Scenario) -> Goniometer:
    g = sc.goniometer
    assert g is not None
    return guard(
        sc,
        ("goniometer",),
        Goniometer,
        rate_hz=g.rate_hz,
        pulses_per_rev=g.pulses_per_rev,
        mount=(g.mount[0], g.mount[1], math.radians(g.mount[2])),
        min_range=g.min_range_m,
        max_range=g.max_range_m,
        p_miss=g.p_miss,
        spurious_rate=g.spurious_rate_hz / g.rate_hz,
        jitter_std=g.jitter_std_s,
    )


def ultrasonic_array(sc: Scenario) -> UltrasonicArray:
    """The rangers of ``sc.ultrasonic`` on the vehicle's body (the seed-004 layout unless sensors are listed)."""
    us, veh = sc.ultrasonic, sc.vehicle
    if us is None:
        raise sc.error(("ultrasonic",), "no ultrasonic rangers are mounted")
    base = UltrasonicSensor(
        half_angle=math.radians(us.half_angle_deg), max_incidence=math.radians(us.max_incidence_deg),
        min_range=us.min_range_m, max_range=us.max_range_m, noise_std=us.noise_std_m, p_miss=us.p_miss,
        rate_hz=us.rate_hz,
    )
    if us.sensors is None:
        return guard(sc, ("ultrasonic",), seed_004_layout, us.spacing_m, veh.body_length_m, veh.body_width_m, base)
    q = 0.25 / us.rate_hz
    sensors = {
        s.name: dataclasses.replace(base, mount=(s.mount[0], s.mount[1], math.radians(s.mount[2])), phase=(i % 4) * q)
        for i, s in enumerate(us.sensors)
    }
    return guard(sc, ("ultrasonic", "sensors"), UltrasonicArray, sensors, veh.body_length_m, veh.body_width_m)


def wall_ids(world: WorldMap) -> list[str]:
    """One name per wall segment of ``world`` (``id``, or ``id[i]`` for polylines), in ``wall_segments`` order."""
    ids: list[str] = []
    for w in world.walls:
        n = w.segments.shape[0]
        ids += [w.id] if n == 1 else [f"{w.id}[{i}]" for i in range(n)]
    return ids


def odometry_noise(sc: Scenario) -> OdometryNoise:
    """The estimator's odometry model: ``positioning.odometry_noise``, or its ``wheel_odometry``.

    ``wheel_odometry`` (steered vehicles; the scenario validates it) gives the exact wheel model
    :class:`~agvnav.odometry.SteeredOdometryNoise`, one steering draw per control step of
    ``traction.speed_m_s x step_s`` metres, with the vehicle's steering limit
    ``vehicle.steering.max_angle_deg``.
    """
    ps = sc.positioning
    wo = ps.wheel_odometry
    if wo is None:
        return OdometryNoise(*ps.odometry_noise)
    return steered_noise(
        sc.vehicle.model, wo.slip_std**2, float(sc.vehicle.wheelbase_m),  # type: ignore[union-attr]
        math.radians(wo.steering_noise_std_deg), sc.traction.speed_m_s * sc.step_s, wo.wheel_radius_std,
        math.radians(wo.steering_offset_std_deg), math.radians(sc.vehicle.steering.max_angle_deg),  # type: ignore[union-attr]
    )


def _estimator(
    sc: Scenario, world: WorldMap, x0: NDArray[np.float64], rangers: UltrasonicArray | None
) -> PositioningEstimator:
    """The estimator by method (null: ekf with a goniometer, wall_landmarks with rangers only, else dead reckoning)."""
    ps = sc.positioning
    err = np.array([ps.initial_error[0], ps.initial_error[1], math.radians(ps.initial_error[2])])
    std = np.array([ps.initial_std[0], ps.initial_std[1], math.radians(ps.initial_std[2])])
    g = sc.goniometer
    noise, pose0, cov0 = odometry_noise(sc), x0[:3] + err, np.diag(np.maximum(std, 1e-6) ** 2)
    kwargs: dict[str, object] = {
        "odometry_noise": noise,
        "initial_pose": pose0,
        "initial_covariance": cov0,
        "strict": False,  # a running vehicle: implausible readings are dropped and counted (issue 12)
    }
    mount: tuple[float, float, float] = (0.0, 0.0, 0.0)
    if g is not None:
        mount = (g.mount[0], g.mount[1], math.radians(g.mount[2]))
        kwargs.update(pulses_per_rev=g.pulses_per_rev, rate_hz=g.rate_hz, max_range=g.max_range_m)
    if sc.world_truth.reflector_survey_std_m > 0.0:
        kwargs["map_std"] = sc.world_truth.reflector_survey_std_m
    kwargs.update(ps.params)
    method = ps.method or ("ekf" if g is not None else "wall_landmarks" if rangers is not None else "dead_reckoning")
    if g is None and method in ("naive", "angle_propagation", "batch_ml", "ekf"):
        raise sc.error(("positioning", "method"), f"{method} positions with the goniometer: mount one")
    if method in ("wall_landmarks", "dead_reckoning"):
        if method == "wall_landmarks" and rangers is None:
            raise sc.error(("positioning", "method"), "wall_landmarks positions with ultrasonic rangers: mount them")
        walls = world.wall_segments if method == "wall_landmarks" else ()
        return guard(
            sc, ("positioning",), WallLandmarkLocalizer, walls, rangers if method == "wall_landmarks" else None,
            pose=pose0, wall_ids=wall_ids(world) if method == "wall_landmarks" else None,
            odometry_noise=noise, initial_covariance=cov0,
        )
    if rangers is not None and method == "ekf":  # fuse the rangers' wall ranges too
        kwargs.update(walls=world.wall_segments, rangers=rangers)
    return guard(sc, ("positioning",), make_estimator, method, world, mount, **kwargs)


def _watch(sc: Scenario) -> EstimatorWatch:
    """The positioning guard (issue 12): active with the scenario's limits when a goniometer positions the vehicle.

    A vehicle without an absolute sensor is built to dead-reckon: its guard only records.
    """
    s = sc.safety
    limits = guard(
        sc, ("safety",), GuardLimits, s.lateral_3sigma_slow_m, s.lateral_3sigma_stop_m, s.slow_speed_fraction,
        s.resume_after_s,
    )
    return EstimatorWatch(PositioningGuard(limits, enabled=s.enabled and sc.goniometer is not None))


def _sensors(
    sc: Scenario, world: WorldMap, rangers: UltrasonicArray | None, estimator: PositioningEstimator,
    docked: DockingEstimate | None = None,
) -> list[Sensor]:
    """The goniometer seeing the true world (survey error, moved reflectors), with the sensor faults; the rangers.

    ``docked`` (a mission that docks at its target's node): the goniometer also sees the target on the true
    station (:func:`agvnav.sim.docking.true_world`) and feeds both of its estimators.

    Each feeds ``estimator`` when it takes that kind of measurement (bearings: a streaming estimator;
    ranges: the EKF with rangers or the wall-landmark localizer); otherwise the sensor is only observed
    and recorded (the rangers still serve the reaction to obstacles), as when a run dead-reckons on
    purpose with a goniometer mounted.
    """
    ranges: RangeEstimator | None = None  # a dead-reckoning localizer (no rangers) takes no ranges
    if isinstance(estimator, EkfEstimator) or (
        isinstance(estimator, WallLandmarkLocalizer) and estimator.rangers is not None
    ):
        ranges = estimator
    out: list[Sensor] = [] if rangers is None else [UltrasonicSensorRole(rangers, world.wall_segments, ranges)]
    if sc.goniometer is None:
        if any(f.kind not in PLANT_FAULTS for f in sc.faults):
            raise sc.error(("faults",), "goniometer and reflector faults need a goniometer: mount one")
        return out
    for i, f in enumerate(sc.faults):
        if f.reflector is not None and f.reflector not in world.reflector_ids:
            raise sc.error(("faults", i, "reflector"), f"no reflector {f.reflector!r} in the map")
    true_world = world_with_faults(surveyed_truth(world, sc.world_truth.reflector_survey_std_m, sc.seed), sc.faults)
    bearings = estimator if isinstance(estimator, StreamingEstimator) else None
    gonio = GoniometerSensor(_goniometer(sc), true_world, bearings)
    sensor: Sensor = gonio
    if docked is not None:
        target = docked.station.target
        sensor = docking.goniometer_role(sc, target, _goniometer(sc), docking.true_world(sc, true_world, target),
                                         docked)
        if not isinstance(sensor, GoniometerSensor):  # a person walking past: the sensor faults do not wrap it
            return [sensor, *out]
        gonio = sensor
    if any(f.kind not in PLANT_FAULTS for f in sc.faults):
        sensor = FaultySensor(gonio, sc.faults, world, sc.goniometer.rate_hz, sc.seed)
    return [sensor, *out]


def _loop_plant(sc: Scenario, plant: Plant, world: WorldMap) -> Plant:
    """The plant the loop drives: odometry faults applied, collisions with the walls ending the run."""
    if any(f.kind in PLANT_FAULTS for f in sc.faults):
        plant = FaultyPlant(plant, sc.faults)
    return CollisionWatch(plant, WallCollider(plant.footprint, world.wall_segments))


def _default_duration(sc: Scenario, path: Path) -> float:
    """Time to drive the path at cruise speed with the ramps, plus margin and the end hold."""
    tc = sc.traction
    v = tc.speed_m_s
    ramps = v / tc.max_accel_m_s2 + v / tc.max_decel_m_s2
    return 1.5 * (path.length / v + ramps) + 5.0 + sc.end_hold_s


def build(sc: Scenario, mission: MissionPlan | None = None) -> Built:
    """Wire every part of scenario ``sc`` (any vehicle following a path) into a ClosedLoop.

    A scenario with the seed-004 ``route`` runs laps instead (:func:`agvnav.sim.laps.simulate_tracked`).
    ``mission``: a mission planned elsewhere for the scenario's mission vehicle (a fleet's traffic plan,
    :mod:`agvnav.sim.traffic`), driven instead of the scenario's own jobs.
    """
    if sc.route is not None:
        raise sc.error(("route",), "a route scenario runs laps (agvnav.sim.simulate), it has no single path loop")
    if sc.docking is not None and sc.mission is None:  # issue 32: dock relative to the station's target
        return build_docking(sc)
    world = build_world(sc)
    if mission is not None and sc.mission is None:
        raise ValueError("a planned mission needs a mission scenario (its network and start)")
    if sc.mission is not None:
        # imported only for a mission scenario: routes pull in networkx and scipy.interpolate, about
        # half of agvnav.sim's import time, which path scenarios never use
        from agvnav.sim import mission as missions  # noqa: PLC0415 - start-up time of path scenarios

        if mission is None:
            mission = missions.plan_mission(sc)
    path = build_path(sc) if mission is None else mission.path
    family = sc.vehicle.family
    point = _point(sc, family)
    wheelbase = float(getattr(sc.vehicle, "wheelbase_m", 0.0))
    offset = wheelbase if point == "C" else 0.0
    _check_start(sc, max(wheelbase, sc.vehicle.body_length_m))
    x0 = _initial_state(sc, path, offset, family)
    plant = guard(sc, ("vehicle",), build_plant, sc.vehicle, x0.tolist())
    _check_mount(sc, plant)
    _check_feasible(sc, path, family, plant.geometry, point)
    _check_visibility(sc, world, path, offset)
    follower = _follower(sc, path, family, plant.geometry)
    tc = sc.traction
    profile = guard(
        sc, ("traction",), SpeedProfile, cruise_speed=tc.speed_m_s, max_accel=tc.max_accel_m_s2,
        max_decel=tc.max_decel_m_s2,
    )
    rangers = ultrasonic_array(sc) if sc.ultrasonic is not None else None
    estimator = _estimator(sc, world, x0, rangers)
    pilot: PathAutopilot | MissionAutopilot = PathAutopilot(follower, path, profile, plant, offset, watch=_watch(sc))
    if mission is not None:  # one PathAutopilot per leg (issue 14)
        pilot = missions.mission_autopilot(sc, mission, follower, plant, offset, _watch(sc))
    # a mission that docks at the target's node (VDA 5050 finePositioning): the loop feeds both estimators
    docked = _mission_docking(sc, estimator) if sc.docking is not None else None
    sensors = _sensors(sc, world, rangers, estimator, docked)
    loop_plant = _loop_plant(sc, plant, world)
    if sc.obstacles or sc.scanner is not None or sc.reactive is not None:  # issue 18: obstacles, scanner, reaction
        loop_plant, sensors, pilot = wire_reactive(sc, world, loop_plant, sensors, pilot)
    loop = ClosedLoop(loop_plant, sensors, estimator if docked is None else docked, pilot, sc.step_s, sc.seed)
    duration = sc.duration_s if sc.duration_s is not None else _default_duration(sc, path)
    if mission is not None and sc.duration_s is None:
        duration = missions.mission_duration(sc, mission)
    return Built(loop, world, path, plant, pilot, estimator, duration, point, offset, mission, docked)


def _mission_docking(sc: Scenario, estimator: PositioningEstimator) -> DockingEstimate:
    """The estimates of a mission that docks at its target's node: the global one and an idle station one."""
    _docking_point(sc, sc.vehicle.family)
    target = docking.load_target(sc)
    return DockingEstimate(_docking_global(sc, estimator), station_estimator(sc, target))


def build_docking(sc: Scenario) -> Built:
    """Wire a docking scenario (module doc); every problem a ScenarioError naming file, line and key."""
    assert sc.docking is not None and sc.goniometer is not None
    world = build_world(sc)
    target = docking.load_target(sc)
    path = docking.approach_path(target)
    family = sc.vehicle.family
    point = _docking_point(sc, family)
    x0 = _initial_state(sc, path, 0.0, family)
    plant = guard(sc, ("vehicle",), build_plant, sc.vehicle, x0.tolist())
    _check_mount(sc, plant)
    estimator = _docking_global(sc, _estimator(sc, world, x0, None))
    estimate = DockingEstimate(estimator, station_estimator(sc, target))
    pilot = docking_autopilot(sc, target, plant, estimate)
    truth = surveyed_truth(world, sc.world_truth.reflector_survey_std_m, sc.seed)
    sensors = [docking.goniometer_role(sc, target, _goniometer(sc), docking.true_world(sc, truth, target), estimate)]
    loop = ClosedLoop(_loop_plant(sc, plant, world), sensors, estimate, pilot, sc.step_s, sc.seed)
    dk = sc.docking
    duration = sc.duration_s if sc.duration_s is not None else 2.0 * target.approach / dk.speed_m_s + 60.0
    return Built(loop, world, path, plant, pilot, estimator, duration, point, 0.0)


def _docking_point(sc: Scenario, family: str) -> str:
    point = _point(sc, family)
    if point != "O":
        raise sc.error(("controller", "point"), "docking guides point O (base_link): set controller.point: O")
    return point


def _docking_global(sc: Scenario, estimator: PositioningEstimator) -> StreamingEstimator:
    if not isinstance(estimator, StreamingEstimator):
        raise sc.error(("positioning", "method"), "docking positions globally with the goniometer: give ekf")
    return estimator


def station_estimator(sc: Scenario, target: DockingTarget) -> StationEstimator:
    """A fresh (idle) station estimator of ``target`` for the scenario's goniometer and odometry (issue 32)."""
    g = sc.goniometer
    if g is None:
        raise sc.error(("docking",), "docking recognises its target with the goniometer: mount one")
    mount = (g.mount[0], g.mount[1], math.radians(g.mount[2]))
    return StationEstimator(target, mount, g.pulses_per_rev, 1.0 / g.rate_hz,
                            docking.station_noise(sc, odometry_noise(sc)))


def docking_autopilot(sc: Scenario, target: DockingTarget, plant: VehiclePlant,
                      estimate: DockingEstimate) -> DockingAutopilot:
    """The docking autopilot of ``sc.docking`` at ``target`` (issue 32): the straight approach drawn relative to
    the map's station, the fine positioning of a vehicle that turns on the spot, the tolerances; guided on
    ``estimate``'s station estimator (give it a fresh one, :func:`station_estimator`, for every docking)."""
    dk, g = sc.docking, sc.goniometer
    assert dk is not None and g is not None
    path = docking.approach_path(target)
    family = sc.vehicle.family
    follower = _follower(sc, path, family, plant.geometry)
    profile = guard(sc, ("docking", "speed_m_s"), SpeedProfile, cruise_speed=dk.speed_m_s,
                    max_accel=sc.traction.max_accel_m_s2, max_decel=sc.traction.max_decel_m_s2)
    approach = PathAutopilot(follower, path, profile, plant, 0.0, end_tolerance=target.max_offset[0] + 0.05,
                             watch=_watch(sc))
    fine = None
    if family != "steered":
        turn = math.radians(sc.mission.turn_rate_deg_s) if sc.mission is not None else math.radians(30.0)
        fine = guard(sc, ("docking",), fine_positioner, plant, "X", 1.0 / g.rate_hz, sc.traction.max_accel_m_s2,
                     turn)
        fine.tolerance = 0.5 * dk.tolerance_mm * 1e-3
        fine.heading_tolerance = 0.5 * math.radians(dk.heading_tolerance_deg)
        fine.speed = 0.5 * fine.tolerance * g.rate_hz
    tol = DockingTolerances(dk.tolerance_mm * 1e-3, math.radians(dk.heading_tolerance_deg))
    return DockingAutopilot(target, approach, estimate, tol, fine, relative=dk.guide_on == "station")
