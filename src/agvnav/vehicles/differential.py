"""Differential-drive AGV: two driven wheels and castors (seed 002 §2, seed 003 §3.2.4) as a truth vehicle.

Composition: the seed-004 speed loop (:class:`agvnav.actuators.WheelSpeedLoop`,
PID + motor pair, through its scalar fast path) turns the wheel-rate set-points
into wheel rotations; the *true* wheel radii and track come from
:class:`agvnav.odometry.SystematicErrors` (Borenstein and Feng's ``E_d``, ``E_b``
and a misalignment of the rolling direction), random wheel slip and bumps from
:class:`agvnav.odometry.NonSystematicErrors`; two quantising
:class:`agvnav.sensors.encoders.WheelEncoder` count the wheel rotations and the
odometry converts them with the *nominal* geometry (seed 002 eq. 16).

Motion: the speed loop runs in ``substep`` sub-steps; in each, a wheel turns at
the mean of its start and end rates (trapezoidal rule of the motor's first-order
response) and the base moves with the constant body twist those ground speeds
give (the SE(2) exponential), so :meth:`DifferentialPlant.pose_at` is exact
inside the step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.actuators import WheelSpeedLoop
from agvnav.actuators._fast import ScalarSpeedLoop
from agvnav.kinematics._fast import track_twist, twist_pose
from agvnav.odometry._fast import track_increments
from agvnav.odometry.errors import DifferentialGeometry, NonSystematicErrors, SystematicErrors
from agvnav.sensors.encoders import WheelEncoder, wheel_count
from agvnav.vehicles.geometry import UnicycleGeometry, box_footprint, check_footprint
from agvnav.vehicles.motion import differential_twist_matrix, piecewise_twist_pose

__all__ = ["DifferentialPlant"]


class DifferentialPlant:
    """Truth differential-drive vehicle: speed loops, true wheel geometry and slip, wheel encoders, nominal odometry.

    Parameters
    ----------
    wheel_radius : nominal radius of both driven wheels (m), > 0.
    track : nominal distance between the driven wheels' contact points (m), > 0.
    counts_per_rev : encoder counts per wheel revolution (quantisation), >= 1.
    initial_pose : true base_link (axle midpoint) pose ``[x, y, heading]`` (m, rad).
    loop : the :class:`~agvnav.actuators.WheelSpeedLoop` (its state is copied; default the seed-004 loop).
    systematic : :class:`~agvnav.odometry.SystematicErrors` of the true vehicle (default none).
    nonsystematic : :class:`~agvnav.odometry.NonSystematicErrors` (default none); slip and
        bumps are drawn per wheel per sub-step (right, then left), their variance
        ``slip_k |d|`` making the result independent of the sub-step.
    substep : speed-loop period (s), > 0.
    footprint : body polygon ``(k, 2)`` in base_link (m); default a box ``±0.5 track``
        long and ``0.5 track + 0.5 wheel_radius`` to each side (an assumption).

    Plant role: ``family = "unicycle"``, command ``(omega_right, omega_left)``
    wheel-rate set-points (rad/s), ``geometry = UnicycleGeometry(track, wheel_radius)``.
    """

    family: ClassVar[str] = "unicycle"
    signal_names: tuple[str, ...] = (
        "x", "y", "psi", "omega_right", "omega_left", "v", "yaw_rate", "odo_dd", "odo_dtheta", "distance",
    )

    def __init__(
        self,
        wheel_radius: float,
        track: float,
        counts_per_rev: int,
        initial_pose: Sequence[float],
        loop: WheelSpeedLoop | None = None,
        systematic: SystematicErrors | None = None,
        nonsystematic: NonSystematicErrors | None = None,
        substep: float = 0.01,
        *,
        footprint: ArrayLike | None = None,
    ) -> None:
        if not (math.isfinite(substep) and substep > 0.0):
            raise ValueError(f"substep must be a positive number of seconds, got {substep!r}")
        self.nominal = DifferentialGeometry.symmetric(wheel_radius, track)
        self.systematic = systematic if systematic is not None else SystematicErrors()
        self.nonsystematic = nonsystematic if nonsystematic is not None else NonSystematicErrors()
        self.truth = self.systematic.true_geometry(self.nominal)
        self.encoders = (WheelEncoder(counts_per_rev, wheel_radius), WheelEncoder(counts_per_rev, wheel_radius))
        self.speed_loop = ScalarSpeedLoop(loop if loop is not None else WheelSpeedLoop())
        self.substep = float(substep)
        self.geometry = UnicycleGeometry(float(track), float(wheel_radius))
        default = box_footprint(0.5 * track, 0.5 * track, 0.5 * track + 0.5 * wheel_radius)
        self.footprint = check_footprint(default if footprint is None else footprint)
        self._T = differential_twist_matrix(self.truth.track, self.systematic.misalignment)
        self._To = differential_twist_matrix(self.nominal.track)
        p = np.asarray(initial_pose, dtype=np.float64).reshape(3)
        self._pose = (float(p[0]), float(p[1]), float(p[2]))
        self._angle = [0.0, 0.0]  # true wheel rotations (rad)
        self._counts = [0, 0]
        self._t0, self._h = 0.0, self.substep
        self._states = p[None, :].copy()
        self._twists = np.zeros((1, 3))
        self._odo = (0.0, 0.0)
        self._v = self._w = 0.0
        self.distance = 0.0

    @property
    def pose(self) -> NDArray[np.float64]:
        """True base_link pose ``[x, y, heading]`` now (m, rad)."""
        return np.array(self._pose)

    @property
    def substep_twists(self) -> NDArray[np.float64]:
        """Body twists ``(n, 3)`` ``[v_x, v_y, omega]`` (m/s, rad/s) of the last step's sub-steps (a copy)."""
        return self._twists.copy()

    @property
    def substep_length(self) -> float:
        """Length (s) of the last step's sub-steps."""
        return self._h

    def failure(self) -> str | None:
        """No physical failure ends a differential run: always None."""
        return None

    def advance(self, command: Sequence[float], t0: float, dt: float, rng: np.random.Generator) -> None:
        """Hold wheel-rate set-points ``(omega_right, omega_left)`` (rad/s) from ``t0`` (s) for ``dt`` s."""
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
        n = max(1, round(dt / self.substep))
        h = dt / n
        sp = (float(command[0]), float(command[1]))
        x, y, th = self._pose
        states, twists = [(x, y, th)], []
        dist = 0.0
        for _ in range(n):
            vx, vy, w = self._substep_twist(sp, h, rng)
            x, y, th = twist_pose(x, y, th, vx, vy, w, h)
            states.append((x, y, th))
            twists.append((vx, vy, w))
            dist += math.hypot(vx, vy) * h
        self._pose = (x, y, th)
        self._t0, self._h = float(t0), h
        self._states = np.array(states)
        self._twists = np.array(twists)
        self._v, self._w = twists[-1][0], twists[-1][2]
        self.distance += dist
        self._odo = self._odometry_increment()

    def _substep_twist(self, setpoint: tuple[float, float], h: float, rng: np.random.Generator) -> tuple[float, ...]:
        """Speed loop for ``h`` s, wheel rotations, true ground speeds, body twist [seed002 eq16]."""
        loop = self.speed_loop
        w0 = loop.omega[0], loop.omega[1]
        w1 = loop.step(setpoint, h)
        wr, wl = 0.5 * (w0[0] + w1[0]), 0.5 * (w0[1] + w1[1])
        self._angle[0] += wr * h
        self._angle[1] += wl * h
        ns, g = self.nonsystematic, self.truth
        d_r = ns.perturb_scalar(wr * h * g.radius_right, rng)
        d_l = ns.perturb_scalar(wl * h * g.radius_left, rng)
        return track_twist(d_r / h, d_l / h, self._T)

    def _odometry_increment(self) -> tuple[float, float]:
        """Nominal ``(ΔD, Δθ)`` from the quantised wheel counts [seed002 eq16]."""
        ds = []
        for i, enc in enumerate(self.encoders):
            c = wheel_count(self._angle[i], enc.angle_resolution)
            ds.append((c - self._counts[i]) * enc.angle_resolution * enc.wheel_radius)
            self._counts[i] = c
        return track_increments(ds[0], ds[1], self._To)

    def pose_at(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """True pose ``(k, 3)`` at instants ``t (k,)`` (s) of the last step (exact per sub-step twist)."""
        return piecewise_twist_pose(t, self._t0, self._h, self._states, self._twists)

    def odometry(self) -> tuple[float, float, float]:
        """``(delta_d, delta_theta, 0.0)`` of base_link over the last step (m, rad, m), nominal [seed002 eq16]."""
        return self._odo[0], self._odo[1], 0.0

    def signals(self) -> tuple[float, ...]:
        """Values in ``signal_names`` order (m, rad, rad/s, m/s, rad/s, m, rad, m)."""
        x, y, th = self._pose
        w = self.speed_loop.omega
        return (x, y, th, w[0], w[1], self._v, self._w, self._odo[0], self._odo[1], self.distance)
