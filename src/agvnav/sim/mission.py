"""Missions in the closed loop: a mission autopilot driving one :class:`PathAutopilot` per leg.

:func:`plan_mission` loads the scenario's route network, plans every job
(:mod:`agvnav.routes.mission`) and chains the legs into the one path the run
is judged against. :class:`MissionAutopilot` then drives leg after leg: for
each leg a :class:`~agvnav.sim.roles.PathAutopilot` (speed profile + follower,
stops at cusps) follows that leg's path with a :class:`LimitedSpeedProfile`
that caps the cruise speed by the leg's speed limit (edge limits, curvature,
creep-in before the station); once the leg's pilot has stopped at the station
the mission autopilot records the stop, holds for the job's dwell time and
starts the next leg.

Topological navigation (seed 003 §3.9): the controller's path is the
concatenation of the planned edges; where the vehicle is on the graph (edge,
progress, next node) comes from its progress along the chained path
(:class:`agvnav.routes.topology.GraphLocator` for a pose alone). The recorded
series get ``leg`` (index of the job being driven), ``nodes_passed`` and
``dwelling`` (1 while stopped at a station).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path as FsPath
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.actuators import SpeedProfile
from agvnav.geometry import wrap_angle_scalar
from agvnav.guidance.paths import Path
from agvnav.routes.mission import Job, MissionError, MissionPlan, chain_mission, plan_legs, speed_limits
from agvnav.routes.network import EDGE_KINDS, RouteNetwork, load_network
from agvnav.routes.planning import Planner, VehicleLimits
from agvnav.sim.roles import PathAutopilot
from agvnav.world.scenario import Scenario, ScenarioError

__all__ = [
    "LimitedSpeedProfile", "MissionAutopilot", "StationStop", "mission_autopilot", "mission_duration",
    "mission_figures", "plan_mission", "route_tracking", "run_bounds", "tracked_point",
]

#: A node counts as passed once the progress is within this distance (m) of it (a station stop ends short of it).
NODE_REACHED_M = 0.05


def _network(sc: Scenario) -> RouteNetwork:
    m = sc.mission
    assert m is not None
    p = FsPath(m.network)
    if not p.is_absolute() and sc.base_dir is not None and (sc.base_dir / p).is_file():
        p = sc.base_dir / p
    try:
        return load_network(p if p.is_file() else m.network)
    except ScenarioError as exc:
        if exc.source in (m.network, str(p)) and "no such" in exc.detail:
            raise sc.error(("mission", "network"), f"no route network {m.network!r} (file or shipped name)") from None
        raise


def plan_mission(sc: Scenario) -> MissionPlan:
    """Plan the scenario's mission into one chained path; errors name the mission key and line."""
    m = sc.mission
    assert m is not None
    net = _network(sc)
    if m.start not in net.nodes:
        raise sc.error(("mission", "start"), f"unknown station {m.start!r} in network {net.name!r}")
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


class LimitedSpeedProfile(SpeedProfile):
    """A :class:`SpeedProfile` whose cruise target is capped by a speed limit along the leg.

    ``limit()`` returns the cap (m/s) where the vehicle is now; the target's sign
    (direction of travel) is kept.
    """

    limit: Callable[[], float] | None = None

    def command(self, remaining: float, dt: float, v_target: float | None = None) -> float:
        """As :meth:`SpeedProfile.command`, with ``|v_target|`` capped by ``limit()``."""
        target = self.cruise_speed if v_target is None else float(v_target)
        if self.limit is not None:
            target = math.copysign(min(abs(target), self.limit()), target) if target else 0.0
        return super().command(remaining, dt, target)


@dataclass(frozen=True)
class StationStop:
    """Where the vehicle stopped for a job: leg index, station, time (s) and the planned pose there."""

    leg: int
    station: str
    t: float
    x: float
    y: float
    heading: float


