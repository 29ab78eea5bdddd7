"""From a validated :class:`~agvnav.world.scenario.Scenario` to a running closed loop.

Building is where the cross-part checks happen (the schema alone cannot see
them): the map must load, the path must have no gap, the controller gains must
be stable (Routh-Hurwitz, seed 000 eqs 18-19), and at least three reflectors must
be in view (in range and line of sight) all along the path. Every failure is a
:class:`~agvnav.world.scenario.ScenarioError` naming the key and its line.
"""

from __future__ import annotations

import dataclasses

import math
from dataclasses import dataclass
from pathlib import Path as FsPath
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.world.scenario import KeyPath, PathSpec, Scenario, ScenarioError
from agvnav.world.tracked_scenario import TrackedScenario

__all__ = ["Built", "build", "build_path", "build_world", "reflectors_in_view"]


@dataclass
class Built:
    """The wired parts of one run."""

    loop: Any
    world: Any
    path: Any
    plant: Any
    autopilot: Any
    estimator: Any
    duration: float
    point: str


def _guard(sc: Scenario | TrackedScenario, key: KeyPath, func: Any, *args: Any, **kwargs: Any) -> Any:
    """Call ``func``; a ValueError becomes a ScenarioError at ``key``."""
    try:
        return func(*args, **kwargs)
    except ScenarioError:
        raise
    except ValueError as exc:
        raise sc.error(key, " ".join(str(exc).split())) from None


def build_world(sc: Scenario | TrackedScenario) -> Any:
    """The map: a shipped name (``lab``), a file path (relative to the scenario), or inline.

    Either scenario kind (the tracked robot's map key has the same forms).
    """
    from agvnav.world import builtin_map_names, load_builtin_map, load_map
    from agvnav.world.map import WorldMap

    spec = sc.map
    if isinstance(spec, dict):
        return _guard(sc, ("map",), WorldMap.from_dict, spec)
    if spec in builtin_map_names():
        return load_builtin_map(spec)
    p = FsPath(spec)
    if not p.is_absolute() and sc.base_dir is not None:
        p = sc.base_dir / p
    if not p.is_file():
        raise sc.error(("map",), f"{spec!r} is neither a shipped map ({', '.join(builtin_map_names())}) nor a file")
    return _guard(sc, ("map",), load_map, p)


def build_path(sc: Scenario) -> Any:
    """The planned path of the tracked point from the chained segment specs; gaps are errors."""
    from agvnav.guidance.paths import ArcSegment, LineSegment, Path

    spec: PathSpec = sc.path
    pos = np.array(spec.start[:2], dtype=np.float64)
    heading = math.radians(spec.start[2])
    segs = []
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
        if seg.type == "line":
            obj = _guard(sc, key, LineSegment, pos.copy(), heading, seg.length_m, d)
        else:
            obj = _guard(sc, key, ArcSegment, pos.copy(), heading, seg.radius_m, math.radians(seg.sweep_deg), d)
        segs.append(obj)
        pos, heading = np.asarray(obj.end, dtype=np.float64), float(obj.end_heading)
    return _guard(sc, ("path",), Path, segs)


