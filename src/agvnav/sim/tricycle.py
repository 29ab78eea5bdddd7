"""The seed-000 tricycle pallet stacker as plant and autopilot of the closed loop (Fig. 9).

The plant lives in :mod:`agvnav.vehicles.tricycle` (re-exported here until sim is
restructured). Wiring only: the motion is :class:`agvnav.kinematics.TricycleStacker`, the
steering servo and speed profile come from :mod:`agvnav.actuators`, the law from
:mod:`agvnav.guidance`, the goniometer from :mod:`agvnav.sensors.goniometer`.

Truth versus nominal is the odometry package's error model
(:mod:`agvnav.odometry.errors`): :class:`~agvnav.odometry.TricycleErrors` scales
the drive-wheel radius and the wheelbase and turns the wheel ``steering_offset``
off what the steering encoder reads; :class:`~agvnav.odometry.NonSystematicErrors`
slips the traction (variance ``slip_k * |ds|``, so it does not depend on the
step) and adds a random steering error per step. The encoders quantise: the
traction encoder counts whole pulses of the wheel's rotation, the steering
encoder rounds to whole pulses.
"""

from __future__ import annotations

import bisect
import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.vehicles.tricycle import TricyclePlant

__all__ = ["GoniometerSensor", "TricycleAutopilot", "TricyclePlant"]

TWO_PI = 2.0 * math.pi


class GoniometerSensor:
    """The laser goniometer as a closed-loop sensor: scans along the true motion."""

    name = "reflections"
    event_names = ("t", "bearing", "reflector_index")

    def __init__(self, goniometer: Any, world: Any) -> None:
        self.goniometer = goniometer
        self.world = world

    def observe(self, pose_at: Any, t0: float, t1: float, rng: np.random.Generator) -> NDArray[np.float64]:
        r = self.goniometer.scan(self.world, pose_at, t0, t1, rng)
        if len(r) == 0:
            return _EMPTY3
        return np.column_stack([r.t, r.bearing, r.reflector_index])

    def deliver(self, estimator: Any, event: NDArray[np.float64]) -> None:
        estimator.update(float(event[0]), float(event[1]))


_EMPTY3 = np.zeros((0, 3))


class TricycleAutopilot:
    """Guidance law and traction speed profile of the stacker (seed 000 Fig. 9).

    Each step: the speed profile gives the speed of C for the next step from the
    distance left along the path (the projection of the estimated tracked point),
    then the law gives the steering-rate command from the estimated pose, the
    measured steering angle and that speed. Until the estimator has a fix the
    vehicle waits at standstill.

    Progress ``s`` along the path advances only through a projection of the
    estimated tracked point searched within ``progress_window`` metres of the
    previous ``s`` (starting from 0): a start far off the path cannot project
    onto the path end. The path counts as completed only when ``s`` reached the
    end and the tracked point is within ``end_tolerance`` metres of the path's
    end point.
    """

    signal_names = ("v_cmd", "gamma_dot_cmd", "s_est", "eps_c_est", "xi_r_est", "remaining")

    def __init__(
        self,
        controller: Any,
        path: Any,
        profile: Any,
        wheelbase: float,
        point: str = "C",
        progress_window: float = 1.0,
        end_tolerance: float = 0.1,
    ) -> None:
        self.controller = controller
        self.path = path
        self.profile = profile
        self.L = float(wheelbase)
        self.point = point
        self.finished = False
        self._s = 0.0
        self._length = float(path.length)
        # segment starts and directions as Python values: direction_at without NumPy per step
        self._seg_starts = [float(v) for v in path.segment_starts[:-1]]
        self._seg_dirs = [int(seg.direction) for seg in path.segments]
        self._sig = (0.0, 0.0, 0.0, math.nan, math.nan, self._length)
        self.progress_window = float(progress_window)
        self.end_tolerance = float(end_tolerance)
        self._end = tuple(float(c) for c in path.point_at(self._length)) if path is not None else (0.0, 0.0)

    def _tracked_point(self, pose: Any) -> tuple[float, float]:
        """The tracked point (O, or C one wheelbase ahead along the heading) of an estimated pose (m)."""
        x, y, psi = float(pose[0]), float(pose[1]), float(pose[2])
        if self.point == "C":
            return x + self.L * math.cos(psi), y + self.L * math.sin(psi)
        return x, y

    def _advance(self, pose: Any) -> None:
        """Advance ``s`` to the windowed projection of the tracked point (never backwards, never a jump)."""
        x, y = self._tracked_point(pose)
        pr = self.path.project_point(x, y, self._s, self.progress_window)
        self._s = max(self._s, min(float(pr.s), self._s + self.progress_window))

    def _at_end(self, pose: Any) -> bool:
        """True when the tracked point is within ``end_tolerance`` (m) of the path's end point."""
        x, y = self._tracked_point(pose)
        return math.hypot(x - self._end[0], y - self._end[1]) <= self.end_tolerance

    def _direction(self, s: float) -> int:
        """``path.direction_at(s)`` (a joint belongs to the next segment), by bisection on cached starts."""
        s = min(max(s, 0.0), self._length)
        i = bisect.bisect_right(self._seg_starts, s) - 1
        return self._seg_dirs[min(max(i, 0), len(self._seg_dirs) - 1)]

    def command(self, t: float, estimator: Any, plant: Any, dt: float) -> tuple[float, float]:
        pose = estimator.pose
        if not (math.isfinite(pose[0]) and math.isfinite(pose[1]) and math.isfinite(pose[2])):
            self.profile.reset(0.0)
            self._sig = (0.0, 0.0, self._s, math.nan, math.nan, self._length - self._s)
            return 0.0, 0.0
        self._advance(pose)
        remaining = self._length - self._s
        direction = self._direction(self._s)
        v = self.profile.command(remaining, dt, direction * abs(self.profile.cruise_speed))
        gamma = plant.gamma_meas
        rate = float(self.controller.command(pose, gamma, v))
        if v == 0.0 and remaining <= self.profile.stop_tolerance + 1e-9:
            self.finished = self.finished or self._at_end(pose)
            rate = 0.0
        err = getattr(self.controller, "last_errors", None)
        eps_c = xi_r = math.nan
        if err is not None:
            eps_c, xi_r = float(err.eps_c), float(err.xi_r)
        self._sig = (v, rate, self._s, eps_c, xi_r, self._length - self._s)
        return v, rate

    def signals(self) -> tuple[float, ...]:
        return self._sig