class MissionAutopilot:
    """Drives a :class:`MissionPlan` leg by leg with one :class:`PathAutopilot` each (module doc).

    ``make_pilot(path, profile)`` builds the leg's PathAutopilot (the follower is
    given the leg's path by it); ``profile`` is the shared :class:`LimitedSpeedProfile`;
    ``limits`` (lateral accel, creep distance, creep speed) shape its speed limit.
    """

    def __init__(
        self,
        plan: MissionPlan,
        make_pilot: Callable[[Path, LimitedSpeedProfile], PathAutopilot],
        profile: LimitedSpeedProfile,
        lateral_accel: float,
        creep_distance: float,
        creep_speed: float,
    ) -> None:
        self.plan = plan
        self._make = make_pilot
        self.profile = profile
        self._limits = (lateral_accel, creep_distance, creep_speed)
        self.stops: list[StationStop] = []
        self.failure: str | None = None
        self.finished = False
        self._leg = 0
        self._dwell_until = -math.inf
        self._leg_s0 = 0.0
        self._node_s = [s for s, _ in plan.node_s]
        self._moving = [k for k, leg in enumerate(plan.legs) if leg.route is not None and leg.route.traversals]
        self.pilot = self._start_leg(self._moving[0])
        names = self.pilot.signal_names
        self._i_s, self._i_rem = names.index("s_est"), names.index("remaining")
        self.signal_names = (*names, "leg", "nodes_passed", "dwelling")
        self._sig = (*self.pilot.signals(), 0.0, 0.0, 0.0)

    def _leg_path(self, k: int) -> tuple[Path, NDArray[np.float64]]:
        sel = np.flatnonzero(self.plan.seg_leg == k)
        segs = [self.plan.path.segments[i] for i in sel]
        return Path(segs), self.plan.seg_speed[sel]

    def _start_leg(self, k: int) -> PathAutopilot:
        """The pilot of leg ``k`` (one that moves), with its speed limit installed in the profile."""
        self._leg = k
        path, speed = self._leg_path(k)
        self._leg_s0 = float(self.plan.leg_bounds[k, 0])
        a_lat, creep_d, creep_v = self._limits
        s_grid, v_grid = speed_limits(path, speed, abs(self.profile.cruise_speed), a_lat, self.profile.max_decel,
                                      creep_d, creep_v)
        self.profile.reset(0.0)
        pilot = self._make(path, self.profile)
        i_s = pilot.signal_names.index("s_est")
        step = float(s_grid[1] - s_grid[0])

        def limit() -> float:
            s = float(pilot.signals()[i_s]) + 2.0 * step + abs(self.profile.v) * 0.1
            return float(v_grid[min(int(s / step), len(v_grid) - 1)])

        self.profile.limit = limit
        return pilot

    def command(self, t: float, estimator: Any, plant: Any, dt: float) -> tuple[float, ...]:
        """The plant command: the current leg's pilot, or standstill while dwelling."""
        if self.finished:
            return self._hold()
        if t < self._dwell_until:
            self._record(dwelling=True)
            return self._hold()
        cmd = self.pilot.command(t, estimator, plant, dt)
        if self.pilot.failure is not None:
            self.failure, self.finished = self.pilot.failure, True
        elif self.pilot.finished:
            self._arrived(t)
        self._record(dwelling=False)
        return cmd

    def _hold(self) -> tuple[float, ...]:
        return (0.0, 0.0, 0.0) if self.pilot.family == "holonomic" else (0.0, 0.0)

    def _arrived(self, t: float) -> None:
        leg = self.plan.legs[self._leg]
        end = self.plan.leg_bounds[self._leg, 1]
        p = self.plan.path.point_at(end)
        h = float(self.plan.path.heading_at(end)) + (math.pi if self.plan.path.direction_at(end) < 0 else 0.0)
        self.stops.append(StationStop(self._leg, str(leg.station), t, float(p[0]), float(p[1]), h))
        dwell = leg.dwell_s
        nxt = self._leg + 1
        while nxt < len(self.plan.legs) and nxt not in self._moving:  # wait jobs after this leg
            dwell += self.plan.legs[nxt].dwell_s
            nxt += 1
        if nxt >= len(self.plan.legs):
            self.finished = True
            return
        self._dwell_until = t + dwell
        self.pilot = self._start_leg(nxt)

    def _record(self, dwelling: bool) -> None:
        sig = list(self.pilot.signals())
        s = self._leg_s0 + float(sig[self._i_s])
        sig[self._i_s] = s
        sig[self._i_rem] = self.plan.path.length - s
        passed = bisect.bisect_right(self._node_s, s + NODE_REACHED_M)
        self._sig = (*sig, float(self._leg), float(passed), 1.0 if dwelling else 0.0)

    def signals(self) -> tuple[float, ...]:
        """The leg pilot's signals (``s_est`` and ``remaining`` along the whole mission), leg, nodes, dwelling."""
        return self._sig


