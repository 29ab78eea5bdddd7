"""The hybrid automaton of seed 004 (Fig. 7): a fixed route corrected by wall landmarks.

Seed 004 §II-C drives a tracked robot around a fixed (square) route with a
finite state machine of five states:

* ``E0`` advance along the current leg;
* ``E1`` / ``E2`` a landmark wall is alongside on the right / left: correct
  the orientation from the side pair ([seed004 eq6] [seed004 eq7]) while advancing;
* ``E3`` at the end of a leg turn 90° in place and count the turn;
* ``E4`` after four turns stop and reset the counter (a lap is done).

This module makes that machine explicit and inspectable: :attr:`state`,
:attr:`leg`, :attr:`turns`, :attr:`laps_done`, and :attr:`transitions`, the
list of every :class:`Transition` with its time and cause. ``command(t)``
steps the machine on the pose of the estimator it reads and returns wheel
speed set-points [seed004 eq1] [seed004 eq2] for the PID speed loops.

The landmark corrections themselves ([seed004 eq6] to [seed004 eq8]: which sensor pair sees which
wall, the corrections, their record) belong to the estimator,
:class:`agvnav.positioning.wall_landmarks.WallLandmarkLocalizer`, which every navigator
shares. The automaton only reads its record of calibrations: a side-pair
calibration is the "landmark alongside" event of E1/E2.

Choices the seed leaves open (each a parameter of :class:`HybridParams`):

* Advance (E0-E2) holds the leg line on the *estimated* pose with
  ``omega = -v (2 e_theta / D + e_y / D^2)`` (critically damped in distance,
  ``D`` = ``convergence_distance``), limited to the seed's correction rate of
  3 °/s; speed 15 cm/s, slowing down before the corner.
* Turns (E3) rotate in place at up to the seed's 10 °/s, proportional near
  the target heading, until within ``turn_tolerance``.
* E1/E2 last while side-pair calibrations keep coming, and fall back to E0
  ``loss_timeout`` s after the last one. The landmark figures of
  :class:`HybridParams` (``gate``, ``end_margin``, ``calibration_gain``...)
  are the estimator's; :meth:`HybridParams.landmark_kwargs` hands them over.
* After E4 the robot starts the next lap after ``dwell`` s, until ``laps``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_nonnegative, require_positive
from agvnav.actuators import DriveGeometry
from agvnav.geometry import angle_diff
from agvnav.guidance.kanayama import DriveCommand

__all__ = [
    "LANDMARK_FIELDS",
    "HybridController",
    "HybridParams",
    "HybridState",
    "LandmarkEstimator",
    "PolygonRoute",
    "Transition",
]

DEG = math.pi / 180.0


class HybridState(StrEnum):
    """The five states of seed 004, Fig. 7."""

    E0 = "E0"  # advance
    E1 = "E1"  # correct with a right landmark
    E2 = "E2"  # correct with a left landmark
    E3 = "E3"  # turn 90 deg and count
    E4 = "E4"  # stop after four turns, reset


SIDE_STATE = {"right": HybridState.E1, "left": HybridState.E2}

#: Fields of :class:`HybridParams` that belong to the wall-landmark estimator.
LANDMARK_FIELDS = ("detect_range", "gate", "front_gate", "end_margin", "calibration_gain", "pair_max_age",
                   "lateral_calibration", "parallel_tolerance")


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

    def landmark_kwargs(self) -> dict[str, Any]:
        """The fields the wall-landmark estimator takes (``agvnav.positioning.landmark_params.LandmarkParams``).

        The automaton itself reads only ``loss_timeout`` of the landmark figures; the
        wiring hands these to the estimator that makes the calibrations.
        """
        return {name: getattr(self, name) for name in LANDMARK_FIELDS}


class LandmarkEstimator(Protocol):
    """What the automaton reads from its estimator: the pose and the calibration record.

    ``history`` holds records with ``t`` (s), ``side`` (``"right"``/``"left"`` for a
    side pair) and ``wall_id``, in time order, as
    :class:`agvnav.positioning.wall_landmarks.WallLandmarkLocalizer` keeps them.
    """

    @property
    def pose(self) -> NDArray[np.float64]: ...

    @property
    def history(self) -> Sequence[Any]: ...


class HybridController:
    """Seed 004's five-state hybrid automaton driving a tracked robot around a route.

    Parameters
    ----------
    route : the closed route (:class:`PolygonRoute`, e.g. ``PolygonRoute.square(3.5)``).
    estimator : where the automaton reads the pose and the landmark calibrations
        (:class:`LandmarkEstimator`, e.g. a
        :class:`~agvnav.positioning.wall_landmarks.WallLandmarkLocalizer` started at the route start).
        The automaton never changes it: feed it odometry and ranges yourself (the
        simulator does).
    geometry : sprocket radius and track width (wheel speeds from ``v``, ``omega``).
    params : :class:`HybridParams`. laps : laps to drive (E4 -> E0 between laps).

    The side-landmark states follow the estimator: a side-pair calibration made
    while in E0 enters E1 (right) or E2 (left) at the calibration's instant, and
    the state falls back to E0 ("landmark lost") ``loss_timeout`` s after the last
    calibration from that side. Without landmark calibrations the automaton drives
    by dead reckoning (E1/E2 never visited).
    """

    def __init__(
        self,
        route: PolygonRoute,
        estimator: LandmarkEstimator,
        geometry: DriveGeometry | None = None,
        params: HybridParams | None = None,
        laps: int = 1,
    ):
        self.route = route
        self.geometry = geometry or DriveGeometry()
        self.params = params or HybridParams()
        if int(laps) < 1:
            raise ValueError(f"laps must be >= 1, got {laps!r}")
        self.laps = int(laps)
        self.bind(estimator)
        self.reset()

    # ------------------------------------------------------------ inspection
    def bind(self, estimator: LandmarkEstimator) -> None:
        """Read the pose and the calibrations from ``estimator`` from now on (its past records are ignored)."""
        if not hasattr(estimator, "pose"):
            raise ValueError("the estimator must expose 'pose'")
        self.estimator = estimator
        self._seen = len(getattr(estimator, "history", ()))

    def reset(self) -> None:
        """Back to E0 on leg 0, counters zeroed, transitions cleared (the estimator is kept)."""
        self.state = HybridState.E0
        self.leg, self.turns, self.laps_done = 0, 0, 0
        self.transitions: list[Transition] = []
        self._entered = 0.0
        self._last_pair_time = -math.inf
        self._seen = len(getattr(self.estimator, "history", ()))

    @property
    def finished(self) -> bool:
        """True once all laps are done (the robot stays in E4)."""
        return self.state is HybridState.E4 and self.laps_done >= self.laps

    def visited(self) -> list[str]:
        """State sequence ``["E0", "E1", ...]`` from the transitions (starting with E0)."""
        return [HybridState.E0.value] + [tr.target.value for tr in self.transitions]

    # --------------------------------------------------------------- control
    def command(self, t: float) -> DriveCommand:
        """Step the automaton at time ``t`` (s) and return the wheel speed set-points.

        First the calibrations the estimator made since the last call (E0 -> E1/E2 at
        their instants), then the state machine on the estimated pose, then the motion
        of the state, converted to wheel speeds by ``geometry``.
        """
        t = float(t)
        self._take_calibrations()
        self._step_machine(t)
        v, omega = self._motion()
        return DriveCommand(v, omega, self.geometry.to_wheels(v, omega), self.state.value)

    def _take_calibrations(self) -> None:
        history = getattr(self.estimator, "history", ())
        if len(history) < self._seen:  # the estimator was reset
            self._seen = 0
        for record in history[self._seen:]:
            side = getattr(record, "side", "")
            if side not in SIDE_STATE:
                continue
            if self.state is HybridState.E0:
                self._go(record.t, SIDE_STATE[side], f"{side} landmark {record.wall_id} detected")
            if self.state is SIDE_STATE[side]:
                self._last_pair_time = record.t
        self._seen = len(history)

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
        pose = self.estimator.pose
        rel = pose[:2] - start
        along = float(u @ rel)
        e_y = float(u[0] * rel[1] - u[1] * rel[0])
        return along, e_y, float(angle_diff(pose[2], heading)), length

    def _turn_error(self) -> float:
        _, next_heading, _ = self.route.leg(self.leg + 1)
        return float(angle_diff(next_heading, self.estimator.pose[2]))
