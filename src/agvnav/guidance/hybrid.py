"""The hybrid automaton of seed 004 (Fig. 7): a fixed route corrected by wall landmarks.

Seed 004 §II-C drives a tracked robot around a fixed (square) route with a
finite state machine of five states:

* ``E0`` advance along the current leg;
* ``E1`` / ``E2`` a landmark wall is alongside on the right / left: correct
  the orientation from the side pair (eqs 6-7) while advancing;
* ``E3`` at the end of a leg turn 90° in place and count the turn;
* ``E4`` after four turns stop and reset the counter (a lap is done).

This module makes that machine explicit and inspectable: :attr:`state`,
:attr:`leg`, :attr:`turns`, :attr:`laps_done`, and :attr:`transitions`, the
list of every :class:`Transition` with its time and cause. ``observe(t,
ranges)`` takes ultrasonic readings at their instant; ``command(t)`` steps
the machine and returns wheel speed set-points (seed 004 eqs 1-2) for the PID
speed loops.

Choices the seed leaves open (each a parameter of :class:`HybridParams`):

* Advance (E0-E2) holds the leg line on the *estimated* pose with
  ``omega = -v (2 e_theta / D + e_y / D^2)`` (critically damped in distance,
  ``D`` = ``convergence_distance``), limited to the seed's correction rate of
  3 °/s; speed 15 cm/s, slowing down before the corner.
* Turns (E3) rotate in place at up to the seed's 10 °/s, proportional near
  the target heading, until within ``turn_tolerance``.
* A landmark is *detected* when both side sensors of one side read within
  the seed's optimal range (<= 0.60 m) and both echoes match the same known
  landmark wall (predicted range from the estimated pose within ``gate``),
  with both sensors abreast of the wall at least ``end_margin`` from its ends
  (near an end the cone sees the wall's corner, not its face). While
  alongside, each new pair recalibrates the heading (eqs 6-7) and, if
  ``lateral_calibration``, the distance to the wall (an extension). Each
  correction is blended with ``calibration_gain`` (1 replaces the estimate as
  the seed does; 0.25 by default averages the ultrasonic noise over a few
  pings).
* Eq 8 is applied whenever the front sensor sees a known landmark wall
  across the leg within the optimal range (the corner walls of Fig. 6); its
  gate ``front_gate`` is wider because the along-track error grows with the
  distance driven since the last corner.
* After E4 the robot starts the next lap after ``dwell`` s, until ``laps``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_nonnegative, require_positive
from agvnav.actuators import DriveGeometry
from agvnav.geometry import angle_diff
from agvnav.guidance.kanayama import DriveCommand
from agvnav.positioning.wall_landmarks import WallLandmarkLocalizer
from agvnav.sensors.ultrasonic import ConeEcho, UltrasonicArray, check_wall_segments

__all__ = ["HybridController", "HybridParams", "HybridState", "PolygonRoute", "Transition"]

DEG = math.pi / 180.0


class HybridState(str, Enum):
    """The five states of seed 004, Fig. 7."""

    E0 = "E0"  # advance
    E1 = "E1"  # correct with a right landmark
    E2 = "E2"  # correct with a left landmark
    E3 = "E3"  # turn 90 deg and count
    E4 = "E4"  # stop after four turns, reset


SIDE_STATE = {"right": HybridState.E1, "left": HybridState.E2}


@dataclass(frozen=True)
class Transition:
    """One state change: time ``t`` (s), ``source`` and ``target`` states, human-readable ``cause``."""

    t: float
    source: HybridState
    target: HybridState
    cause: str


@dataclass(frozen=True)
class PolygonRoute:
    """A closed route through ``corners (K, 2)`` (m), driven in order, starting at corner 0.

    Leg ``k`` goes from corner ``k`` to corner ``k + 1`` (mod K); the robot
    turns in place at every corner, so a lap has K turns (4 for the square).
    """

    corners: NDArray[np.float64]

    def __post_init__(self) -> None:
        c = require_finite("corners", self.corners)
        if c.ndim != 2 or c.shape[1] != 2 or c.shape[0] < 3:
            raise ValueError(f"corners must have shape (K >= 3, 2), got {c.shape}")
        lengths = np.linalg.norm(np.roll(c, -1, axis=0) - c, axis=1)
        if np.any(lengths <= 1e-6):
            raise ValueError(f"route leg {int(np.argmin(lengths))} has zero length")
        object.__setattr__(self, "corners", c.copy())

    @classmethod
    def square(cls, side: float, start: ArrayLike = (0.0, 0.0, 0.0), turn: str = "left") -> PolygonRoute:
        """Square of ``side`` m from pose ``start = (x, y, heading)``, turning ``left`` (CCW) or ``right``."""
        require_positive("side", side)
        if turn not in ("left", "right"):
            raise ValueError(f"turn must be 'left' or 'right', got {turn!r}")
        x, y, h = require_finite("start", start).reshape(3)
        sign = 1.0 if turn == "left" else -1.0
        headings = h + sign * np.arange(4) * math.pi / 2
        steps = side * np.stack([np.cos(headings), np.sin(headings)], axis=-1)
        corners = np.array([x, y]) + np.concatenate([np.zeros((1, 2)), np.cumsum(steps[:3], axis=0)])
        return cls(corners)

    @property
    def n_legs(self) -> int:
        """Number of legs (= corners = turns per lap)."""
        return int(self.corners.shape[0])

    def leg(self, k: int) -> tuple[NDArray[np.float64], float, float]:
        """Start point ``(2,)``, heading (rad) and length (m) of leg ``k`` (mod K)."""
        a = self.corners[k % self.n_legs]
        b = self.corners[(k + 1) % self.n_legs]
        d = b - a
        return a, math.atan2(d[1], d[0]), float(np.hypot(*d))

    @property
    def start_pose(self) -> NDArray[np.float64]:
        """Pose at corner 0 facing along leg 0."""
        a, h, _ = self.leg(0)
        return np.array([a[0], a[1], h])


@dataclass(frozen=True)
class HybridParams:
    """Tuning of :class:`HybridController` (SI units; defaults from seed 004 where it gives them).

    cruise_speed 0.15 m/s and the rates 3 °/s (correction) and 10 °/s (turn)
    are the seed's (§III, Figs. 10-11); the rest are our assumptions.
    """

    cruise_speed: float = 0.15
    correction_rate: float = 3.0 * DEG
    turn_rate: float = 10.0 * DEG
    min_turn_rate: float = 0.5 * DEG
    turn_gain: float = 1.5
    turn_tolerance: float = 0.2 * DEG
    convergence_distance: float = 0.6
    decel: float = 0.05
    min_speed: float = 0.01
    detect_range: float = 0.60
    gate: float = 0.15
    front_gate: float = 0.30
    end_margin: float = 0.05
    calibration_gain: float = 0.25
    pair_max_age: float = 0.12
    loss_timeout: float = 0.5
    dwell: float = 1.0
    lateral_calibration: bool = True
    parallel_tolerance: float = 10.0 * DEG

    def __post_init__(self) -> None:
        for name in ("cruise_speed", "correction_rate", "turn_rate", "min_turn_rate", "turn_gain",
                     "turn_tolerance", "convergence_distance", "decel", "detect_range", "gate",
                     "front_gate", "pair_max_age", "loss_timeout", "parallel_tolerance"):
            require_positive(name, getattr(self, name))
        require_nonnegative("min_speed", self.min_speed)
        require_nonnegative("end_margin", self.end_margin)
        if not 0.0 < self.calibration_gain <= 1.0:
            raise ValueError(f"calibration_gain must be in (0, 1], got {self.calibration_gain!r}")
        require_nonnegative("dwell", self.dwell)


@dataclass
class _Reading:
    t: float = -math.inf
    range: float = math.nan


class HybridController:
    """Seed 004's five-state hybrid automaton driving a tracked robot around a route.

    Parameters
    ----------
    route : the closed route (:class:`PolygonRoute`, e.g. ``PolygonRoute.square(3.5)``).
    sensors : the :class:`UltrasonicArray`; it must hold ``right_front``,
        ``right_rear``, ``left_front``, ``left_rear`` and ``front`` (as
        :func:`agvnav.sensors.seed_004_layout`); only those are read.
    landmarks : ``(M, 2, 2)`` landmark wall segments (m) in ``map``.
    geometry : sprocket radius and track width for eqs 1-2.
    params : :class:`HybridParams`. laps : laps to drive (E4 -> E0 between laps).
    use_landmarks : False gives pure dead reckoning (E1/E2 and eq 8 never used).
    localizer : the pose estimate the automaton reads and recalibrates; by
        default a :class:`WallLandmarkLocalizer` at the route start. Feed it
        odometry with ``controller.localizer.predict(t, delta_d, delta_theta)``.
    landmark_ids : names of the landmark walls for the transition causes.
    """

    SIDE_SENSORS = {"right": ("right_front", "right_rear"), "left": ("left_front", "left_rear")}

    def __init__(
        self,
        route: PolygonRoute,
        sensors: UltrasonicArray,
        landmarks: ArrayLike,
        geometry: DriveGeometry | None = None,
        params: HybridParams | None = None,
        laps: int = 1,
        use_landmarks: bool = True,
        localizer: WallLandmarkLocalizer | None = None,
        landmark_ids: list[str] | None = None,
    ):
        self.route = route
        self.sensors = sensors
        self.geometry = geometry or DriveGeometry()
        self.params = params or HybridParams()
        if int(laps) < 1:
            raise ValueError(f"laps must be >= 1, got {laps!r}")
        self.laps = int(laps)
        self.use_landmarks = bool(use_landmarks)
        missing = {"front", *self.SIDE_SENSORS["right"], *self.SIDE_SENSORS["left"]} - set(sensors.names)
        if missing:
            raise ValueError(f"sensor array lacks {sorted(missing)} (see agvnav.sensors.seed_004_layout)")
        self.landmarks = check_wall_segments(landmarks) if np.size(landmarks) else np.zeros((0, 2, 2))
        self.landmark_ids = landmark_ids or [f"W{i}" for i in range(len(self.landmarks))]
        if len(self.landmark_ids) != len(self.landmarks):
            raise ValueError("landmark_ids must name every landmark segment")
        if self.use_landmarks:
            self._check_route_passes_landmarks()
        self.localizer = localizer or WallLandmarkLocalizer(pose=route.start_pose, gain=self.params.calibration_gain)
        self.reset()

    # ------------------------------------------------------------ inspection
    def reset(self) -> None:
        """Back to E0 on leg 0, counters zeroed, transitions cleared (the localizer is kept)."""
        self.state = HybridState.E0
        self.leg, self.turns, self.laps_done = 0, 0, 0
        self.transitions: list[Transition] = []
        self._entered = 0.0
        self._last = {name: _Reading() for name in self.sensors.names}
        self._last_pair_time = -math.inf
        self._predicted: ConeEcho | None = None

    @property
    def finished(self) -> bool:
        """True once all laps are done (the robot stays in E4)."""
        return self.state is HybridState.E4 and self.laps_done >= self.laps

    def visited(self) -> list[str]:
        """State sequence ``["E0", "E1", ...]`` from the transitions (starting with E0)."""
        return [HybridState.E0.value] + [tr.target.value for tr in self.transitions]

    # --------------------------------------------------------------- control
    def observe(self, t: float, ranges: Mapping[str, float]) -> None:
        """Take ultrasonic readings made at time ``t`` (s) and apply eqs 6-8 at once.

        ``ranges`` maps sensor names to ranges (m; nan for a ping without a
        valid echo). Call it when the localizer has been predicted up to ``t``,
        so a calibration corrects the pose of the instant of the ping. Readings
        during a turn (E3) or a stop (E4) are stored but not used.
        """
        t = float(t)
        fresh = self._store(t, ranges)
        if self.use_landmarks and fresh and self.state in (HybridState.E0, HybridState.E1, HybridState.E2):
            self._landmark_updates(t, fresh)

    def command(self, t: float, ranges: Mapping[str, float] | None = None) -> DriveCommand:
        """Step the automaton at time ``t`` (s) and return the wheel speed set-points.

        ``ranges`` (optional) are readings made at ``t``, passed to
        :meth:`observe` first; a simulator that delivers each ping at its own
        instant calls :meth:`observe` itself and omits them here.
        """
        t = float(t)
        if ranges:
            self.observe(t, ranges)
        self._step_machine(t)
        v, omega = self._motion()
        return DriveCommand(v, omega, self.geometry.to_wheels(v, omega), self.state.value)

    def _store(self, t: float, ranges: Mapping[str, float]) -> set[str]:
        fresh = set()
        for name, value in ranges.items():
            if name in self._last:
                self._last[name] = _Reading(t, float(value))
                fresh.add(name)
        return fresh

    def _go(self, t: float, target: HybridState, cause: str) -> None:
        self.transitions.append(Transition(t, self.state, target, cause))
        self.state, self._entered = target, t

    def _step_machine(self, t: float) -> None:
        p = self.params
        if self.state is HybridState.E4:
            if self.laps_done < self.laps and t - self._entered >= p.dwell:
                self._go(t, HybridState.E0, f"lap {self.laps_done} done: start lap {self.laps_done + 1}")
            return
        if self.state is HybridState.E3:
            if abs(self._turn_error()) <= p.turn_tolerance:
                self.turns += 1
                self.leg = (self.leg + 1) % self.route.n_legs
                if self.turns == self.route.n_legs:
                    self.laps_done += 1
                    self.turns = 0
                    self._go(t, HybridState.E4, f"{self.route.n_legs} turns counted: lap {self.laps_done} complete")
                else:
                    self._go(t, HybridState.E0, f"turn {self.turns} done, leg {self.leg}")
            return
        if self.state in (HybridState.E1, HybridState.E2) and t - self._last_pair_time > p.loss_timeout:
            self._go(t, HybridState.E0, "landmark lost")
        along, _, _, length = self._leg_errors()
        if along >= length:
            self._go(t, HybridState.E3, f"end of leg {self.leg} reached (estimated {along:.3f} m)")

    def _motion(self) -> tuple[float, float]:
        p = self.params
        if self.state is HybridState.E4:
            return 0.0, 0.0
        if self.state is HybridState.E3:
            err = self._turn_error()
            rate = min(p.turn_rate, max(p.min_turn_rate, p.turn_gain * abs(err)))
            return 0.0, math.copysign(rate, err)
        along, e_y, e_theta, length = self._leg_errors()
        v = min(p.cruise_speed, max(p.min_speed, math.sqrt(2.0 * p.decel * max(length - along, 0.0))))
        d = p.convergence_distance
        omega = -v * (2.0 * math.sin(e_theta) / d + e_y / d**2)
        return v, float(np.clip(omega, -p.correction_rate, p.correction_rate))

    def _leg_errors(self) -> tuple[float, float, float, float]:
        """Along-leg distance (m), lateral offset (m, left +), heading error (rad), leg length (m)."""
        start, heading, length = self.route.leg(self.leg)
        u = np.array([math.cos(heading), math.sin(heading)])
        rel = self.localizer.pose[:2] - start
        along = float(u @ rel)
        e_y = float(u[0] * rel[1] - u[1] * rel[0])
        return along, e_y, float(angle_diff(self.localizer.pose[2], heading)), length

    def _turn_error(self) -> float:
        _, next_heading, _ = self.route.leg(self.leg + 1)
        return float(angle_diff(next_heading, self.localizer.pose[2]))

    # ------------------------------------------------------------- landmarks
    def _associate(self, name: str, gate: float) -> int:
        """Landmark index that explains the latest reading of ``name``, or -1.

        The reading must be within the detection range and within ``gate`` (m)
        of the range predicted from the estimated pose to a landmark wall.
        """
        reading = self._last[name]
        if not (math.isfinite(reading.range) and reading.range <= self.params.detect_range):
            return -1
        if self._predicted is None:  # one batched prediction for all sensors per pose
            self._predicted = self.sensors.echo(self.localizer.pose, self.landmarks)
        i = self.sensors.names.index(name)
        segment, predicted = int(self._predicted.segment[i]), float(self._predicted.range[i])
        if segment < 0 or abs(predicted - reading.range) > gate:
            return -1
        return segment

    def _landmark_updates(self, t: float, fresh: set[str]) -> None:
        self._predicted = None
        for side, (front, rear) in self.SIDE_SENSORS.items():
            if not fresh & {front, rear}:
                continue
            if self.state not in (HybridState.E0, SIDE_STATE[side]):
                continue
            ages = t - self._last[front].t, t - self._last[rear].t
            if max(ages) > self.params.pair_max_age:
                continue
            wall = self._associate(front, self.params.gate)
            if wall < 0 or self._associate(rear, self.params.gate) != wall or not self._is_parallel(wall):
                continue
            if not (self._abreast(front, wall) and self._abreast(rear, wall)):
                continue
            if self.state is HybridState.E0:
                self._go(t, SIDE_STATE[side], f"{side} landmark {self.landmark_ids[wall]} detected")
            self._calibrate_side(t, side, wall)
            self._last_pair_time = t
            self._predicted = None
        if "front" in fresh:
            wall = self._associate("front", self.params.front_gate)
            if wall >= 0 and not self._is_parallel(wall):
                self.localizer.calibrate_offset(
                    t, [self._last["front"].range], [self.sensors["front"].mount], self.landmarks[wall],
                    kind="front_offset", wall_index=wall,
                )

    def _calibrate_side(self, t: float, side: str, wall: int) -> None:
        front, rear = self.SIDE_SENSORS[side]
        m_front, m_rear = self.sensors[front].mount, self.sensors[rear].mount
        r_front, r_rear = self._last[front].range, self._last[rear].range
        spacing = m_front[0] - m_rear[0]
        self.localizer.calibrate_heading(t, r_front, r_rear, spacing, side, self.landmarks[wall], wall)
        if self.params.lateral_calibration:
            self.localizer.calibrate_offset(
                t, [r_front, r_rear], [m_front, m_rear], self.landmarks[wall], kind="side_offset", wall_index=wall
            )

    def _abreast(self, name: str, wall: int) -> bool:
        """True if the sensor's estimated position projects onto the wall ``end_margin`` inside its ends."""
        a, b = self.landmarks[wall]
        u = (b - a) / np.hypot(*(b - a))
        along = float(u @ (self.sensors[name].sensor_pose(self.localizer.pose)[:2] - a))
        return self.params.end_margin <= along <= float(np.hypot(*(b - a))) - self.params.end_margin

    def _is_parallel(self, wall: int) -> bool:
        d = self.landmarks[wall, 1] - self.landmarks[wall, 0]
        _, heading, _ = self.route.leg(self.leg)
        across = abs(math.sin(math.atan2(d[1], d[0]) - heading))
        return across <= math.sin(self.params.parallel_tolerance)

    def _check_route_passes_landmarks(self) -> None:
        """ValueError unless some landmark runs alongside some leg within the side sensors' reach."""
        half_width = self.sensors.body_width / 2.0
        for k in range(self.route.n_legs):
            start, heading, length = self.route.leg(k)
            u = np.array([math.cos(heading), math.sin(heading)])
            for seg in self.landmarks:
                d = seg[1] - seg[0]
                if abs(math.sin(math.atan2(d[1], d[0]) - heading)) > math.sin(self.params.parallel_tolerance):
                    continue
                along = (seg - start) @ u
                lateral = abs(float(np.mean((seg - start) @ np.array([-u[1], u[0]]))))
                overlap = min(along.max(), length) - max(along.min(), 0.0)
                if overlap > 0.0 and half_width < lateral <= half_width + self.params.detect_range:
                    return
        raise ValueError(
            "the route never passes a landmark: no landmark wall runs alongside a leg within "
            f"{self.params.detect_range:.2f} m of the side sensors"
        )
