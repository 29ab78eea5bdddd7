"""The mission autopilot: one :class:`~agvnav.navigation.path.PathAutopilot` per stint of a planned mission.

:class:`MissionAutopilot` drives a :class:`~agvnav.routes.mission.MissionPlan` (the legs chained into
one path, :func:`agvnav.sim.mission.plan_mission` plans a scenario's) stint after stint
(:func:`stints`: one per leg, or with point switching one per guided point, C cruising and O on
each final approach and backing up [seed000 §3.1]): for each a
:class:`~agvnav.navigation.path.PathAutopilot` (speed profile + follower, stops at cusps)
follows that stint's path with a :class:`LimitedSpeedProfile` that caps the cruise speed by the
speed limit (edge limits, curvature, creep-in before the station; a steered vehicle holds the
station heading over the creep-in, :class:`agvnav.guidance.approach.HeadingHoldApproach`); once
the pilot of a leg's last stint has stopped at the station the mission autopilot lets a
spot-turning vehicle position finely at standstill (:class:`~agvnav.guidance.FinePositioner`,
wired by :mod:`agvnav.navigation.fine_positioning`: the estimate settles, slow commanded
corrections, the station heading), records the stop, holds for the job's dwell time and starts
the next stint.

Topological navigation (seed 003 §3.9): the controller's path is the concatenation of the
planned edges; where the vehicle is on the graph (edge, progress, next node) comes from its
progress along the chained path. The recorded signals add ``leg`` (index of the job being
driven), ``nodes_passed``, ``dwelling`` (1 while stopped at a station) and ``point_offset`` (m,
the guided point's distance ahead of base_link), and with hold points (:meth:`MissionAutopilot.hold_at`)
``traffic_hold`` (1 while the vehicle stands at a hold point: waiting for traffic, or for a job's release time).
"""

from __future__ import annotations

import bisect
import dataclasses
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from agvnav.actuators import SpeedProfile
from agvnav.geometry import wrap_angle_scalar
from agvnav.guidance import FinePositioner
from agvnav.guidance.paths import LineSegment, Path, Segment
from agvnav.navigation.path import PathAutopilot
from agvnav.roles import Estimator, Plant
from agvnav.routes.mission import MissionPlan, speed_limits

__all__ = [
    "ALIGN_WHEELBASES",
    "HOLD_REACHED_M",
    "MIN_APPROACH_M",
    "NODE_REACHED_M",
    "SPOT_TURN_DONE_RAD",
    "SPOT_TURN_MIN_RAD",
    "HoldPoints",
    "LimitedSpeedProfile",
    "MissionAutopilot",
    "SpotTurn",
    "StationStop",
    "Stint",
    "run_bounds",
    "stints",
    "sub_path",
    "turn_points",
]

#: A node counts as passed once the progress is within this distance (m) of it (a station stop ends short of it).
NODE_REACHED_M = 0.05


class LimitedSpeedProfile(SpeedProfile):
    """A :class:`SpeedProfile` whose cruise target is capped by a speed limit along the leg.

    ``limit()`` returns the cap (m/s) where the vehicle is now; the target's sign
    (direction of travel) is kept.
    """

    limit: Callable[[], float] | None = None
    carry_on: float = 0.0
    """distance (m) the vehicle drives on past the end of the current path (a handover): no braking for it."""
    hold: Callable[[], float] | None = None
    """distance (m) to the hold point where the vehicle must stand next (inf: none; :class:`HoldPoints`)."""

    def command(self, remaining: float, dt: float, v_target: float | None = None) -> float:
        """As :meth:`SpeedProfile.command`, with ``|v_target|`` capped by ``limit()``, ``carry_on`` m
        added to ``remaining`` (m), and ``remaining`` cut at the hold point (the profile's own braking stops
        the vehicle there, smoothly, and starts it again once the hold point moves on)."""
        target = self.cruise_speed if v_target is None else float(v_target)
        if self.limit is not None:
            target = math.copysign(min(abs(target), self.limit()), target) if target else 0.0
        ahead = remaining + self.carry_on
        if self.hold is not None:
            ahead = min(ahead, max(self.hold(), 0.0))
        return super().command(ahead, dt, target)


