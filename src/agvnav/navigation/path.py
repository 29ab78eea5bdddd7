"""The path autopilot: speed profile + path follower + the family's command conversion, for every vehicle.

:class:`PathAutopilot` runs a speed profile (:class:`agvnav.actuators.SpeedProfile`) and any path
follower of :mod:`agvnav.guidance` and converts their output into the plant's command for its
family (docs/ARCHITECTURE.md):

* steered: ``(v_drive, steer_rate)``, ``v_drive`` the driven wheel's speed for the
  profile's speed of the tracked point (``v_O = v_C cos(gamma)`` [seed000 eq8]);
* unicycle: wheel set-points ``((v + ω b/2)/r, (v − ω b/2)/r)`` with the nominal
  track ``b`` and wheel radius ``r`` [seed004 eq1] [seed004 eq2];
* holonomic: the body twist ``(v_x, v_y, ω)`` of the follower (its ``last_twist``).

It reads the estimate (:class:`agvnav.roles.Estimator`) and, on a steered vehicle, the measured
steering angle; never the truth.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from agvnav.actuators import SpeedProfile
from agvnav.guidance import GuidanceError, Path
from agvnav.guidance.follower import FollowErrors, PathFollower
from agvnav.kinematics.differential import wheel_speeds_unchecked
from agvnav.navigation.guard import SpeedWatch
from agvnav.roles import Estimator, Plant, SteeringReading
from agvnav.vehicles.geometry import UnicycleGeometry

__all__ = ["DriveSpeed", "PathAutopilot", "TwistOutput"]


@runtime_checkable
class DriveSpeed(Protocol):
    """A steered follower's conversion of the tracked point's speed into the driven wheel's (m/s)."""

    def drive_speed(self, v: float, steering: float) -> float:
        """Driven wheel speed (m/s) for the tracked point's speed ``v`` (m/s) at steering angle ``steering`` (rad)."""


@runtime_checkable
class TwistOutput(Protocol):
    """A holonomic follower's last body twist ``(v_x, v_y, omega)`` (m/s, m/s, rad/s), None after a reset."""

    last_twist: tuple[float, float, float] | None


