"""Missions in the closed loop: plan a scenario's mission, wire its autopilot, judge it on the truth.

:func:`plan_mission` loads the scenario's route network, plans every job
(:mod:`agvnav.routes.mission`) and chains the legs into the one path the run
is judged against. :func:`mission_autopilot` wires the vehicle's
:class:`~agvnav.navigation.mission.MissionAutopilot` (one
:class:`~agvnav.navigation.path.PathAutopilot` per stint, fine positioning at the
stations of a spot-turning vehicle, :mod:`agvnav.navigation.fine_positioning`) from the
scenario's keys; errors name the key and its line.

Results (:func:`mission_figures`) come from the true pose: the stop errors of
the point guided into each station, once the vehicle is at rest, and the lateral
error of the guided point against the run it drove (:func:`route_tracking`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import wrap_angle, wrap_angle_scalar
from agvnav.guidance import GuidanceError, HeadingHoldApproach, make_follower
from agvnav.guidance.errors import errors_from_projection
from agvnav.guidance.follower import PathFollower
from agvnav.guidance.paths import Path
from agvnav.navigation.fine_positioning import fine_positioner, spot_turn_lever, twist_command
from agvnav.navigation.guard import SpeedWatch
from agvnav.navigation.mission import LimitedSpeedProfile, MissionAutopilot, SpotTurn, StationStop, run_bounds
from agvnav.navigation.path import PathAutopilot
from agvnav.roles import Plant
from agvnav.routes.mission import Job, MissionError, MissionPlan, chain_mission, plan_legs
from agvnav.routes.network import EDGE_KINDS, RouteNetwork, load_network, network_reference
from agvnav.routes.planning import Planner, VehicleLimits
from agvnav.vehicles import SteeredGeometry
from agvnav.world.scenario import GoniometerSpec, Scenario, ScenarioError
from agvnav.world.vehicle_specs import MecanumSpec

__all__ = [
    "MOVING_SPEED_M_S",
    "guided_errors",
    "load_mission_network",
    "mission_autopilot",
    "mission_duration",
    "mission_figures",
    "moving_mask",
    "near_line_curve_joints",
    "plan_mission",
    "route_tracking",
    "spot_turn",
    "tracked_point",
]

def load_mission_network(sc: Scenario) -> RouteNetwork:
    """The route network of mission scenario ``sc``: a shipped name, else a file relative to the scenario
    (never the current folder: :func:`agvnav.routes.network.network_reference`)."""
    m = sc.mission
    assert m is not None
    try:
        path = network_reference(m.network, sc.base_dir)
    except ScenarioError as exc:
        raise sc.error(("mission", "network"), f"{m.network!r}: {exc.detail}") from None
    return load_network(path)


def plan_mission(sc: Scenario) -> MissionPlan:
    """Plan the scenario's mission into one chained path; errors name the mission key and line."""
    m = sc.mission
    assert m is not None
    net = load_mission_network(sc)
    if m.start not in net.nodes:
        raise sc.error(("mission", "start"), f"unknown station {m.start!r} in network {net.name!r}")
    if not m.jobs:
        raise sc.error(("mission", "jobs"), "the mission has no jobs: give at least one")
    limits = VehicleLimits(sc.vehicle.model, sc.traction.speed_m_s, m.lateral_accel_m_s2,
                           math.radians(m.turn_rate_deg_s))
    try:
        planner = Planner(net, limits, tuple(m.blocked_edges))
    except ValueError as exc:
        raise sc.error(("mission", "blocked_edges"), str(exc)) from None
    jobs = [Job(j.action, j.station, j.duration_s) for j in m.jobs]
    try:
        legs = plan_legs(planner, m.start, jobs)
        start = net.nodes[m.start]
        return chain_mission(legs, np.array([start.x, start.y]), math.radians(net.spec.tolerances.heading_deg))
    except MissionError as exc:
        key = ("mission", "jobs", exc.job, "station") if exc.job >= 0 else ("mission", "start")
        raise sc.error(key, str(exc)) from None