@runtime_checkable
class HoldPoints(Protocol):
    """Where a vehicle must stand next along its mission path: a traffic controller's hold points.

    A fleet's traffic control (:mod:`agvnav.traffic.hold`) tells each vehicle, from the progress the vehicle
    reports, the node before the next conflict zone it may not enter yet; the vehicle brakes to stand there
    and goes on once the point moves on.
    """

    def hold_point(self, s: float) -> float:
        """Arclength (m) along the mission path where the vehicle at ``s`` (m, its estimate) must stand next
        (inf: none)."""


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


#: A vehicle stands at its hold point within this distance (m) of it (the recorded ``traffic_hold``).
HOLD_REACHED_M = 0.1

#: A joint of the mission path where the body heading jumps by more than this (rad) is a turn on the spot.
SPOT_TURN_MIN_RAD = math.radians(5.0)
#: A turn on the spot ends once the estimated heading is within this (rad) of the target.
SPOT_TURN_DONE_RAD = math.radians(0.5)


def turn_points(plan: MissionPlan, tol: float = SPOT_TURN_MIN_RAD) -> list[float]:
    """Arclengths (m) of the joints of the mission path where the body heading jumps by more than ``tol`` (rad): the
    turns on the spot the planner gave a spot-turning vehicle inside a leg."""
    starts = plan.path.segment_starts
    out = []
    for i in range(1, len(plan.path.segments)):
        a, b = plan.path.segments[i - 1], plan.path.segments[i]
        ha = float(a.end_heading) + (math.pi if a.direction < 0 else 0.0)
        hb = float(b.heading_at(0.0)) + (math.pi if b.direction < 0 else 0.0)
        if abs(wrap_angle_scalar(hb - ha)) > tol:
            out.append(float(starts[i]))
    return out


def stints(plan: MissionPlan, switching: bool, wheelbase: float = 0.0, turns: bool = False) -> list[Stint]:
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
        if not turns:
            return [Stint(k, float(plan.leg_bounds[k, 0]), float(plan.leg_bounds[k, 1]), None, 0.0, True)
                    for k in moving]
        return _turning_stints(plan, moving)
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


def _turning_stints(plan: MissionPlan, moving: list[int]) -> list[Stint]:
    """One stint per stretch between two turns on the spot (:func:`turn_points`) inside each moving leg."""
    cuts_all = turn_points(plan)
    out = []
    for k in moving:
        a, b = float(plan.leg_bounds[k, 0]), float(plan.leg_bounds[k, 1])
        cuts = [a, *(c for c in cuts_all if a + 1e-9 < c < b - 1e-9), b]
        out += [Stint(k, s0, s1, None, 0.0, s1 == b) for s0, s1 in itertools.pairwise(cuts)]
    return out