def run_bounds(plan: MissionPlan) -> NDArray[np.float64]:
    """Arclengths (m) along the mission path where a *run* starts, and the path length last.

    A run is a stretch driven in one direction within one leg: a new one starts at every
    leg start and at every cusp (a change of the direction of travel), where the vehicle stops.
    """
    starts = plan.path.segment_starts
    dirs = np.array([seg.direction for seg in plan.path.segments])
    cusps = starts[1:-1][dirs[1:] != dirs[:-1]]
    b = np.unique(np.concatenate([plan.leg_bounds[:, 0], cusps, [0.0]]))
    return np.append(b[b < plan.path.length - 1e-9], plan.path.length)


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
    pts = tracked_point(series)
    hint = np.nan_to_num(series["s_est"], nan=0.0)
    bounds = run_bounds(plan)
    run = np.clip(np.searchsorted(bounds, hint, side="right") - 1, 0, len(bounds) - 2)
    s_out = np.zeros(len(hint))
    lat = np.zeros(len(hint))
    starts = plan.path.segment_starts
    for r in np.unique(run):
        a, b = float(bounds[r]), float(bounds[r + 1])
        i0 = int(np.searchsorted(starts, a + 1e-9, side="right") - 1)
        i1 = int(np.searchsorted(starts, b - 1e-9, side="left"))
        sub = Path(list(plan.path.segments[i0:i1]))
        sel = run == r
        local_hint = np.clip(hint[sel] - a, 0.0, sub.length)
        pr = sub.project(pts[sel], s_hint=local_hint, window=1.0)
        s_out[sel] = a + np.asarray(pr.s)
        lat[sel] = np.asarray(pr.lateral)
    return s_out, lat


def mission_figures(
    series: dict[str, NDArray[np.float64]], plan: MissionPlan, stops: list[StationStop]
) -> dict[str, float]:
    """Mission results from the *true* pose: stop errors per station, mission time, lateral error per edge kind.

    ``stop_error_m[i]`` is the distance of the true guided point from the planned
    station point at the moment stop ``i`` was declared; ``stop_heading_error_rad[i]``
    the true heading's difference from the planned one. Lateral errors are those of the
    true guided point against the run it was driving (:func:`route_tracking`), grouped by
    the kind of edge (line, arc, clothoid, nurbs) its projection lies on;
    ``max_lateral_m.line_curve_joints`` is the largest from 0.5 m before to 1.5 m after every
    forward joint between a line and an arc or clothoid edge.
    """
    out: dict[str, float] = {"stations": float(len(stops))}
    t = series["t"]
    pts = tracked_point(series)
    errs, herrs = [], []
    for i, st in enumerate(stops):
        k = min(int(np.searchsorted(t, st.t)), len(t) - 1)
        e = math.hypot(pts[k, 0] - st.x, pts[k, 1] - st.y)
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
    moving = np.abs(series["v_cmd"]) > 1e-6
    for code, name in enumerate(EDGE_KINDS):
        m = moving & (kind == code)
        lat = np.abs(lateral[m])
        out[f"max_lateral_m.{name}"] = float(lat.max()) if lat.size else math.nan
        out[f"rms_lateral_m.{name}"] = float(np.sqrt(np.mean(lat**2))) if lat.size else math.nan
    near = moving & _near_line_curve_joints(plan, s_route)
    lat = np.abs(lateral[near])
    out["max_lateral_m.line_curve_joints"] = float(lat.max()) if lat.size else math.nan
    return out


def _near_line_curve_joints(plan: MissionPlan, s: NDArray[np.float64], before: float = 0.5,
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
    sc: Scenario, plan: MissionPlan, follower: Any, plant: Any, point_offset: float, watch: Any
) -> MissionAutopilot:
    """The mission autopilot of scenario ``sc``: one PathAutopilot per leg sharing ``follower`` and ``watch``."""
    m, tc = sc.mission, sc.traction
    assert m is not None
    try:
        profile = LimitedSpeedProfile(cruise_speed=tc.speed_m_s, max_accel=tc.max_accel_m_s2,
                                      max_decel=tc.max_decel_m_s2)
    except ValueError as exc:
        raise sc.error(("traction",), str(exc)) from None

    def make(path: Path, prof: LimitedSpeedProfile) -> PathAutopilot:
        follower.set_path(path)
        follower.reset()
        return PathAutopilot(follower, path, prof, plant, point_offset, watch=watch)

    return MissionAutopilot(plan, make, profile, m.lateral_accel_m_s2, m.creep_distance_m, m.creep_speed_m_s)
