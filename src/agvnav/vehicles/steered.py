"""Rear-drive steered vehicles as truth vehicles: seed 003 model A (``tricycle_rear``) and Ackermann.

Both move like :class:`agvnav.kinematics.TricycleRearDrive` (seed 003 model A: the
rear-axle midpoint O, base_link, moves at the traction speed ``V`` along the
heading and ``θ' = V tan φ / L``); the Ackermann car (seed 003 §3.2.6) is its
bicycle equivalent, with both front wheel angles reported
(:func:`agvnav.kinematics.ackermann_wheel_angles`).

Composition: the steering servo is an :class:`agvnav.actuators.SteeringActuator`;
the traction loop turns the rear wheels at ``v / R`` (nominal radius); truth
versus nominal is :class:`agvnav.odometry.TricycleErrors` (true wheel radius and
wheelbase, steering offset between the wheel and the encoder) and
:class:`agvnav.odometry.NonSystematicErrors` (traction slip, random steering
error per step); a rear-wheel traction :class:`~agvnav.sensors.encoders.WheelEncoder`
and an absolute :class:`~agvnav.sensors.encoders.SteeringEncoder` feed the nominal
odometry ``ΔD = ds_O``, ``Δθ = ds_O tan φ / L`` with the mean steering reading.

Motion: RK4 of the model in ``substep`` sub-steps of the engine step (the steering
angle changes linearly inside it); :meth:`SteeredPlant.pose_at` interpolates each
sub-step with the cubic Hermite of its end states and derivatives (error
``h^4/384 max|d4p/dt4|``: about 1e-10 rad for 10 ms at 1 m/s and 60 deg/s steering,
where one 50 ms cubic is off by 5e-8 rad, half the goniometer's resolution).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.actuators import SteeringActuator
from agvnav.kinematics.ackermann import ackermann_wheel_angles
from agvnav.odometry.errors import NonSystematicErrors, TricycleErrors
from agvnav.sensors.encoders import SteeringEncoder, WheelEncoder, steering_reading, wheel_count
from agvnav.vehicles.geometry import SteeredGeometry, box_footprint, check_footprint
from agvnav.vehicles.motion import hermite_pose

__all__ = ["STEERED_MODELS", "SteeredPlant", "rear_drive_rate", "rear_drive_rk4"]

#: The rear-drive steered models this plant simulates.
STEERED_MODELS = ("tricycle_rear", "ackermann")

Rate4 = tuple[float, float, float, float]


def rear_drive_rate(theta: float, phi: float, v: float, phi_dot: float, wheelbase: float) -> Rate4:
    """``d/dt [x, y, θ, φ]`` of seed 003 model A: ``(V cos θ, V sin θ, V tan φ / L, φ̇)`` [seed003 §3.2.5].

    ``v`` the speed of the rear-axle midpoint O (m/s), ``phi_dot`` rad/s, ``wheelbase`` L (m).
    """
    return v * math.cos(theta), v * math.sin(theta), v * math.tan(phi) / wheelbase, phi_dot


def rear_drive_rk4(state: Sequence[float], v: float, phi_dot: float, wheelbase: float, dt: float) -> tuple[
    list[float], Rate4, Rate4
]:
    """One classical RK4 step of :func:`rear_drive_rate` over ``dt`` s from ``[x, y, θ, φ]`` (m, rad).

    Returns the new state and the state derivatives at the start and at the end of the step.
    """
    x, y, th, ph = (float(c) for c in state)
    h = dt
    k1 = rear_drive_rate(th, ph, v, phi_dot, wheelbase)
    k2 = rear_drive_rate(th + 0.5 * h * k1[2], ph + 0.5 * h * k1[3], v, phi_dot, wheelbase)
    k3 = rear_drive_rate(th + 0.5 * h * k2[2], ph + 0.5 * h * k2[3], v, phi_dot, wheelbase)
    k4 = rear_drive_rate(th + h * k3[2], ph + h * k3[3], v, phi_dot, wheelbase)
    new = [c + h / 6.0 * (a + 2.0 * b + 2.0 * cc + d) for c, a, b, cc, d in zip((x, y, th, ph), k1, k2, k3, k4,
                                                                                strict=True)]
    return new, k1, rear_drive_rate(new[2], new[3], v, phi_dot, wheelbase)


class SteeredPlant:
    """Truth rear-drive steered vehicle (seed 003 model A or Ackermann) with servo, slip and encoders.

    Parameters
    ----------
    model : ``"tricycle_rear"`` or ``"ackermann"``.
    wheelbase, wheel_radius : nominal L (rear axle to steered axle) and rear-wheel radius (m), > 0.
    traction_cpr, steering_cpr : encoder counts per revolution of the rear wheel and of the steering.
    steering : the :class:`~agvnav.actuators.SteeringActuator`; ``max_angle + |steering_offset|``
        must stay below 90° (``tan φ``).
    systematic : :class:`~agvnav.odometry.TricycleErrors` (default none).
    nonsystematic : :class:`~agvnav.odometry.NonSystematicErrors` (default none).
    initial_state : true ``[x_O, y_O, theta, phi]`` (m, rad); ``phi`` is what the encoder reads.
    track : distance between the front wheels (m), required for ``"ackermann"``.
    substep : integration and interpolation sub-step (s), > 0.
    footprint : body polygon ``(k, 2)`` (m, base_link); default a box from ``0.15 L`` behind
        O to ``1.15 L`` ahead, ``max(0.4 L, track/2 + 0.1)`` to each side (an assumption).

    Plant role: ``family = "steered"``, command ``(v, phi_dot)`` with ``v`` the signed
    speed of O (m/s); ``geometry = SteeredGeometry(L, "O", steering.max_angle)``;
    ``gamma_meas`` is the steering reading (rad).
    """

    family: ClassVar[str] = "steered"

    def __init__(
        self,
        model: str,
        wheelbase: float,
        wheel_radius: float,
        traction_cpr: int,
        steering_cpr: int,
        steering: SteeringActuator,
        systematic: TricycleErrors | None = None,
        nonsystematic: NonSystematicErrors | None = None,
        initial_state: Sequence[float] = (0.0, 0.0, 0.0, 0.0),
        *,
        track: float | None = None,
        substep: float = 0.01,
        footprint: ArrayLike | None = None,
    ) -> None:
        self._check_model(model, track)
        if not (math.isfinite(substep) and substep > 0.0):
            raise ValueError(f"substep must be a positive number of seconds, got {substep!r}")
        self.substep = float(substep)
        self.model = model
        self.systematic = systematic if systematic is not None else TricycleErrors()
        self.nonsystematic = nonsystematic if nonsystematic is not None else NonSystematicErrors()
        self.geometry = SteeredGeometry(float(wheelbase), "O", float(steering.max_angle))
        if steering.max_angle + abs(self.systematic.steering_offset) >= 0.5 * math.pi:
            raise ValueError("steering max_angle + |steering_offset| must stay below pi/2 (tan phi) for a rear drive")
        self.L, self.R = float(wheelbase), float(wheel_radius)
        self.L_true = self.L * self.systematic.wheelbase_scale
        self.R_true = self.R * self.systematic.radius_scale
        self.track = None if track is None else float(track)
        self.traction_encoder = WheelEncoder(int(traction_cpr), self.R)
        self.steering_encoder = SteeringEncoder(int(steering_cpr), offset=self.systematic.steering_offset)
        self.steering = steering
        half_w = 0.4 * self.L if self.track is None else max(0.4 * self.L, 0.5 * self.track + 0.1)
        self.footprint = check_footprint(
            box_footprint(1.15 * self.L, 0.15 * self.L, half_w) if footprint is None else footprint
        )
        self.signal_names: tuple[str, ...] = (
            "x", "y", "psi", "phi", "v", "phi_rate", "gamma_meas", "ds_meas", "odo_dd", "odo_dtheta", "distance_O",
        ) + (("phi_left", "phi_right") if model == "ackermann" else ())
        self._init_state(initial_state)

    @staticmethod
    def _check_model(model: str, track: float | None) -> None:
        if model not in STEERED_MODELS:
            raise ValueError(f"model must be one of {STEERED_MODELS}, got {model!r}")
        if model == "ackermann" and (track is None or not (math.isfinite(track) and track > 0.0)):
            raise ValueError(f"an ackermann plant needs a positive track (m), got {track!r}")

    def _init_state(self, initial_state: Sequence[float]) -> None:
        x0 = np.asarray(initial_state, dtype=np.float64).reshape(4)
        if not np.all(np.isfinite(x0)):
            raise ValueError(f"initial_state must be finite, got {initial_state!r}")
        self.steering.reset(float(x0[3]))
        self._state = [float(x0[0]), float(x0[1]), float(x0[2]), float(x0[3]) + self.systematic.steering_offset]
        self._knots = np.array([self._state[:3], self._state[:3]])
        self._rates = np.zeros((2, 3))
        self._t0, self._h = 0.0, 1.0
        self._wheel_angle, self._count = 0.0, 0
        self.v = 0.0
        self.gamma_meas = self._read_steering(self.steering.gamma)
        self.ds_meas = 0.0
        self._odo = (0.0, 0.0)
        self.distance_O = 0.0

    def _read_steering(self, phi_servo: float) -> float:
        """Steering encoder reading (rad) with the wheel at ``phi_servo + offset``."""
        enc = self.steering_encoder
        return steering_reading(phi_servo + enc.offset, enc.offset, enc.resolution)

    @property
    def pose(self) -> NDArray[np.float64]:
        """True base_link (O) pose ``[x, y, theta]`` now (m, rad)."""
        return np.array(self._state[:3])

    @property
    def state(self) -> NDArray[np.float64]:
        """True ``[x_O, y_O, theta, phi_wheel]`` now (m, rad)."""
        return np.array(self._state)

    def failure(self) -> str | None:
        """No physical failure ends a steered run: always None."""
        return None

    def advance(self, command: Sequence[float], t0: float, dt: float, rng: np.random.Generator) -> None:
        """From ``t0`` (s), hold ``(v, phi_dot)`` for ``dt`` s: servo, truth motion, encoders, odometry.

        ``v`` (m/s) is the commanded speed of O, realised as a rear-wheel rate ``v / R``
        (nominal radius); the ground moves ``R_true`` per radian plus slip.
        """
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
        v_cmd, rate_cmd = float(command[0]), float(command[1])
        g0 = self.steering.gamma
        g1, rate = self.steering.step_rate(rate_cmd, dt)
        wheel_rate = v_cmd / self.R
        ns = self.nonsystematic
        ds_true = ns.perturb_scalar(wheel_rate * dt * self.R_true, rng)
        state = list(self._state)
        state[3] = ns.perturb_steering_scalar(g0 + self.systematic.steering_offset, rng)
        self._integrate(state, ds_true / dt, rate, dt)
        self._t0 = float(t0)
        self.v = ds_true / dt
        self.distance_O += abs(ds_true)
        self._read_encoders(wheel_rate * dt, g1)

    def _integrate(self, state: list[float], v: float, rate: float, dt: float) -> None:
        """RK4 sub-steps of model A over ``dt`` s; keeps the knots and rates for :meth:`pose_at`."""
        n = max(1, round(dt / self.substep))
        h = dt / n
        knots: list[Sequence[float]] = [state[:3]]
        rates: list[Sequence[float]] = []
        d1: Sequence[float] = (0.0, 0.0, 0.0)
        for _ in range(n):
            state, d0, d1 = rear_drive_rk4(state, v, rate, self.L_true, h)
            knots.append(state[:3])
            rates.append(d0[:3])
        rates.append(d1[:3])
        self._state = state
        self._knots, self._rates, self._h = np.array(knots), np.array(rates), h

    def _read_encoders(self, wheel_turn: float, phi_servo: float) -> None:
        """Traction count and steering reading, then the nominal odometry of O [seed003 §3.2.5]."""
        self._wheel_angle += wheel_turn
        enc = self.traction_encoder
        count = wheel_count(self._wheel_angle, enc.angle_resolution)
        self.ds_meas = (count - self._count) * enc.angle_resolution * enc.wheel_radius
        self._count = count
        prev, self.gamma_meas = self.gamma_meas, self._read_steering(phi_servo)
        self._odo = (self.ds_meas, self.ds_meas * math.tan(0.5 * (prev + self.gamma_meas)) / self.L)

    def pose_at(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """True base_link pose ``(k, 3)`` at instants ``t (k,)`` (s) inside the last step (cubic Hermite)."""
        return hermite_pose(t, self._t0, self._h, self._knots, self._rates)

    def odometry(self) -> tuple[float, float, float]:
        """``(delta_d, delta_theta, 0.0)`` of O over the last step: ``ds_O``, ``ds_O tan φ / L`` (nominal)."""
        return self._odo[0], self._odo[1], 0.0

    def signals(self) -> tuple[float, ...]:
        """Values in ``signal_names`` order (m, rad, m/s, rad/s, m); Ackermann adds the front wheel angles (rad)."""
        x, y, th, ph = self._state
        out = (x, y, th, ph, self.v, self.steering.rate, self.gamma_meas, self.ds_meas, self._odo[0], self._odo[1],
               self.distance_O)
        if self.model != "ackermann" or self.track is None:
            return out
        left, right = ackermann_wheel_angles(ph, self.L_true, self.track)
        return (*out, float(left), float(right))
