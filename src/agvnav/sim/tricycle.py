"""The seed-000 tricycle pallet stacker as plant and autopilot of the closed loop (Fig. 9).

Wiring only: the motion is :class:`agvnav.kinematics.TricycleStacker`, the
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
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.kinematics._fast import stacker_rk4
from agvnav.odometry._fast import tricycle_increments_scalar
from agvnav.odometry.errors import NonSystematicErrors, TricycleErrors
from agvnav.sensors.encoders import steering_reading, wheel_count

__all__ = ["GoniometerSensor", "TricycleAutopilot", "TricyclePlant"]

TWO_PI = 2.0 * math.pi


class TricyclePlant:
    """Truth tricycle stacker with steering servo and quantising encoders.

    Parameters
    ----------
    wheelbase, wheel_radius
        Nominal L and drive-wheel radius (m).
    traction_cpr, steering_cpr
        Encoder counts per revolution of the drive wheel and of the steering.
    steering
        A :class:`agvnav.actuators.SteeringActuator` (servo limits and lag).
    systematic
        :class:`agvnav.odometry.TricycleErrors` of the truth vehicle.
    nonsystematic
        :class:`agvnav.odometry.NonSystematicErrors` of the traction and steering (None: none).
    initial_state
        True ``[x_O, y_O, psi, gamma]`` (m, rad); ``gamma`` is what the encoder reads
        (the wheel itself points ``steering_offset`` further).
    """

    signal_names = (
        "x",
        "y",
        "psi",
        "gamma",
        "x_C",
        "y_C",
        "v",
        "gamma_rate",
        "gamma_meas",
        "ds_meas",
        "odo_dd",
        "odo_dtheta",
        "distance_C",
    )

    def __init__(
        self,
        wheelbase: float,
        wheel_radius: float,
        traction_cpr: int,
        steering_cpr: int,
        steering: Any,
        systematic: TricycleErrors,
        nonsystematic: NonSystematicErrors | None,
        initial_state: Sequence[float],
    ) -> None:
        from agvnav.sensors.encoders import SteeringEncoder, WheelEncoder

        self.L = float(wheelbase)
        self.R = float(wheel_radius)
        self.systematic = systematic
        self.nonsystematic = nonsystematic if nonsystematic is not None else NonSystematicErrors()
        self.L_true = self.L * systematic.wheelbase_scale
        self.R_true = self.R * systematic.radius_scale
        self.traction_encoder = WheelEncoder(int(traction_cpr), self.R)
        # the encoder reads the servo position: the true wheel angle minus the steering offset
        self.steering_encoder = SteeringEncoder(int(steering_cpr), offset=systematic.steering_offset)
        self.steering_q = self.steering_encoder.resolution
        self.steering = steering
        x0 = np.asarray(initial_state, dtype=np.float64)
        self.steering.reset(float(x0[3]))
        self._state = np.array([x0[0], x0[1], x0[2], x0[3] + systematic.steering_offset])
        self._start = self._state.copy()
        self._deriv = np.zeros((2, 4))
        self._hermite = (self._start[:3], np.zeros(3), self._state[:3], np.zeros(3))
        self._hermite_t = tuple(tuple(a.tolist()) for a in self._hermite)
        self._u = np.zeros(2)
        self._dt = 1.0
        self._t0 = 0.0
        self._wheel_angle = 0.0  # true rotation of the drive wheel (rad)
        self._count = 0
        self.v = 0.0
        self.gamma_meas = self._read_steering(self.steering.gamma)
        self._gamma_meas_prev = self.gamma_meas
        self.ds_meas = 0.0
        self._odo = (0.0, 0.0)
        self.distance_C = 0.0

    def _read_steering(self, gamma_servo: float) -> float:
        """Steering encoder reading (rad) with the wheel at ``gamma_servo + offset``."""
        enc = self.steering_encoder
        g = steering_reading(gamma_servo + enc.offset, enc.offset, enc.resolution)
        limit = math.pi / 2 - enc.resolution  # the reading stays inside (-90, 90) deg, seed 000 §3.1
        return max(-limit, min(limit, g))

    @property
    def state(self) -> NDArray[np.float64]:
        """True ``[x_O, y_O, psi, gamma_wheel]`` now (a copy)."""
        return self._state.copy()

    def advance(self, command: Sequence[float], t0: float, dt: float, rng: np.random.Generator) -> None:
        """From ``t0`` (s), hold ``(v, gamma_dot)`` commands for ``dt`` s: servo, truth motion, encoders.

        ``v`` (m/s) is the commanded speed of C, realised by the traction loop as a
        wheel rotation rate ``v / R`` (nominal radius); the ground moves ``R_true``
        per radian plus slip. ``gamma_dot`` (rad/s) goes through the steering servo.
        """
        v_cmd, rate_cmd = float(command[0]), float(command[1])
        self._t0 = float(t0)
        g0 = self.steering.gamma
        g1, rate = self.steering.step_rate(rate_cmd, dt)
        wheel_rate = v_cmd / self.R
        ns = self.nonsystematic
        ds_true = ns.perturb_scalar(wheel_rate * dt * self.R_true, rng)
        start = self._state
        start[3] = ns.perturb_steering_scalar(g0 + self.systematic.steering_offset, rng)
        self._start = start.copy()
        self._u = np.array([ds_true / dt, rate])
        self._dt = dt
        self._state, self._deriv = stacker_rk4(start, self._u[0], self._u[1], self.L_true, dt)
        # end poses and scaled end derivatives of the step, for pose_at's Hermite cubic
        self._hermite = (self._start[:3], self._deriv[0, :3] * dt, self._state[:3], self._deriv[1, :3] * dt)
        self._hermite_t = tuple(tuple(a.tolist()) for a in self._hermite)
        self.v = ds_true / dt
        self.distance_C += abs(ds_true)
        # encoders (nominal parameters)
        self._wheel_angle += wheel_rate * dt
        enc = self.traction_encoder
        count = wheel_count(self._wheel_angle, enc.angle_resolution)
        self.ds_meas = (count - self._count) * enc.angle_resolution * enc.wheel_radius  # WheelEncoder.distance
        self._count = count
        self._gamma_meas_prev, self.gamma_meas = self.gamma_meas, self._read_steering(g1)
        self._odo = tricycle_increments_scalar(self.ds_meas, 0.5 * (self._gamma_meas_prev + self.gamma_meas), self.L)

    def pose_at(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """True base_link (O) pose ``(k, 3)`` at instants ``t (k,)`` inside the last step.

        Cubic Hermite interpolation between the exact states at both ends of the
        step, with the exact time derivatives there (seed 000 eq. 8 via the
        kinematic model). Its error is ``h^4/384 max|d4x/dt4|``: for a 0.05 s step
        at 0.8 m/s with the wheel turning at 60 deg/s it is below 1e-8 m and 1e-8
        rad (tested), a thousandth of the goniometer's resolution, at a fraction of
        the cost of integrating the kinematics again for every query of the
        sensor's root finder.
        """
        t = np.asarray(t, dtype=np.float64)
        if t.ndim == 1 and t.shape[0] <= 4:  # the goniometer's usual few instants
            return np.array([self._pose_at_scalar(ti) for ti in t.tolist()]).reshape(-1, 3)
        # np.minimum/np.maximum: np.clip's dispatch cost more than the arithmetic here
        u = np.minimum(np.maximum((t - self._t0) / self._dt, 0.0), 1.0)[..., None]
        u2 = u * u
        u3 = u2 * u
        h00, h10 = 2.0 * u3 - 3.0 * u2 + 1.0, u3 - 2.0 * u2 + u
        h01, h11 = 3.0 * u2 - 2.0 * u3, u3 - u2
        p0, d0, p1, d1 = self._hermite
        return h00 * p0 + h10 * d0 + h01 * p1 + h11 * d1

    def _pose_at_scalar(self, t: float) -> tuple[float, float, float]:
        """:meth:`pose_at` for one instant, element by element in the same order (bit-identical)."""
        u = min(max((t - self._t0) / self._dt, 0.0), 1.0)
        u2 = u * u
        u3 = u2 * u
        h00, h10 = 2.0 * u3 - 3.0 * u2 + 1.0, u3 - 2.0 * u2 + u
        h01, h11 = 3.0 * u2 - 2.0 * u3, u3 - u2
        (x0, y0, a0), (dx0, dy0, da0), (x1, y1, a1), (dx1, dy1, da1) = self._hermite_t
        return (
            h00 * x0 + h10 * dx0 + h01 * x1 + h11 * dx1,
            h00 * y0 + h10 * dy0 + h01 * y1 + h11 * dy1,
            h00 * a0 + h10 * da0 + h01 * a1 + h11 * da1,
        )

    def odometry(self) -> tuple[float, float]:
        """``(delta_d, delta_theta)`` of O over the last step from the encoders (nominal L, R)."""
        return self._odo

    def signals(self) -> tuple[float, ...]:
        s = self._state
        c, si = math.cos(s[2]), math.sin(s[2])
        return (
            s[0],
            s[1],
            s[2],
            s[3],
            s[0] + self.L_true * c,
            s[1] + self.L_true * si,
            self.v,
            self.steering.rate,
            self.gamma_meas,
            self.ds_meas,
            self._odo[0],
            self._odo[1],
            self.distance_C,
        )


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