class PathAutopilot:
    """Speed profile + path follower + the family's command conversion, for every vehicle.

    Each step: the speed profile gives the speed for the next step from the
    distance left along the path (the projection of the estimated tracked
    point), then the follower gives the rate command from the estimated pose,
    the measured steering angle (steered vehicles) and that speed. Until the
    estimator has a fix the vehicle waits at standstill; should the estimate
    become undefined while it moves, it brakes straight ahead at its deceleration limit.

    Progress ``s`` along the path advances only through a projection of the
    estimated tracked point searched within ``progress_window`` metres ahead of
    the previous ``s`` (starting from 0): a start far off the path cannot project
    onto the path end. It holds while the estimator's status is ``lost``, so a
    wandering lost estimate cannot carry it to the path end; once the status leaves
    ``lost`` it is projected again within the window either side (a relocalisation may
    move it back). The speed profile brings the vehicle to a stop at every cusp
    (where the direction of travel changes) before it drives on in the
    other direction, and the follower is given one run of same-direction
    segments at a time (a reverse segment often retraces a forward one, where
    a projection could not tell them apart). The path counts as completed only when ``s`` reached the
    end and the tracked point is within ``end_tolerance`` metres of the path's
    end point.

    Parameters
    ----------
    follower : a :mod:`agvnav.guidance` path follower (``command(pose, v, steering) -> (v_lat, rate)``).
    path : the planned path of the tracked point.
    profile : :class:`agvnav.actuators.SpeedProfile`.
    plant : the vehicle, read only for its family, nominal ``geometry`` and measured steering ``gamma_meas``
        (a steered vehicle's proprioceptive reading, :class:`agvnav.roles.SteeringReading`).
    point_offset : the tracked point's distance ahead of base_link along the heading (m; L for C).
    watch : an optional :class:`agvnav.navigation.guard.SpeedWatch` (:class:`~agvnav.navigation.guard.EstimatorWatch`):
        its guard's speed scale
        multiplies the profile's target speed (slow down / controlled stop when positioning
        degrades, issue 12) and its signals are recorded after the autopilot's own.

    A follower failure (:class:`agvnav.guidance.GuidanceError`) stops the vehicle and sets
    ``failure = "infeasible"``; the run then ends as the autopilot is ``finished``.
    """

    signal_names: tuple[str, ...] = (
        "v_cmd", "rate_cmd", "v_lateral_cmd", "s_est", "lateral_error_est", "heading_error_est", "remaining",
    )

    def __init__(
        self,
        follower: PathFollower,
        path: Path,
        profile: SpeedProfile,
        plant: Plant,
        point_offset: float = 0.0,
        progress_window: float = 1.0,
        end_tolerance: float = 0.1,
        watch: SpeedWatch | None = None,
    ) -> None:
        self.watch = watch
        self.failure: str | None = None
        if watch is not None:
            self.signal_names = (*PathAutopilot.signal_names, *watch.signal_names)
        self.path = path
        self.profile = profile
        self.plant = plant
        self.family = str(plant.family)
        self.geometry = plant.geometry
        self._steering = _steering_reading(plant) if self.family == "steered" else None
        self.follower = follower
        self._wheels = _wheels(plant.geometry) if self.family == "unicycle" else (math.nan, math.nan)
        self.offset = float(point_offset)
        self.finished = False
        self._s = 0.0
        self._length = float(path.length)
        # segment starts and directions as Python values: direction_at without NumPy per step
        self._seg_starts = [float(v) for v in path.segment_starts[:-1]]
        self._seg_dirs = [int(seg.direction) for seg in path.segments]
        self._run_end, self._run_dir = self._run_from(0.0)
        self._run_start = 0.0
        self._was_lost = False
        self._cusps = 0
        if self._run_end < self._length:  # the follower sees one run of one direction at a time
            follower.set_path(self._run_path(0.0))
        self._sig: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, math.nan, math.nan, self._length)
        self.progress_window = float(progress_window)
        self.end_tolerance = float(end_tolerance)
        self._end = tuple(float(c) for c in path.point_at(self._length))

    @property
    def follower(self) -> PathFollower:
        """The path follower (replaceable: its family's extra output is looked up once, here)."""
        return self._follower

    @follower.setter
    def follower(self, follower: PathFollower) -> None:
        self._follower = follower
        self._drive = follower if isinstance(follower, DriveSpeed) else None
        self._twist = follower if isinstance(follower, TwistOutput) else None

    def _tracked_point(self, pose: Sequence[float] | NDArray[np.float64]) -> tuple[float, float]:
        """The tracked point (base_link, or ``point_offset`` ahead along the heading) of a pose (m)."""
        x, y, psi = (float(pose[0]), float(pose[1]), float(pose[2])) if type(pose) is not tuple else pose
        if self.offset:
            return x + self.offset * math.cos(psi), y + self.offset * math.sin(psi)
        return x, y

    def _advance(self, pose: tuple[float, float, float], back: float = 0.0) -> None:
        """Move ``s`` to the projection of the tracked point searched in ``[s - back, s + window]``.

        The search never reaches past the end of the current run of segments in one
        direction (a cusp), so a reverse segment retracing a forward one is entered
        only once the vehicle has stopped at the cusp, nor behind the run's start.
        ``back`` is 0 (progress never goes back) except once the status leaves ``lost``:
        a relocalisation can correct the pose by metres, and a wrong one that was briefly
        trusted may have carried ``s`` ahead of the vehicle (integrity bench, differential
        clutter severe, seed 19: ``s`` at the path end, the vehicle 0.88 m before it,
        standing until the timeout).
        """
        lo = max(self._run_start, self._s - back)
        hi = min(self._s + self.progress_window, self._run_end)
        if hi - lo <= 1e-12:
            return
        x, y = self._tracked_point(pose)
        pr = self.path.project_point(x, y, 0.5 * (lo + hi), 0.5 * (hi - lo))
        self._s = min(max(float(pr.s), lo), hi)

    def _at_end(self, pose: tuple[float, float, float]) -> bool:
        """True when the tracked point is within ``end_tolerance`` (m) of the path's end point."""
        x, y = self._tracked_point(pose)
        return math.hypot(x - self._end[0], y - self._end[1]) <= self.end_tolerance

    def _run_from(self, s: float) -> tuple[float, int]:
        """End (m) and direction (+1/-1) of the run of same-direction segments starting at ``s``."""
        i = min(max(bisect.bisect_right(self._seg_starts, s) - 1, 0), len(self._seg_dirs) - 1)
        direction = self._seg_dirs[i]
        j = i
        while j + 1 < len(self._seg_dirs) and self._seg_dirs[j + 1] == direction:
            j += 1
        end = self._seg_starts[j + 1] if j + 1 < len(self._seg_starts) else self._length
        return end, direction

    def _run_path(self, s: float) -> Path:
        """The sub-path of the run of same-direction segments starting at ``s`` (a cusp or 0)."""
        i = min(max(bisect.bisect_right(self._seg_starts, s) - 1, 0), len(self._seg_dirs) - 1)
        end, _ = self._run_from(s)
        j = bisect.bisect_left(self._seg_starts, end - 1e-12) if end < self._length else len(self._seg_dirs)
        return type(self.path)(list(self.path.segments[i:j]))

    def _hold(self) -> tuple[float, ...]:
        """The command that keeps the vehicle at standstill."""
        return (0.0, 0.0, 0.0) if self.family == "holonomic" else (0.0, 0.0)

    def command(self, t: float, estimator: Estimator, plant: Plant, dt: float) -> tuple[float, ...]:
        """The plant command for the next ``dt`` s from the estimate (see the class doc)."""
        pose = estimator.pose
        xyp = (float(pose[0]), float(pose[1]), float(pose[2]))  # plain floats, read once
        if not (math.isfinite(xyp[0]) and math.isfinite(xyp[1]) and math.isfinite(xyp[2])):
            return self._brake_blind(dt)
        lost = estimator.status == "lost"
        if not lost:  # a lost estimate says nothing of progress
            self._advance(xyp, self.progress_window if self._was_lost else 0.0)
        self._was_lost = lost
        remaining = self._run_end - self._s
        scale = 1.0 if self.watch is None else self.watch.scale(t, estimator)
        v = self.profile.command(remaining, dt, self._run_dir * abs(self.profile.cruise_speed) * scale)
        steering = self._measured_steering()
        try:
            v_lat, rate = self.follower.command(pose, v, steering)
        except GuidanceError:
            self.failure = self.failure or "infeasible"
            self.finished = True
            self.profile.reset(0.0)
            return self._hold()
        if v == 0.0 and scale == 0.0:  # stopped for positioning: hold still (no turn or sidestep either)
            v_lat = rate = 0.0
        if v == 0.0 and remaining <= self.profile.stop_tolerance + 1e-9:
            if self._run_end < self._length:  # stopped at a cusp: the next run reverses
                self._s = self._run_start = self._run_end
                self._run_end, self._run_dir = self._run_from(self._s)
                self.follower.set_path(self._run_path(self._s))
            else:
                self.finished = self.finished or self._at_end(xyp)
            v_lat = rate = 0.0
        lateral, heading = self._errors()
        self._sig = (v, rate, v_lat, self._s, lateral, heading, self._length - self._s)
        return self._plant_command(v, v_lat, rate, steering)

    def _measured_steering(self) -> float:
        """The steering angle a steered vehicle measures (rad); 0 for the other families."""
        return float(self._steering.gamma_meas) if self._steering is not None else 0.0

    def _brake_blind(self, dt: float) -> tuple[float, ...]:
        """No pose estimate: brake straight ahead at the deceleration limit (stand still if at rest)."""
        v_prev = self.profile.v
        v = self.profile.command(max(self._run_end - self._s, 1.0), dt, 0.0)
        self._sig = (v, 0.0, 0.0, self._s, math.nan, math.nan, self._length - self._s)
        if v == 0.0:
            return self._hold()
        if self.family == "holonomic":  # the last twist, scaled down with the speed
            k = v / v_prev if v_prev else 0.0
            return tuple(k * c for c in self._last_twist())
        steering = self._measured_steering()
        return self._plant_command(v, 0.0, 0.0, steering)

    def _errors(self) -> tuple[float, float]:
        """The follower's view of the lateral and heading errors (m, rad): seed 000's eps_c, xi_r if steered."""
        err = self.follower.last_errors
        if err is None:
            return math.nan, math.nan
        if isinstance(err, FollowErrors):  # base_link's (unicycle, holonomic)
            return float(err.lateral), float(err.heading_error)
        return float(err.eps_c), float(err.xi_r)  # a steered follower's, seed 000 Fig. 5

    def _plant_command(self, v: float, v_lat: float, rate: float, steering: float) -> tuple[float, ...]:
        if self.family == "steered":  # the driven wheel's speed for the tracked point's speed v
            return _drive_speed(self._drive).drive_speed(v, steering), rate
        if self.family == "unicycle":
            track, wheel_radius = self._wheels
            v_right, v_left = wheel_speeds_unchecked(v, rate, track)
            return v_right / wheel_radius, v_left / wheel_radius
        if v == 0.0 and v_lat == 0.0 and rate == 0.0:  # at rest (e.g. the path's end): no follower twist
            return 0.0, 0.0, 0.0
        return tuple(self._last_twist())

    def _last_twist(self) -> tuple[float, float, float]:
        """The holonomic follower's last twist (m/s, m/s, rad/s)."""
        twist = None if self._twist is None else self._twist.last_twist
        if twist is None:
            raise GuidanceError("the holonomic follower has given no twist yet")
        return twist

    def signals(self) -> tuple[float, ...]:
        """``v_cmd, rate_cmd, v_lateral_cmd, s_est, lateral_error_est, heading_error_est, remaining``.

        Followed by the watch's signals when one is given.
        """
        if self.watch is not None:
            return (*self._sig, *self.watch.signals())
        return self._sig


def _steering_reading(plant: Plant) -> SteeringReading:
    """The steered vehicle's steering reading (its ``gamma_meas``), or ValueError."""
    if not isinstance(plant, SteeringReading):
        raise ValueError(f"a steered vehicle measures its steering angle (gamma_meas); {type(plant).__name__} does not")
    return plant


def _drive_speed(follower: DriveSpeed | None) -> DriveSpeed:
    """The steered follower's driven-wheel speed conversion, or ValueError when it has none."""
    if follower is None:
        raise ValueError("a steered vehicle's follower converts the speed for the driven wheel (drive_speed)")
    return follower


def _wheels(geometry: object) -> tuple[float, float]:
    """``(track, wheel_radius)`` (m) of a unicycle base's nominal geometry, or ValueError."""
    if not isinstance(geometry, UnicycleGeometry):
        raise ValueError(
            f"a unicycle vehicle has a UnicycleGeometry (track, wheel radius), got {type(geometry).__name__}"
        )
    return geometry.track, geometry.wheel_radius