def reflectors_in_view(
    world: Any, head_xy: NDArray[np.float64], min_range: float, max_range: float
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
            return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

        d1 = cross(pr, a[None, None] - p4)
        d2 = cross(pr, b[None, None] - p4)
        d3 = cross(ab, p4 - a[None, None])
        d4 = cross(ab, p4 + pr - a[None, None])
        blocked = np.any((d1 * d2 < 0) & (d3 * d4 < 0), axis=-1)  # (k, N)
        ok &= ~blocked
    return ok.sum(axis=1)


def _check_visibility(sc: Scenario, world: Any, path: Any, point: str, L: float) -> None:
    """At least ``min_reflectors_in_view`` reflectors visible from the head all along the path."""
    n = max(2, int(math.ceil(path.length / 0.1)) + 1)
    s = np.linspace(0.0, path.length, n)
    pts = path.point_at(s)
    heading = path.heading_at(s) + np.where(path.direction_at(s) < 0, math.pi, 0.0)
    g = sc.goniometer
    # Pose of O: for a path of C, O is L behind C (exact on lines, close on arcs).
    if point == "C":
        pts = pts - L * np.column_stack([np.cos(heading), np.sin(heading)])
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


def _check_radii(sc: Scenario, point: str, L: float) -> None:
    """Point C cannot follow an arc tighter than the wheelbase (R_C = L / |sin gamma| >= L, seed 000 eq. 8)."""
    if point != "C":
        return
    for i, seg in enumerate(sc.path.segments):
        if seg.type == "arc" and seg.radius_m < L:
            raise sc.error(
                ("path", "segments", i, "radius_m"),
                f"radius {seg.radius_m:g} m is below the wheelbase {L:g} m: the drive wheel C cannot follow it",
            )


def _check_start(sc: Scenario, L: float) -> None:
    """Refuse a start farther from the path than ``max(2 m, 2 wheelbases)``.

    Guidance (seed 000 §3) corrects small initial errors (110 mm in §4.3); from
    farther away the projection on the path is meaningless and progress along
    it cannot be tracked.
    """
    limit = max(2.0, 2.0 * L)
    off = sc.start.lateral_offset_m
    if abs(off) > limit:
        raise sc.error(
            ("start", "lateral_offset_m"),
            f"start {off:g} m off the path is too far: at most {limit:g} m (2 m or two wheelbases) is supported",
        )


def _initial_state(sc: Scenario, path: Any, point: str, L: float) -> NDArray[np.float64]:
    """True ``[x_O, y_O, psi, gamma]``: the tracked point displaced left of the path start."""
    start = path.start_pose
    d = int(path.direction_at(0.0))
    psi = float(start[2]) + (math.pi if d < 0 else 0.0) + math.radians(sc.start.heading_offset_deg)
    normal = np.array([-math.sin(start[2]), math.cos(start[2])])
    p = start[:2] + sc.start.lateral_offset_m * normal
    if point == "C":
        p = p - L * np.array([math.cos(psi), math.sin(psi)])
    if sc.start.steering_deg == "feedforward":
        from agvnav.guidance.errors import feedforward_steering

        gamma, _ = feedforward_steering(float(path.curvature_at(0.0)), L, point, d)
        gamma = float(gamma)
    else:
        gamma = math.radians(sc.start.steering_deg)
    return np.array([p[0], p[1], psi, gamma])


def _controller(sc: Scenario, path: Any, L: float, cruise: float) -> Any:
    """The guidance law by name; poles per metre or fixed gains (Routh-Hurwitz checked by guidance)."""
    from agvnav.guidance import make_controller

    spec = sc.controller
    kwargs: dict[str, Any] = dict(spec.params)
    key: KeyPath = ("controller",)
    if spec.name in ("seed_general", "pure_pursuit"):
        kwargs["point"] = spec.point
    elif spec.point != "C":
        raise sc.error(("controller", "point"), f"{spec.name} guides point C only")
    if spec.name in ("pure_pursuit", "stanley"):
        kwargs.setdefault("v_nominal", cruise)
    if spec.poles_per_m is not None:
        kwargs["poles_per_m"] = list(spec.poles_per_m)
        key = ("controller", "poles_per_m")
    if spec.gains is not None:
        key = ("controller", "gains")
        order = ("a", "b", "c") if spec.name == "seed_general" else ("a", "b")
        if spec.name in ("seed_general", "seed_simple"):
            unknown = set(spec.gains) - set(order)
            missing = [k for k in order if k not in spec.gains]
            if unknown or missing:
                raise sc.error(key, f"{spec.name} needs gains {', '.join(order)}")
            kwargs["gains"] = tuple(spec.gains[k] for k in order)
            if spec.name == "seed_general":
                kwargs.setdefault("v_max", cruise)
        else:
            kwargs.update(spec.gains)
    return _guard(sc, key, make_controller, spec.name, path, L, **kwargs)


def build(sc: Scenario) -> Built:
    """Wire every part of scenario ``sc`` into a :class:`~agvnav.sim.engine.ClosedLoop`."""
    from agvnav.actuators import SpeedProfile, SteeringActuator
    from agvnav.sensors.goniometer import Goniometer
    from agvnav.sim.engine import ClosedLoop
    from agvnav.odometry import NonSystematicErrors, TricycleErrors
    from agvnav.sim.tricycle import GoniometerSensor, TricycleAutopilot, TricyclePlant

    if hasattr(sc, "route"):  # issue 6: the tracked robot is checked and wired by sim.tracked_build
        from agvnav.sim.tracked_build import prepare_tracked

        return prepare_tracked(sc)  # type: ignore[arg-type,return-value]
    world = build_world(sc)
    path = build_path(sc)
    veh = sc.vehicle
    L = veh.wheelbase_m
    point = sc.controller.point
    _check_radii(sc, point, L)
    _check_start(sc, L)
    _check_visibility(sc, world, path, point, L)
    g = sc.goniometer
    mount = (g.mount[0], g.mount[1], math.radians(g.mount[2]))
    gonio = _guard(
        sc,
        ("goniometer",),
        Goniometer,
        rate_hz=g.rate_hz,
        pulses_per_rev=g.pulses_per_rev,
        mount=mount,
        min_range=g.min_range_m,
        max_range=g.max_range_m,
        p_miss=g.p_miss,
        spurious_rate=g.spurious_rate_hz / g.rate_hz,
        jitter_std=g.jitter_std_s,
    )
    st = sc.steering
    steering = _guard(
        sc,
        ("steering",),
        SteeringActuator,
        max_angle=math.radians(st.max_angle_deg) - (1e-9 if st.max_angle_deg >= 90.0 else 0.0),
        max_rate=math.radians(st.max_rate_deg_s),
        tau=st.time_constant_s,
    )
    tr = sc.truth
    # the scenario's truth: keys in the odometry package's truth-vs-nominal error model
    systematic = _guard(
        sc,
        ("truth",),
        TricycleErrors,
        radius_scale=1.0 + tr.wheel_radius_error,
        wheelbase_scale=1.0 + tr.wheelbase_error,
        steering_offset=math.radians(tr.steering_offset_deg),
    )
    nonsystematic = _guard(
        sc,
        ("truth",),
        NonSystematicErrors,
        slip_k=tr.slip_std**2,
        steering_std=math.radians(tr.steering_noise_std_deg),
    )
    x0 = _initial_state(sc, path, point, L)
    plant = _guard(
        sc,
        ("vehicle",),
        TricyclePlant,
        L,
        veh.drive_wheel_radius_m,
        veh.traction_counts_per_rev,
        veh.steering_counts_per_rev,
        steering,
        systematic,
        nonsystematic,
        x0,
    )
    ctrl = _controller(sc, path, L, sc.traction.speed_m_s)
    tc = sc.traction
    profile = _guard(
        sc, ("traction",), SpeedProfile, cruise_speed=tc.speed_m_s, max_accel=tc.max_accel_m_s2, max_decel=tc.max_decel_m_s2
    )
    pilot = TricycleAutopilot(ctrl, path, profile, L, point)
    estimator = _estimator(sc, world, mount, x0)
    true_world = surveyed_truth(world, tr.reflector_survey_std_m, sc.seed)
    loop = ClosedLoop(plant, [GoniometerSensor(gonio, true_world)], estimator, pilot, sc.step_s, sc.seed)
    duration = sc.duration_s if sc.duration_s is not None else _default_duration(sc, path)
    return Built(loop, world, path, plant, pilot, estimator, duration, point)


def surveyed_truth(world: Any, survey_std: float, seed: int) -> Any:
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


def _estimator(sc: Scenario, world: Any, mount: tuple[float, float, float], x0: NDArray[np.float64]) -> Any:
    from agvnav.positioning.estimator import make_estimator

    from agvnav.odometry import OdometryNoise

    ps = sc.positioning
    err = np.array([ps.initial_error[0], ps.initial_error[1], math.radians(ps.initial_error[2])])
    std = np.array([ps.initial_std[0], ps.initial_std[1], math.radians(ps.initial_std[2])])
    g = sc.goniometer
    kwargs: dict[str, Any] = {
        "pulses_per_rev": g.pulses_per_rev,
        "rate_hz": g.rate_hz,
        "max_range": g.max_range_m,
        "odometry_noise": OdometryNoise(*ps.odometry_noise),
        "initial_pose": x0[:3] + err,
        "initial_covariance": np.diag(np.maximum(std, 1e-6) ** 2),
    }
    if sc.truth.reflector_survey_std_m > 0.0:
        kwargs["map_std"] = sc.truth.reflector_survey_std_m
    kwargs.update(ps.params)
    return _guard(sc, ("positioning",), make_estimator, ps.method, world, mount, **kwargs)


def _default_duration(sc: Scenario, path: Any) -> float:
    """Time to drive the path at cruise speed with the ramps, plus margin and the end hold."""
    tc = sc.traction
    v = tc.speed_m_s
    ramps = v / tc.max_accel_m_s2 + v / tc.max_decel_m_s2
    return 1.5 * (path.length / v + ramps) + 5.0 + sc.end_hold_s
