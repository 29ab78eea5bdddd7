"""Missions in the closed loop: a mission autopilot driving one :class:`PathAutopilot` per stint.

:func:`plan_mission` loads the scenario's route network, plans every job
(:mod:`agvnav.routes.mission`) and chains the legs into the one path the run
is judged against. :class:`MissionAutopilot` then drives stint after stint
(:func:`stints`: one per leg, or with ``mission.point_switching`` one per guided
point, C cruising and O on each final approach and backing up [seed000 §3.1]):
for each a :class:`~agvnav.sim.roles.PathAutopilot` (speed profile + follower,
stops at cusps) follows that stint's path with a :class:`LimitedSpeedProfile`
that caps the cruise speed by the speed limit (edge limits, curvature,
creep-in before the station; a steered vehicle holds the station heading over the
creep-in, :class:`agvnav.guidance.approach.HeadingHoldApproach`); once the pilot of a leg's last stint has stopped
at the station the mission autopilot lets a spot-turning vehicle position finely at
standstill (:class:`~agvnav.guidance.FinePositioner`: the estimate settles, slow commanded corrections,
the station heading), records the stop, holds for the job's dwell time and starts
the next stint.

Topological navigation (seed 003 §3.9): the controller's path is the
concatenation of the planned edges; where the vehicle is on the graph (edge,
progress, next node) comes from its progress along the chained path
(:class:`agvnav.routes.topology.GraphLocator` for a pose alone). The recorded
series get ``leg`` (index of the job being driven), ``nodes_passed``,
``dwelling`` (1 while stopped at a station) and ``point_offset`` (m, the guided
point's distance ahead of base_link).

Results (:func:`mission_figures`) come from the true pose: the stop errors of
the point guided into each station, once the vehicle is at rest, and the lateral
error of the guided point against the run it drove (:func:`route_tracking`).
"""

from __future__ import annotations

import bisect
import dataclasses
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.actuators import SpeedProfile
from agvnav.geometry import wrap_angle, wrap_angle_scalar
from agvnav.guidance import FinePositioner, GuidanceError, HeadingHoldApproach, make_follower
from agvnav.guidance.errors import errors_from_projection
from agvnav.guidance.paths import LineSegment, Path, Segment
from agvnav.kinematics.differential import wheel_speeds_unchecked
from agvnav.routes.mission import Job, MissionError, MissionPlan, chain_mission, plan_legs, speed_limits
from agvnav.routes.network import EDGE_KINDS, RouteNetwork, load_network, network_reference
from agvnav.routes.planning import Planner, VehicleLimits
from agvnav.sim.roles import PathAutopilot
from agvnav.vehicles import HolonomicGeometry, UnicycleGeometry
from agvnav.world.scenario import GoniometerSpec, Scenario, ScenarioError
from agvnav.world.vehicle_specs import MecanumSpec

__all__ = [
    "ALIGN_WHEELBASES",
    "MIN_APPROACH_M",
    "MOVING_SPEED_M_S",
    "LimitedSpeedProfile",
    "MissionAutopilot",
    "StationStop",
    "Stint",
    "guided_errors",
    "load_mission_network",
    "mission_autopilot",
    "mission_duration",
    "mission_figures",
    "moving_mask",
    "near_line_curve_joints",
    "plan_mission",
    "route_tracking",
    "run_bounds",
    "spot_turn_lever",
    "stints",
    "sub_path",
    "tracked_point",
]

#: A node counts as passed once the progress is within this distance (m) of it (a station stop ends short of it).
NODE_REACHED_M = 0.05


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
    carry_on: float = 0.0
    """distance (m) the vehicle drives on past the end of the current path (a handover): no braking for it."""

    def command(self, remaining: float, dt: float, v_target: float | None = None) -> float:
        """As :meth:`SpeedProfile.command`, with ``|v_target|`` capped by ``limit()`` and ``carry_on`` m
        added to ``remaining`` (m)."""
        target = self.cruise_speed if v_target is None else float(v_target)
        if self.limit is not None:
            target = math.copysign(min(abs(target), self.limit()), target) if target else 0.0
        return super().command(remaining + self.carry_on, dt, target)


