"""The seed-000 front-drive tricycle stacker (seed 003 model B) as a truth vehicle.

Composes the motion of :class:`agvnav.kinematics.TricycleStacker` (seed 000 eq. 8,
through its scalar fast path), the steering servo of :mod:`agvnav.actuators`, the
quantising traction and steering encoders of :mod:`agvnav.sensors.encoders` and the
truth-vs-nominal error model of :mod:`agvnav.odometry.errors`.

Truth versus nominal: :class:`~agvnav.odometry.TricycleErrors` scales the
drive-wheel radius and the wheelbase and turns the wheel ``steering_offset`` off
what the steering encoder reads; :class:`~agvnav.odometry.NonSystematicErrors`
slips the traction (variance ``slip_k * |ds|``, so it does not depend on the
step) and adds a random steering error per step. The encoders quantise: the
traction encoder counts whole pulses of the wheel's rotation, the steering
encoder rounds to whole pulses.

Moved from ``agvnav.sim.tricycle`` with its arithmetic unchanged, so seeded runs
stay bit-identical; new are the Plant-role members ``family``, ``pose``,
``failure``, ``geometry`` and ``footprint`` and the 3-tuple odometry.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.actuators import SteeringActuator
from agvnav.geometry.hermite import HermitePoses, hermite_poses
from agvnav.kinematics.scalar import stacker_rk4_values
from agvnav.odometry.errors import NonSystematicErrors, TricycleErrors
from agvnav.odometry.scalar import tricycle_increments_scalar
from agvnav.sensors.encoders import SteeringEncoder, WheelEncoder, steering_reading, wheel_count
from agvnav.vehicles.geometry import SteeredGeometry, box_footprint, check_footprint

__all__ = ["TricyclePlant", "hermite_poses"]


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
    footprint
        Body polygon ``(k, 2)`` in base_link (m); default a box from ``0.15 L``
        behind O to ``1.15 L`` ahead, ``0.4 L`` to each side (an assumption).

    Plant role: ``family = "steered"``, command ``(v, gamma_dot)`` with ``v`` the
    signed speed of the drive wheel centre C (m/s); base_link is the rear-axle
    midpoint O; ``geometry`` is ``SteeredGeometry(L, "C", steering.max_angle)``.
    """

    family: ClassVar[str] = "steered"
    signal_names: tuple[str, ...] = (
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
        steering: SteeringActuator,
        systematic: TricycleErrors,
        nonsystematic: NonSystematicErrors | None,
        initial_state: Sequence[float],
        *,
        footprint: ArrayLike | None = None,
    ) -> None:
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
        self._xyz: tuple[float, ...] = tuple(self._state[:3].tolist())  # the pose now, as floats
        self._start: tuple[float, ...] = tuple(self._state.tolist())  # state at the start of the last step
        hermite = np.zeros((4, 3))  # p0, d0 dt, p1, d1 dt of the last step (see hermite_poses)
        hermite[0], hermite[2] = self._state[:3], self._state[:3]
        self._poses = HermitePoses(hermite, 0.0, 1.0)
        self._u = (0.0, 0.0)  # (v of C, steering rate) held over the last step (m/s, rad/s)
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
        self.geometry = SteeredGeometry(self.L, "C", float(steering.max_angle))
        self.footprint = check_footprint(
            box_footprint(1.15 * self.L, 0.15 * self.L, 0.4 * self.L) if footprint is None else footprint
        )

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

    @property
    def pose(self) -> NDArray[np.float64]:
        """True base_link (O) pose ``[x, y, psi]`` now (m, rad), a copy."""
        return self._state[:3].copy()

    def failure(self) -> str | None:
        """No physical failure ends a tricycle run: always None."""
        return None

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
        x, y, psi = self._xyz
        start = (x, y, psi, ns.perturb_steering_scalar(g0 + self.systematic.steering_offset, rng))
        self._start = start
        v_true = ds_true / dt
        self._u = (v_true, rate)
        self._dt = dt
        new, d0, d1 = stacker_rk4_values(start, v_true, rate, self.L_true, dt)
        self._state = np.array(new)
        self._xyz = new[:3]
        # end poses and scaled end derivatives of the step, for pose_at's Hermite cubic (one array
        # from floats: NumPy's per-call cost was more than the arithmetic)
        herm = np.array([(x, y, psi), (d0[0] * dt, d0[1] * dt, d0[2] * dt),
                         new[:3], (d1[0] * dt, d1[1] * dt, d1[2] * dt)])
        self._poses.set(herm, self._t0, dt)
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

    @property
    def pose_at(self) -> HermitePoses:
        """True base_link (O) pose ``(k, 3)`` at instants ``t (k,)`` inside the last step: ``pose_at(t)``.

        Cubic Hermite interpolation between the exact states at both ends of the
        step, with the exact time derivatives there (seed 000 eq. 8 via the
        kinematic model; :class:`~agvnav.geometry.hermite.HermitePoses`, one object
        updated every step). Its error is ``h^4/384 max|d4x/dt4|``: for a 0.05 s step
        at 0.8 m/s with the wheel turning at 60 deg/s it is below 1e-8 m and 1e-8
        rad (tested), a thousandth of the goniometer's resolution, at a fraction of
        the cost of integrating the kinematics again for every query of the
        sensor's root finder (which evaluates the curve itself, compiled).
        """
        return self._poses

    def odometry(self) -> tuple[float, float, float]:
        """``(delta_d, delta_theta, 0.0)`` of O over the last step from the encoders (nominal L, R).

        Seed 000 eq. 8 over the step with the mean steering reading [seed000 eq8];
        ``delta_lateral`` is 0 (O cannot move sideways).
        """
        return self._odo[0], self._odo[1], 0.0

    def signals(self) -> tuple[float, ...]:
        """Values in ``signal_names`` order (m, rad, m/s, rad/s)."""
        s = self._state.tolist()
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