def mission_duration(sc: Scenario, plan: MissionPlan) -> float:
    """A time limit for the mission (s): the planned drive time as if driven all along at the positioning
    guard's slow speed, the stops, and 20 s per leg and at the end."""
    drive = sum(leg.route.time_s for leg in plan.legs if leg.route is not None)
    dwell = sum(leg.dwell_s for leg in plan.legs)
    return drive / sc.safety.slow_speed_fraction + dwell + 20.0 * len(plan.legs) + 20.0 + sc.end_hold_s


def tracked_point(series: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    """The true guided point (n, 2) (m): ``point_offset`` ahead of base_link when the mission recorded it
    (the guided point switches between C and O), else the run's ``x_tracked``/``y_tracked``."""
    if "point_offset" in series:
        off = series["point_offset"]
        return np.column_stack([series["x"] + off * np.cos(series["psi"]), series["y"] + off * np.sin(series["psi"])])
    return np.column_stack([series["x_tracked"], series["y_tracked"]])


def route_tracking(
    series: dict[str, NDArray[np.float64]], plan: MissionPlan
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(s, lateral)``: the true guided point projected onto the run the vehicle was driving (m, m).

    Each sample is projected only onto the run (:func:`run_bounds`) holding the autopilot's own
    progress ``s_est``, within 1 m of it: after a cusp a reverse run often retraces the forward
    one (the dock spur leaves the lane it was approached on), where a projection onto the whole
    path would jump back onto the forward run and report the heading error times the wheelbase
    as a lateral error. ``lateral`` is the guided point's (left of the tangent positive).
    """
    proj = _route_projection(series, plan)
    return proj["s"], proj["lateral"]


def _route_projection(series: dict[str, NDArray[np.float64]], plan: MissionPlan) -> dict[str, NDArray[np.float64]]:
    """The projection of :func:`route_tracking`: ``s``, ``lateral`` (m), ``heading`` (rad), ``curvature`` (1/m),
    ``direction`` (+1/-1) of the mission path at the true guided point's projection onto its run."""
    pts = tracked_point(series)
    hint = np.nan_to_num(series["s_est"], nan=0.0)
    bounds = run_bounds(plan)
    run = np.clip(np.searchsorted(bounds, hint, side="right") - 1, 0, len(bounds) - 2)
    out = {name: np.zeros(len(hint)) for name in ("s", "lateral", "heading", "curvature", "direction")}
    starts = plan.path.segment_starts
    for r in np.unique(run):
        a, b = float(bounds[r]), float(bounds[r + 1])
        i0 = int(np.searchsorted(starts, a + 1e-9, side="right") - 1)
        i1 = int(np.searchsorted(starts, b - 1e-9, side="left"))
        sub = Path(list(plan.path.segments[i0:i1]))
        sel = run == r
        local_hint = np.clip(hint[sel] - a, 0.0, sub.length)
        pr = sub.project(pts[sel], s_hint=local_hint, window=1.0)
        out["s"][sel] = a + np.asarray(pr.s)
        out["lateral"][sel] = np.asarray(pr.lateral)
        out["heading"][sel] = np.asarray(pr.heading)
        out["curvature"][sel] = np.asarray(pr.curvature)
        out["direction"][sel] = np.asarray(pr.direction)
    return out


#: A sample counts as moving when the autopilot commands more than this speed (m/s).
MOVING_SPEED_M_S = 1e-6


def moving_mask(series: dict[str, NDArray[np.float64]]) -> NDArray[np.bool_]:
    """True where the vehicle is commanded to move (``|v_cmd|`` above :data:`MOVING_SPEED_M_S`).

    A mission's guidance figures count these samples: at a station the next stint's guided point is
    recorded before the vehicle moves off, where it need not lie on the run it will drive.
    """
    return np.asarray(np.abs(series["v_cmd"]) > MOVING_SPEED_M_S)


def guided_errors(
    series: dict[str, NDArray[np.float64]], plan: MissionPlan, family: str, wheelbase: float = 0.0
) -> dict[str, NDArray[np.float64]]:
    """The true errors of the point guided at each instant against the run it drove (m, rad).

    With point switching the guided point is C on the cruising stints and O on the manoeuvres
    (the recorded ``point_offset``: the wheelbase or 0): the errors of each sample are those of
    its guided point against the path planned for it (:func:`route_tracking`), never of a point
    the controller was not guiding. Returns ``s_true``, ``lateral_error``, ``x_tracked``,
    ``y_tracked`` and ``heading_error``: for a steered vehicle (``family`` "steered", ``wheelbase``
    L in m) seed 000 Fig. 5's ``eps_c``, ``eps_o``, ``xi``, ``xi_r`` of the guided point relative to
    its feed-forward, ``heading_error`` being ``xi_r`` as in a path run; otherwise the body heading
    against the tangent (+ pi reversing, + the yaw offset of a holonomic vehicle).
    """
    proj = _route_projection(series, plan)
    pts = tracked_point(series)
    out = {"s_true": proj["s"], "lateral_error": proj["lateral"], "x_tracked": pts[:, 0].copy(),
           "y_tracked": pts[:, 1].copy()}
    psi = np.asarray(series["psi"], dtype=np.float64)
    if family == "steered":
        gamma = series["gamma"] if "gamma" in series else series["phi"]
        on_c = np.asarray(series.get("point_offset", np.zeros_like(psi))) > 0.0
        names = ("eps_c", "eps_o", "xi", "xi_r")
        for name in names:
            out[name] = np.zeros_like(psi)
        for point, sel in (("C", on_c), ("O", ~on_c)):
            if not np.any(sel):
                continue
            values = errors_from_projection(psi[sel], gamma[sel], proj["lateral"][sel], proj["heading"][sel],
                                            proj["curvature"][sel], proj["direction"][sel], wheelbase, point)
            for name, v in zip(names, values[:4], strict=True):
                out[name][sel] = v
        out["heading_error"] = out["xi_r"]
        return out
    yaw = np.asarray(plan.path.yaw_offset_at(proj["s"])) if family == "holonomic" else 0.0
    reverse = np.where(proj["direction"] < 0, math.pi, 0.0)
    out["heading_error"] = np.asarray(wrap_angle(psi - proj["heading"] - reverse - yaw), dtype=np.float64)
    return out


def mission_figures(
    series: dict[str, NDArray[np.float64]], plan: MissionPlan, stops: list[StationStop],
    counted: NDArray[np.bool_] | None = None,
) -> dict[str, float]:
    """Mission results from the *true* pose: stop errors per station, mission time, lateral error per edge kind.

    ``stop_error_m[i]`` is the distance of the true guided point from the planned
    station point at the moment stop ``i`` was declared; ``stop_heading_error_rad[i]``
    the true heading's difference from the planned one. Lateral errors are those of the
    true guided point against the run it was driving (:func:`route_tracking`), grouped by
    the kind of edge (line, arc, clothoid, nurbs) its projection lies on;
    ``max_lateral_m.line_curve_joints`` is the largest from 0.5 m before to 1.5 m after every
    forward joint between a line and an arc or clothoid edge. The lateral figures count the
    samples ``counted`` (default: where the vehicle is commanded to move, :func:`moving_mask`); the run's
    headline ``max_abs_lateral_error_m`` counts the same samples, so it is the largest of them.
    """
    out: dict[str, float] = {"stations": float(len(stops))}
    t = series["t"]
    pts = tracked_point(series)
    errs, herrs = [], []
    for i, st in enumerate(stops):
        k = min(int(np.searchsorted(t, st.t)), len(t) - 1)
        px, py = float(pts[k, 0]), float(pts[k, 1])
        if st.offset is not None:  # the point guided into the station (the next stint may guide the other)
            psi = float(series["psi"][k])
            px = float(series["x"][k]) + st.offset * math.cos(psi)
            py = float(series["y"][k]) + st.offset * math.sin(psi)
        e = math.hypot(px - st.x, py - st.y)
        he = abs(wrap_angle_scalar(float(series["psi"][k]) - st.heading))
        out[f"stop_error_m[{i}]"], out[f"stop_heading_error_rad[{i}]"] = e, he
        errs.append(e)
        herrs.append(he)
    out["max_stop_error_m"] = max(errs) if errs else math.nan
    out["max_stop_heading_error_rad"] = max(herrs) if herrs else math.nan
    out["mission_time_s"] = stops[-1].t if stops else math.nan
    s_route, lateral = route_tracking(series, plan)
    seg = np.clip(np.searchsorted(plan.path.segment_starts, s_route, side="right") - 1, 0,
                  len(plan.seg_kind) - 1)
    kind = plan.seg_kind[seg]
    moving = moving_mask(series) if counted is None else np.asarray(counted, dtype=bool)
    for code, name in enumerate(EDGE_KINDS):
        m = moving & (kind == code)
        lat = np.abs(lateral[m])
        out[f"max_lateral_m.{name}"] = float(lat.max()) if lat.size else math.nan
        out[f"rms_lateral_m.{name}"] = float(np.sqrt(np.mean(lat**2))) if lat.size else math.nan
    near = moving & near_line_curve_joints(plan, s_route)
    lat = np.abs(lateral[near])
    out["max_lateral_m.line_curve_joints"] = float(lat.max()) if lat.size else math.nan
    return out


def near_line_curve_joints(plan: MissionPlan, s: NDArray[np.float64], before: float = 0.5,
                            after: float = 1.5) -> NDArray[np.bool_]:
    """True where ``s`` lies from ``before`` m ahead of to ``after`` m past a joint between a line edge and an
    arc or clothoid edge driven forward (where a plain arc makes the steering jump)."""
    line, arc, clothoid = (EDGE_KINDS.index(k) for k in ("line", "arc", "clothoid"))
    starts = plan.path.segment_starts
    fwd = np.array([seg.direction > 0 for seg in plan.path.segments])
    a, b = plan.seg_kind[:-1], plan.seg_kind[1:]
    curve_a, curve_b = np.isin(a, (arc, clothoid)), np.isin(b, (arc, clothoid))
    joint = ((a == line) & curve_b | curve_a & (b == line)) & fwd[:-1] & fwd[1:]
    mask = np.zeros(s.shape, dtype=bool)
    for js in starts[1:-1][joint]:
        mask |= (s >= js - before) & (s <= js + after)
    return mask


def mission_autopilot(
    sc: Scenario, plan: MissionPlan, follower: PathFollower, plant: Plant, point_offset: float, watch: SpeedWatch
) -> MissionAutopilot:
    """The mission autopilot of scenario ``sc``: one PathAutopilot per stint sharing ``watch``.

    Without point switching every stint uses ``follower`` (the scenario's point, ``point_offset``
    m ahead of base_link); with ``mission.point_switching`` (steered vehicles) a second follower
    of the same law guides the other point. A steered vehicle (it cannot turn at standstill) holds the
    station heading over the last ``mission.creep_distance_m`` before each station instead of correcting
    the lateral error there (:class:`~agvnav.guidance.approach.HeadingHoldApproach`: a lateral correction
    within the creep would cost a heading swing of about twice the error over the creep distance, left
    at the stop). Unicycle and holonomic vehicles position finely at
    standstill after each station stop (:func:`agvnav.navigation.fine_positioning.fine_positioner`,
    ``mission.align_heading``): the
    estimate settles for up to ``goniometer.rate_hz`` based revolutions, then a correction move.
    """
    m, tc = sc.mission, sc.traction
    assert m is not None
    try:
        profile = LimitedSpeedProfile(cruise_speed=tc.speed_m_s, max_accel=tc.max_accel_m_s2,
                                      max_decel=tc.max_decel_m_s2)
    except ValueError as exc:
        raise sc.error(("traction",), str(exc)) from None
    switching = bool(getattr(m, "point_switching", False))
    followers: dict[str | None, tuple[PathFollower, float]] = {None: (follower, point_offset)}
    wheelbase = float(plant.geometry.wheelbase) if isinstance(plant.geometry, SteeredGeometry) else 0.0
    if switching:
        if plant.family != "steered":
            raise sc.error(("mission", "point_switching"), "only steered vehicles switch between points C and O")
        followers["C"] = (_twin_follower(sc, follower, plant, plan.path, "C"), wheelbase)
        followers["O"] = (_twin_follower(sc, follower, plant, plan.path, "O"), 0.0)

    def make(path: Path, prof: LimitedSpeedProfile, point: str | None,
             station: tuple[float, float] | None) -> PathAutopilot:
        f, off = followers[point]
        f.set_path(path)
        f.reset()
        if station is not None and plant.family == "steered" and m.creep_distance_m > 0.0:
            f = HeadingHoldApproach(f, station, m.creep_distance_m)  # the creep-in holds the station heading
        return PathAutopilot(f, path, prof, plant, off, watch=watch)

    align = None
    if plant.family in ("unicycle", "holonomic") and bool(getattr(m, "align_heading", True)):
        rate = (sc.goniometer or GoniometerSpec()).rate_hz  # no goniometer: nothing to settle, the seed's rate
        layout = sc.vehicle.layout if isinstance(sc.vehicle, MecanumSpec) else "X"
        try:  # spot-turn acceleration: the traction limit at the wheels over their lever
            align = fine_positioner(plant, layout, 1.0 / rate, sc.traction.max_accel_m_s2,
                                    math.radians(m.turn_rate_deg_s))
        except ValueError as exc:
            raise sc.error(("vehicle",), str(exc)) from None
    pilot = MissionAutopilot(plan, make, profile, m.lateral_accel_m_s2, m.creep_distance_m, m.creep_speed_m_s,
                             switching, wheelbase, point_offset, align)
    if plant.family in ("unicycle", "holonomic"):
        pilot.turn_on_spot(spot_turn(sc, plant))
    return pilot


def spot_turn(sc: Scenario, plant: Plant) -> SpotTurn:
    """How a spot-turning vehicle of scenario ``sc`` turns on the spot where its mission turns at a node: the body
    twist command, the mission's turn rate, and the traction limit at the wheels over their lever (rad/s^2)."""
    m = sc.mission
    assert m is not None
    layout = sc.vehicle.layout if isinstance(sc.vehicle, MecanumSpec) else "X"
    lever = spot_turn_lever(plant.geometry, layout)
    return SpotTurn(twist_command(plant), math.radians(m.turn_rate_deg_s), sc.traction.max_accel_m_s2 / lever)


def _twin_follower(sc: Scenario, follower: PathFollower, plant: Plant, path: Path, point: str) -> PathFollower:
    """A follower of the scenario's steered law guiding ``point`` (the scenario's own when it already does)."""
    if getattr(follower, "point", None) == point:
        return follower
    spec = sc.controller
    name = getattr(follower, "name", None)
    if name not in ("seed_general", "pure_pursuit"):
        raise sc.error(("mission", "point_switching"), f"{name} guides point C only: use seed_general or pure_pursuit")
    kwargs: dict[str, Any] = dict(spec.params)
    kwargs["point"] = point
    if name == "pure_pursuit":
        kwargs.setdefault("v_nominal", sc.traction.speed_m_s)
    if spec.poles_per_m is not None:
        kwargs["poles_per_m"] = list(spec.poles_per_m)
    if spec.gains is not None:
        if name == "seed_general":
            kwargs["gains"] = tuple(spec.gains[k] for k in ("a", "b", "c"))
            kwargs.setdefault("v_max", sc.traction.speed_m_s)
        else:
            kwargs.update(spec.gains)
    try:
        return make_follower(name, "steered", path, plant.geometry, **kwargs)
    except (ValueError, GuidanceError) as exc:
        raise sc.error(("controller",), f"point {point}: {exc}") from None