@dataclass(frozen=True)
class StationStop:
    """Where the vehicle stopped for a job: leg index, station, time (s), the planned pose there (m, m, rad)."""

    leg: int
    station: str
    t: float
    x: float
    y: float
    heading: float
    offset: float | None = None
    """the guided point's distance ahead of base_link (m) at the stop (None: the run's tracked point)."""
    corrections: int = 0
    """fine-positioning moves driven at standstill before the stop counted (:class:`FinePositioner`)."""


#: Shortest approach (m) guided at O after the handover from C.
MIN_APPROACH_M = 0.5
#: Wheelbases C drives along the final straight before the handover, so the body has turned onto it.
ALIGN_WHEELBASES = 3.0


@dataclass(frozen=True)
class Stint:
    """What one :class:`PathAutopilot` drives: the mission path from ``s0`` to ``s1`` (m) of leg ``leg``,
    guided at ``point`` ("C", "O", or None for the follower's own), its path extended by ``extend`` m
    straight on; ``last`` when it ends at the leg's station; ``handover`` when the next stint takes
    over while the vehicle moves (no stop at its end)."""

    leg: int
    s0: float
    s1: float
    point: str | None
    extend: float
    last: bool
    handover: bool = False


def _straight_tail(plan: MissionPlan, s0: float, s1: float) -> float:
    """Where (m) the run of straight segments ending at ``s1`` starts (not before ``s0``)."""
    starts = plan.path.segment_starts
    i = int(np.searchsorted(starts, s1 - 1e-9, side="left")) - 1
    s = s1
    while i >= 0 and starts[i] >= s0 - 1e-9 and plan.path.segments[i].curvature == 0.0:
        s = float(starts[i])
        i -= 1
    return max(s, s0)


def stints(plan: MissionPlan, switching: bool, wheelbase: float = 0.0) -> list[Stint]:
    """The stints of a mission: one per moving leg, or with ``switching`` the guided point's stints.

    Point switching [seed000 §3.1]: the stacker is guided at C (the steered wheel) cruising and at
    O (between the fork wheels) in manoeuvres. Here a run driven forward (:func:`run_bounds`) is
    cruising (C) into the straight that ends it, the approach to its station or cusp is a
    manoeuvre (O), and so is every run backing up. The handover happens on the move once C has
    driven :data:`ALIGN_WHEELBASES` wheelbases along that straight (after a curve guided at C
    the body lags behind its path; on the straight it turns onto it): the C path goes on
    ``wheelbase`` m further, so when C has arrived there O (L behind, on the line) stands where
    its own path starts, at least :data:`MIN_APPROACH_M` before the station or cusp. A forward
    run without such a straight is guided at O all along.
    """
    moving = [k for k, leg in enumerate(plan.legs) if leg.route is not None and leg.route.traversals]
    if not switching:
        return [Stint(k, float(plan.leg_bounds[k, 0]), float(plan.leg_bounds[k, 1]), None, 0.0, True) for k in moving]
    bounds = run_bounds(plan)
    out: list[Stint] = []
    for k in moving:
        a, b = float(plan.leg_bounds[k, 0]), float(plan.leg_bounds[k, 1])
        cuts = [a, *(float(s) for s in bounds if a + 1e-9 < s < b - 1e-9), b]
        for s0, s1 in itertools.pairwise(cuts):
            last = s1 == b
            if int(plan.path.direction_at(0.5 * (s0 + s1))) < 0:
                out.append(Stint(k, s0, s1, "O", 0.0, last))
                continue
            so = _straight_tail(plan, s0, s1) + ALIGN_WHEELBASES * wheelbase
            if s1 - so >= MIN_APPROACH_M and so - ALIGN_WHEELBASES * wheelbase > s0 + 1e-9:
                out.append(Stint(k, s0, so, "C", wheelbase, False, handover=True))
                out.append(Stint(k, so, s1, "O", 0.0, last))
            else:
                out.append(Stint(k, s0, s1, "O", 0.0, last))
    return out


