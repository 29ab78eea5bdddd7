"""Path follower for steered vehicles: the tricycle controllers behind the follower interface.

Steered vehicles (tricycle stacker, tricycle_rear, ackermann) share one path
geometry: the rear-axle midpoint O is base_link and the steered wheel centre
C (the front axle midpoint of the Ackermann bicycle equivalent) is L ahead.
The seed-000 laws are written for the stacker, whose front wheel drives:
``psi' = v_C sin(gamma) / L``, ``v_O = v_C cos(gamma)`` [seed000 eq8]. Seed
003's model A (rear drive, ``theta' = V tan(phi) / l``, V the speed of O)
[seed003 §3.2.5] and the Ackermann bicycle equivalent [seed003 §3.2.6] have
the same motion for the same path: with ``v_C = V / cos(phi)``,
``V tan(phi) / L = v_C sin(phi) / L`` and O moves at ``v_C cos(phi) = V``.
So every law carries over as it is once it is given the speed of C, whichever
wheel drives; only the plant command differs (:meth:`SteeredFollower.drive_speed`).

Where it does not carry over: the Ackermann car's two front wheels turn by
different angles; the laws command the *bicycle* angle (the plant maps it to
the two wheels), and the equivalence is kinematic (no tyre slip). A steering
limit below 90 deg (model A, Ackermann) bounds the curvature the laws may ask
for: :func:`agvnav.guidance.check_path_feasible` refuses tighter arcs before a
run, and the tractor-trailer is a differential tractor (unicycle family,
:mod:`agvnav.guidance.unicycle`), not a steered vehicle.

Speed conversion: ``command(pose, v, steering)`` takes ``v``, the signed
speed (m/s) of the *tracked* point (the controller's ``point``, C or O)
along the path, and hands the wrapped controller the speed of C:
``v`` when tracking C, ``v / cos(steering)`` when tracking O (cos clipped at
cos 89 deg).
"""

from __future__ import annotations

import math
from typing import Any, Protocol, cast

from numpy.typing import ArrayLike

from agvnav.guidance.baselines import MAX_STEERING_RAD
from agvnav.guidance.controller import CONTROLLERS, GuidanceController
from agvnav.guidance.errors import TrackingErrors
from agvnav.guidance.follower import GuidanceError, check_pose
from agvnav.guidance.paths import Path

__all__ = ["SteeredFollower", "drive_speed"]

_MIN_COS = math.cos(MAX_STEERING_RAD)


class _PointController(GuidanceController, Protocol):
    """The tricycle controllers all expose the point they track ("C" or "O")."""

    point: str


def drive_speed(v: float, steering: float, tracked_point: str, drive_point: str) -> float:
    """Speed (m/s) of the driven wheel centre when the tracked point moves at ``v`` (m/s).

    O and C are rigidly L apart and O moves along the body axis, so
    ``v_O = v_C cos(steering)`` [seed000 eq8]; ``steering`` in rad. Points
    are "C" or "O"; equal points return ``v``.
    """
    for name, p in (("tracked_point", tracked_point), ("drive_point", drive_point)):
        if p not in ("C", "O"):
            raise GuidanceError(f"{name} must be 'C' or 'O', got {p!r}")
    if tracked_point == drive_point:
        return v
    c = max(math.cos(steering), _MIN_COS)
    return v * c if tracked_point == "C" else v / c


class SteeredFollower:
    """A tricycle controller (seed_general, seed_simple, pure_pursuit, stanley) as a path follower.

    Parameters
    ----------
    name : controller name in :data:`agvnav.guidance.CONTROLLERS`.
    path : the planned path of the tracked point.
    wheelbase : L (m); ``drive_point`` "C" or "O" (which wheel drives);
    max_steer : steering limit (rad): a rate that would push the measured
        angle further beyond it is set to 0 (the actuator holds the limit).
    params : the controller's own parameters (``convergence_distance`` m,
        ``point``, gains, ...), see :func:`agvnav.guidance.make_controller`.
    """

    family = "steered"

    def __init__(
        self, name: str, path: Path, wheelbase: float, drive_point: str, max_steer: float, **params: Any
    ):
        if name not in CONTROLLERS:
            raise GuidanceError(f"unknown steered controller {name!r}; choose from: {', '.join(CONTROLLERS)}")
        if not (math.isfinite(max_steer) and 0.0 < max_steer <= 0.5 * math.pi):
            raise GuidanceError(f"max_steer must be in (0, pi/2] rad, got {max_steer!r}")
        drive_speed(0.0, 0.0, "C", drive_point)  # validates drive_point
        try:
            controller = CONTROLLERS[name](path, wheelbase, **params)
        except TypeError as exc:
            raise GuidanceError(f"controller {name!r}: {exc}") from None
        except ValueError as exc:
            raise GuidanceError(f"controller {name!r}: {exc}") from exc
        self.name = name
        self.controller = cast(_PointController, controller)
        self.wheelbase = float(wheelbase)
        self.drive_point = drive_point
        self.max_steer = float(max_steer)

    @property
    def point(self) -> str:
        """The tracked point, "C" or "O": the path is its path, ``v`` its speed."""
        return self.controller.point

    @property
    def path(self) -> Path:
        """The planned path of the tracked point."""
        return self.controller.path

    @property
    def last_errors(self) -> TrackingErrors | None:
        """Seed 000 Fig. 5 errors of the last command (None after a reset)."""
        return self.controller.last_errors

    def set_path(self, path: Path) -> None:
        """Follow a new path from its closest point (resets the follower)."""
        try:
            self.controller.set_path(path)
        except ValueError as exc:
            raise GuidanceError(str(exc)) from exc

    def reset(self) -> None:
        """Forget the projection hint and the last errors."""
        self.controller.reset()

    def command(self, pose: ArrayLike, v: float, steering: float = 0.0) -> tuple[float, float]:
        """``(0.0, steering rate)`` (rad/s) for base_link at ``pose`` (m, m, rad).

        ``v`` (m/s): signed speed of the tracked point; ``steering`` (rad): the
        measured steering angle. See the module doc for the speed conversion.
        """
        x, y, psi, v = check_pose(pose, v)
        gamma = float(steering)
        if not (math.isfinite(gamma) and abs(gamma) < 0.5 * math.pi):
            raise ValueError(f"steering must be a finite angle within (-pi/2, pi/2) rad, got {steering!r}")
        v_c = v if self.point == "C" else v / max(math.cos(gamma), _MIN_COS)
        try:
            rate = self.controller.command((x, y, psi), gamma, v_c)
        except ValueError as exc:
            raise GuidanceError(f"{self.name}: {exc}") from exc
        if abs(gamma) >= self.max_steer and rate * gamma > 0.0:
            rate = 0.0
        return 0.0, rate

    def drive_speed(self, v: float, steering: float) -> float:
        """Speed (m/s) of the driven wheel (plant command) for the tracked point's speed ``v`` (m/s).

        :func:`drive_speed` with this follower's tracked and drive points.
        """
        return drive_speed(v, steering, self.point, self.drive_point)