@dataclass(frozen=True)
class SpotTurn:
    """How a spot-turning vehicle turns on the spot between two stints: the plant command of a body twist
    ``twist(v, omega)`` (m/s, rad/s), the turn rate (rad/s) and the spot-turn acceleration (rad/s^2)."""

    twist: Callable[[float, float], tuple[float, ...]]
    turn_rate: float
    turn_accel: float

    def omega(self, error: float, omega_prev: float, dt: float) -> float:
        """Yaw rate (rad/s) for the next ``dt`` s with ``error`` (rad) left: the largest that still stops at the
        target at ``turn_accel``, at most ``turn_rate``, changed by at most ``turn_accel dt``."""
        want = math.copysign(min(self.turn_rate, math.sqrt(2.0 * self.turn_accel * abs(error))), error)
        step = self.turn_accel * dt
        return min(max(want, omega_prev - step), omega_prev + step)


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
        self._wrap: Callable[[PathAutopilot], PathAutopilot] | None = None
        self._holds: HoldPoints | None = None
        self._spot: SpotTurn | None = None
        self._turn_to: float | None = None
        self._omega = 0.0
        self._begin()

    def _begin(self) -> None:
        """The first stint's pilot, and the signal names its pilots give."""
        self.pilot = self._start(0)
        names = self.pilot.signal_names
        self._i_s, self._i_rem = names.index("s_est"), names.index("remaining")
        self._i_v = names.index("v_cmd")
        held: tuple[str, ...] = ("traffic_hold",) if self._holds is not None else ()
        self.signal_names = (*names, "leg", "nodes_passed", "dwelling", "point_offset", *held)
        self._sig = (*self.pilot.signals(), 0.0, 0.0, 0.0, self._offsets[self._stints[0].point],
                     *(0.0 for _ in held))

    def wrap_stints(self, wrap: Callable[[PathAutopilot], PathAutopilot]) -> None:
        """Drive every stint with ``wrap(pilot)`` instead of its PathAutopilot (e.g. the reaction to the safety
        fields, :class:`~agvnav.navigation.reactive.ReactiveAutopilot`); before the mission starts only."""
        if self._k != 0 or self.stops or self.finished:
            raise ValueError("wrap the stints before the mission starts")
        self._wrap = wrap
        self._begin()

    def hold_at(self, holds: HoldPoints) -> None:
        """Stand at ``holds``' hold points (a fleet's traffic control): every stint brakes to stop at the next one
        and starts again once it moves on; before the mission starts only."""
        if self._k != 0 or self.stops or self.finished:
            raise ValueError("give the hold points before the mission starts")
        self._holds = holds
        self._begin()

    def turn_on_spot(self, spot: SpotTurn) -> None:
        """Turn on the spot where the mission path's heading jumps inside a leg (:func:`turn_points`: the planner's
        turns at a node), and before a stint that leaves a station in another heading; before the mission starts
        only. Each stretch between two turns is a stint of its own, stopped at its end."""
        if self._k != 0 or self.stops or self.finished:
            raise ValueError("give the spot turn before the mission starts")
        self._spot = spot
        self._stints = stints(self.plan, False, 0.0, turns=True)
        self._begin()

    @property
    def progress(self) -> float:
        """The estimated arclength (m) along the whole mission path (what the vehicle reports to a fleet manager)."""
        return float(self._sig[self._i_s])

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
        if self._spot is not None:
            direction = int(self.plan.path.direction_at(st.s0 + 1e-6))
            self._turn_to = float(self.plan.path.heading_at(st.s0 + 1e-6)) + (math.pi if direction < 0 else 0.0)
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
        if self._wrap is not None:
            pilot = self._wrap(pilot)
        i_s = pilot.signal_names.index("s_est")
        step = float(s_grid[1] - s_grid[0])

        def limit() -> float:
            s = float(pilot.signals()[i_s]) + 2.0 * step + abs(self.profile.v) * 0.1
            return float(v_grid[min(int(s / step), len(v_grid) - 1)])

        self.profile.limit = limit
        self.profile.hold = None
        holds = self._holds
        if holds is not None:
            def hold() -> float:  # the pilot's progress along the stint is one step old, as for limit()
                s = st.s0 + float(pilot.signals()[i_s])
                return holds.hold_point(s) - s

            self.profile.hold = hold
        return pilot

    def _station_point(self, st: Stint) -> tuple[float, float]:
        """Where (m) the guided point of stint ``st`` stops: the end of its leg."""
        p = self.plan.path.point_at(float(self.plan.leg_bounds[st.leg, 1]))
        return float(p[0]), float(p[1])

    def command(self, t: float, estimator: Estimator, plant: Plant, dt: float) -> tuple[float, ...]:
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
        if self._spot is not None and self._turn_to is not None:
            cmd = self._turning(estimator, dt)
            if cmd is not None:
                self._record(dwelling=False)
                return cmd
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

    def _turning(self, estimator: Estimator, dt: float) -> tuple[float, ...] | None:
        """The spot turn to the stint's start heading (None once done: the stint's pilot drives on)."""
        assert self._spot is not None and self._turn_to is not None
        heading = float(estimator.pose[2])
        if not math.isfinite(heading) or estimator.status in ("initialising", "lost"):
            self._omega = 0.0
            return self._hold()  # no heading to turn by: wait for the estimate
        error = wrap_angle_scalar(self._turn_to - heading)
        if abs(error) <= SPOT_TURN_DONE_RAD and abs(self._omega) <= self._spot.turn_accel * dt:
            self._turn_to, self._omega = None, 0.0
            return None
        self._omega = self._spot.omega(error, self._omega, dt)
        return self._spot.twist(0.0, self._omega)

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
        self._sig = (*sig, float(st.leg), float(passed), 1.0 if dwelling else 0.0, self._offsets[st.point],
                     *self._held(s, float(sig[self._i_v]), dwelling))

    def _held(self, s: float, v: float, dwelling: bool) -> tuple[float, ...]:
        """``traffic_hold``: 1 while the vehicle stands at its hold point (not dwelling), with hold points only."""
        if self._holds is None:
            return ()
        at = self._holds.hold_point(s) - s <= HOLD_REACHED_M and v == 0.0 and not dwelling
        return (1.0 if at else 0.0,)

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