def sub_path(plan: MissionPlan, a: float, b: float) -> tuple[list[Segment], NDArray[np.int64]]:
    """The segments of the mission path from ``a`` to ``b`` (m), lines cut at the ends, and their indices.

    Arcs are never cut (the stints start and end at segment joints or on straights).
    """
    starts = plan.path.segment_starts
    i0 = int(np.searchsorted(starts, a + 1e-9, side="right") - 1)
    i1 = int(np.searchsorted(starts, b - 1e-9, side="left"))
    out: list[Segment] = []
    for i in range(i0, i1):
        seg = plan.path.segments[i]
        lo, hi = max(a, float(starts[i])), min(b, float(starts[i + 1]))
        if isinstance(seg, LineSegment) and (lo > starts[i] + 1e-9 or hi < starts[i + 1] - 1e-9):
            seg = LineSegment(np.asarray(seg.point_at(lo - starts[i])), seg.heading, hi - lo, seg.direction,
                              seg.yaw_offset)
        out.append(seg)
    return out, np.arange(i0, i1)


class MissionAutopilot:
    """Drives a :class:`MissionPlan` stint by stint with one :class:`PathAutopilot` each (module doc).

    ``make_pilot(path, profile, point, station)`` builds a stint's PathAutopilot (the follower of
    ``point``, or the scenario's for None, is given the path by it; ``station`` the point (x, y), m,
    where the stint stops at its leg's station, None for a stint that does not); ``profile`` is the shared
    :class:`LimitedSpeedProfile`; ``limits`` (lateral accel, creep distance, creep speed) shape
    its speed limit. ``switching`` (and the nominal ``wheelbase``, m) guide C cruising and O in
    manoeuvres (:func:`stints`); a handover stint gives way to the next one, on the move, once
    its progress reached the end of its (extended) path. ``align`` (a spot-turning vehicle): after each station stop the
    vehicle positions finely at standstill (:class:`~agvnav.guidance.FinePositioner`: the estimate settles, a short
    turn-drive-turn correction if it is off the station, the station heading) before it dwells.
    The recorded ``point_offset`` (m) is the guided point's distance ahead of base_link.
    """

    def __init__(
        self,
        plan: MissionPlan,
        make_pilot: Callable[[Path, LimitedSpeedProfile, str | None, tuple[float, float] | None], PathAutopilot],
        profile: LimitedSpeedProfile,
        lateral_accel: float,
        creep_distance: float,
        creep_speed: float,
        switching: bool = False,
        wheelbase: float = 0.0,
        base_offset: float = 0.0,
        align: FinePositioner | None = None,
    ) -> None:
        self.plan = plan
        self._make = make_pilot
        self.profile = profile
        self._limits = (lateral_accel, creep_distance, creep_speed)
        self._offsets = {None: float(base_offset), "C": float(wheelbase), "O": 0.0}
        self.stops: list[StationStop] = []
        self.failure: str | None = None
        self.finished = False
        self._stints = stints(plan, switching, wheelbase)
        self._k = 0
        self._dwell_until = -math.inf
        self._dwell_s = 0.0
        self._align = align
        self._aligning: StationStop | None = None
        self._node_s = [s for s, _ in plan.node_s]
        self._handover_at = math.inf
        self.pilot = self._start(0)
        names = self.pilot.signal_names
        self._i_s, self._i_rem = names.index("s_est"), names.index("remaining")
        self.signal_names = (*names, "leg", "nodes_passed", "dwelling", "point_offset")
        self._sig = (*self.pilot.signals(), 0.0, 0.0, 0.0, self._offsets[self._stints[0].point])

    def _stint_path(self, st: Stint) -> tuple[Path, NDArray[np.float64]]:
        segs, idx = sub_path(self.plan, st.s0, st.s1)
        speed = self.plan.seg_speed[idx]
        if st.extend > 0.0:
            end = segs[-1]
            segs.append(LineSegment(np.asarray(end.end), float(end.end_heading), st.extend, direction=end.direction))
            speed = np.append(speed, speed[-1])
        return Path(segs), speed

    def _start(self, i: int) -> PathAutopilot:
        """The pilot of stint ``i``, with its speed limit installed in the profile.

        A handover stint does not brake at its end (the profile sees the next stint's length as
        well) and its successor starts at the speed the vehicle has.
        """
        self._k = i
        st = self._stints[i]
        path, speed = self._stint_path(st)
        a_lat, creep_d, creep_v = self._limits
        ahead, ahead_speed = path, speed
        if st.handover:  # the limit looks on through the next stint: C stops L past where O will stop
            nxt = self._stints[i + 1]
            ahead, ahead_speed = self._stint_path(Stint(st.leg, st.s0, nxt.s1, None, st.extend, True))
        s_grid, v_grid = speed_limits(ahead, ahead_speed, abs(self.profile.cruise_speed), a_lat,
                                      self.profile.max_decel, creep_d, creep_v)
        moving_on = i > 0 and self._stints[i - 1].handover
        self.profile.reset(self.profile.v if moving_on else 0.0)
        self.profile.carry_on = self._stints[i + 1].s1 - self._stints[i + 1].s0 if st.handover else 0.0
        self._handover_at = path.length - 1e-6 if st.handover else math.inf
        pilot = self._make(path, self.profile, st.point, self._station_point(st) if st.last else None)
        i_s = pilot.signal_names.index("s_est")
        step = float(s_grid[1] - s_grid[0])

        def limit() -> float:
            s = float(pilot.signals()[i_s]) + 2.0 * step + abs(self.profile.v) * 0.1
            return float(v_grid[min(int(s / step), len(v_grid) - 1)])

        self.profile.limit = limit
        return pilot

    def _station_point(self, st: Stint) -> tuple[float, float]:
        """Where (m) the guided point of stint ``st`` stops: the end of its leg."""
        p = self.plan.path.point_at(float(self.plan.leg_bounds[st.leg, 1]))
        return float(p[0]), float(p[1])

    def command(self, t: float, estimator: Any, plant: Any, dt: float) -> tuple[float, ...]:
        """The plant command: the current stint's pilot, the heading alignment, or standstill while dwelling."""
        if self.finished:
            return self._hold()
        if self._aligning is not None:
            assert self._align is not None
            cmd = self._align.command(estimator, dt)
            if cmd is None:
                self._aligning = None
                self._after_stop(t)
                return self._hold() if self.finished else self.command(t, estimator, plant, dt)
            self._record(dwelling=False)
            return cmd
        if t < self._dwell_until:
            self._record(dwelling=True)
            return self._hold()
        if float(self.pilot.signals()[self._i_s]) >= self._handover_at:  # C arrived: O takes over, moving
            self.pilot = self._start(self._k + 1)
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
        st = self._stints[self._k]
        if not st.last:  # a cusp inside the leg: the next run at once
            self.pilot = self._start(self._k + 1)
            return
        leg = self.plan.legs[st.leg]
        end = self.plan.leg_bounds[st.leg, 1]
        p = self.plan.path.point_at(end)
        h = float(self.plan.path.heading_at(end)) + (math.pi if self.plan.path.direction_at(end) < 0 else 0.0)
        stop = StationStop(st.leg, str(leg.station), t, float(p[0]), float(p[1]), h, self._offsets[st.point])
        self.stops.append(stop)
        dwell = leg.dwell_s
        nxt = st.leg + 1
        moving = {s.leg for s in self._stints}
        while nxt < len(self.plan.legs) and nxt not in moving:  # wait jobs after this leg
            dwell += self.plan.legs[nxt].dwell_s
            nxt += 1
        self._dwell_s = dwell
        if self._align is not None:
            self._align.start(stop.x, stop.y, stop.heading, self._offsets[st.point])
            self._aligning = stop
            return
        self._after_stop(t)

    def _after_stop(self, t: float) -> None:
        """The station stop is over (finely positioned): dwell, then the next stint, or the mission is done."""
        if self._k + 1 >= len(self._stints):
            self.finished = True
            if self._align is not None and self.stops:  # the stop counts once finely positioned, at rest
                self.stops[-1] = dataclasses.replace(self.stops[-1], t=t, corrections=self._align.corrections)
            return
        if self._align is not None and self.stops:
            self.stops[-1] = dataclasses.replace(self.stops[-1], t=t, corrections=self._align.corrections)
        self._dwell_until = t + self._dwell_s
        self.pilot = self._start(self._k + 1)

    def _record(self, dwelling: bool) -> None:
        st = self._stints[self._k]
        sig = list(self.pilot.signals())
        s = st.s0 + min(float(sig[self._i_s]), st.s1 - st.s0)
        sig[self._i_s] = s
        sig[self._i_rem] = self.plan.path.length - s
        passed = bisect.bisect_right(self._node_s, s + NODE_REACHED_M)
        self._sig = (*sig, float(st.leg), float(passed), 1.0 if dwelling else 0.0, self._offsets[st.point])

    def signals(self) -> tuple[float, ...]:
        """The stint pilot's signals (``s_est`` and ``remaining`` along the whole mission), leg, nodes, dwelling,
        point_offset."""
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
    sc: Scenario, plan: MissionPlan, follower: Any, plant: Any, point_offset: float, watch: Any
) -> MissionAutopilot:
    """The mission autopilot of scenario ``sc``: one PathAutopilot per stint sharing ``watch``.

    Without point switching every stint uses ``follower`` (the scenario's point, ``point_offset``
    m ahead of base_link); with ``mission.point_switching`` (steered vehicles) a second follower
    of the same law guides the other point. A steered vehicle (it cannot turn at standstill) holds the
    station heading over the last ``mission.creep_distance_m`` before each station instead of correcting
    the lateral error there (:class:`~agvnav.guidance.approach.HeadingHoldApproach`: a lateral correction
    within the creep would cost a heading swing of about twice the error over the creep distance, left
    at the stop). Unicycle and holonomic vehicles position finely at
    standstill after each station stop (:class:`FinePositioner`, ``mission.align_heading``): the
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
    followers: dict[str | None, tuple[Any, float]] = {None: (follower, point_offset)}
    wheelbase = float(getattr(plant.geometry, "wheelbase", 0.0))
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
        twist = _twist_command(plant)
        rate = (sc.goniometer or GoniometerSpec()).rate_hz  # no goniometer: nothing to settle, the seed's rate
        layout = sc.vehicle.layout if isinstance(sc.vehicle, MecanumSpec) else "X"
        try:  # spot-turn acceleration: the traction limit at the wheels over their lever
            lever = spot_turn_lever(plant.geometry, layout)
        except ValueError as exc:
            raise sc.error(("vehicle",), str(exc)) from None
        a = sc.traction.max_accel_m_s2
        align = FinePositioner(twist, 1.0 / rate, a, a / lever, math.radians(m.turn_rate_deg_s))
    return MissionAutopilot(plan, make, profile, m.lateral_accel_m_s2, m.creep_distance_m, m.creep_speed_m_s,
                            switching, wheelbase, point_offset, align)


def spot_turn_lever(geometry: object, layout: str = "X") -> float:
    """A wheel's ground speed per unit yaw rate in a spot turn (m per rad): the traction limit
    ``max_accel`` (m/s^2) over it is the spot-turn acceleration (rad/s^2).

    * differential or tracked base (:class:`~agvnav.vehicles.UnicycleGeometry`): each wheel at half
      the track, ``v_wheel = v +- (track / 2) omega`` (:func:`agvnav.kinematics.differential.wheel_speeds`);
    * mecanum base (:class:`~agvnav.vehicles.HolonomicGeometry`, :mod:`agvnav.kinematics.omnidirectional`):
      ``r omega_i = (v_x - omega y_i) + s_i (v_y + omega x_i)``, so a pure yaw turns each wheel at
      ``|s_i x_i - y_i| omega``: ``a + b`` (half length plus half width) in the ``"X"`` layout,
      ``|a - b|`` in ``"O"`` (``layout``).

    Any other geometry (a steered vehicle cannot turn on the spot) or layout raises ValueError.
    """
    if isinstance(geometry, UnicycleGeometry):
        return 0.5 * geometry.track
    if isinstance(geometry, HolonomicGeometry):
        a, b = geometry.half_length, geometry.half_width
        if layout == "X":
            return a + b
        if layout == "O" and a != b:
            return abs(a - b)
        raise ValueError(f"mecanum layout {layout!r} with half_length {a!r}, half_width {b!r} cannot turn on the spot")
    raise ValueError(f"no spot-turn lever for geometry {type(geometry).__name__}: a differential, tracked or "
                     "mecanum base turns on the spot")


def _twist_command(plant: Any) -> Callable[[float, float], tuple[float, ...]]:
    """Plant command of a body twist ``(v, omega)`` (m/s, rad/s): wheel rates (unicycle) or the twist."""
    if plant.family == "holonomic":
        return lambda v, omega: (v, 0.0, omega)
    g = plant.geometry

    def wheels(v: float, omega: float) -> tuple[float, ...]:
        v_right, v_left = wheel_speeds_unchecked(v, omega, g.track)
        return v_right / g.wheel_radius, v_left / g.wheel_radius

    return wheels


def _twin_follower(sc: Scenario, follower: Any, plant: Any, path: Path, point: str) -> Any:
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
