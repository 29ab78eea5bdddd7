"""The seed-004 tracked robot as a truth vehicle (seed 004 §II, ICR slip model).

The truth motion is :class:`agvnav.kinematics.TrackedVehicle` (ICR slip model),
the speed loops are :class:`agvnav.actuators.WheelSpeedLoop` (seed 004 PID,
Kp = 10, Ki = 20, Kd = 0.5, on a motor pair with asymmetry) run through its scalar
fast path.

Truth versus nominal. The tracks slip on the ground as the *truth* terrain
says; odometry (seed 004 eqs 3-5 generalised to the ICR model) converts the
quantised sprocket-encoder increments with the *odometry* terrain: the figures
the robot was calibrated with, which need not be the floor it drives on. That
mismatch, not motor asymmetry, is what drifts (plus the random slip of
:class:`agvnav.kinematics.TrackSlipNoise`): the PID integral cancels the
asymmetry at the sprockets, and the encoders see the sprockets, not the ground.

Speed. The speed loop and the vehicle run in ``substep`` sub-steps (10 ms)
inside every engine step, through the packages' scalar fast paths (each tested
against its kernel to 1e-12). Within a sub-step each track moves at the mean of
its start and end sprocket speeds (trapezoidal rule of the first-order motor
response).

Moved from ``agvnav.sim.tracked`` with its arithmetic unchanged (seeded runs stay
bit-identical); new are ``family``, ``geometry``, ``footprint``, ``failure`` and the
3-tuple odometry.
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
from agvnav.kinematics.tracked import TrackedVehicle, TrackSlipNoise, TrackTerrain
from agvnav.odometry._fast import track_increments
from agvnav.vehicles.geometry import UnicycleGeometry, box_footprint, check_footprint
from agvnav.vehicles.motion import piecewise_twist_pose

__all__ = ["TrackedPlant"]

TWO_PI = 2.0 * math.pi


class TrackedPlant:
    """Truth tracked robot: speed loops, ICR slip, sprocket encoders, nominal odometry.

    Parameters
    ----------
    vehicle : :class:`agvnav.kinematics.TrackedVehicle` with the *truth* terrain.
    loop : :class:`agvnav.actuators.WheelSpeedLoop` (its state is copied at construction).
    odometry_terrain : the :class:`~agvnav.kinematics.tracked.TrackTerrain` odometry believes.
    counts_per_rev : sprocket encoder counts per revolution (quantisation).
    initial_pose : true ``[x, y, heading]`` (m, rad).
    substep : speed-loop period (s).
    slip_noise_std : random slip, ``slip_noise_std`` m after 1 m per track: the
        :class:`agvnav.kinematics.TrackSlipNoise` model, drawn once per engine step.

    footprint : body polygon ``(k, 2)`` in base_link (m); default the seed-004 robot's
        0.40 m width and an assumed 0.50 m length, centred on base_link.

    Plant role: ``family = "unicycle"``; the command is the sprocket speed set-point
    ``[right, left]`` (rad/s); ``geometry`` is ``UnicycleGeometry(gauge, sprocket_radius)``.
    """

    family: ClassVar[str] = "unicycle"
    signal_names = ("x", "y", "psi", "omega_right", "omega_left", "v", "yaw_rate", "odo_dd", "odo_dtheta", "distance")

    def __init__(
        self,
        vehicle: TrackedVehicle,
        loop: WheelSpeedLoop,
        odometry_terrain: TrackTerrain | str,
        counts_per_rev: int,
        initial_pose: Sequence[float],
        substep: float = 0.01,
        slip_noise_std: float = 0.0,
        *,
        footprint: ArrayLike | None = None,
    ) -> None:
        if int(counts_per_rev) < 1:
            raise ValueError(f"counts_per_rev must be >= 1, got {counts_per_rev!r}")
        if not (math.isfinite(substep) and substep > 0):
            raise ValueError(f"substep must be a positive number of seconds, got {substep!r}")
        self.vehicle = vehicle
        self.r = float(vehicle.sprocket_radius)
        self.speed_loop = ScalarSpeedLoop(loop)
        self.odometry_model = TrackedVehicle(vehicle.gauge, self.r, odometry_terrain)
        self.counts_per_rev = int(counts_per_rev)
        self.substep = float(substep)
        self.slip_noise_std = float(slip_noise_std)
        self.slip_noise = TrackSlipNoise(self.slip_noise_std)
        self._T = [[float(v) for v in row] for row in vehicle.twist_matrix]
        self._To = [[float(v) for v in row] for row in self.odometry_model.twist_matrix]
        p = np.asarray(initial_pose, dtype=np.float64).reshape(3)
        self._pose = [float(p[0]), float(p[1]), float(p[2])]
        self._angle = [0.0, 0.0]  # true sprocket rotations (rad)
        self._counts = [0, 0]
        self._t0, self._h = 0.0, self.substep
        self._states = p[None, :].copy()
        self._twists = np.zeros((1, 3))
        self._odo = (0.0, 0.0)
        self._v = self._w = 0.0
        self.distance = 0.0
        self._lateral = 0.0
        self.geometry = UnicycleGeometry(float(vehicle.gauge), self.r)
        half_w = max(0.20, 0.5 * self.geometry.track + 0.035)
        self.footprint = check_footprint(box_footprint(0.25, 0.25, half_w) if footprint is None else footprint)

    @property
    def pose(self) -> NDArray[np.float64]:
        """True base_link pose now ``(3,)``."""
        return np.array(self._pose)

    def failure(self) -> str | None:
        """No physical failure ends a tracked run: always None."""
        return None

    def advance(self, command: Sequence[float], t0: float, dt: float, rng: np.random.Generator) -> None:
        """Hold sprocket set-points ``[right, left]`` (rad/s) from ``t0`` for ``dt`` s."""
        n = max(1, round(dt / self.substep))
        h = dt / n
        sp = (float(command[0]), float(command[1]))
        # random slip of the step: the faster sprocket's set-point distance sets its scale
        noise = self.slip_noise.factors_scalar(max(abs(sp[0]), abs(sp[1])) * self.r * dt, rng)
        T = self._T
        x, y, th = self._pose
        states, twists = [(x, y, th)], []
        loop = self.speed_loop
        dist = 0.0
        for _ in range(n):
            w0 = loop.omega[0], loop.omega[1]
            w1 = loop.step(sp, h)
            wr, wl = 0.5 * (w0[0] + w1[0]), 0.5 * (w0[1] + w1[1])
            self._angle[0] += wr * h
            self._angle[1] += wl * h
            vx, vy, w = track_twist(wr * self.r * noise[0], wl * self.r * noise[1], T)
            x, y, th = twist_pose(x, y, th, vx, vy, w, h)
            states.append((x, y, th))
            twists.append((vx, vy, w))
            dist += math.hypot(vx, vy) * h
        self._pose = [x, y, th]
        self._t0, self._h = float(t0), h
        self._states = np.array(states)
        self._twists = np.array(twists)
        self._v, self._w = twists[-1][0], twists[-1][2]
        self.distance += dist
        self._odo = self._odometry_increment()

    def _odometry_increment(self) -> tuple[float, float]:
        """Nominal ``(delta_d, delta_theta)`` from the encoder counts (ICR-generalised) [seed004 eq3] [seed004 eq4].

        Also stores the nominal lateral increment (row ``v_y`` of the odometry
        terrain's twist matrix; 0 unless its ``x_icr`` is non-zero).
        """
        q = TWO_PI / self.counts_per_rev
        ds = []
        for i in (0, 1):
            c = math.floor(self._angle[i] / q)
            ds.append((c - self._counts[i]) * q * self.r)
            self._counts[i] = c
        t1 = self._To[1]
        self._lateral = t1[0] * ds[0] + t1[1] * ds[1]
        return track_increments(ds[0], ds[1], self._To)

    def pose_at(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """True pose ``(k, 3)`` at instants ``t (k,)`` of the last step (exact per sub-step twist)."""
        return piecewise_twist_pose(t, self._t0, self._h, self._states, self._twists)

    def odometry(self) -> tuple[float, float, float]:
        """``(delta_d, delta_theta, delta_lateral)`` of base_link over the last step (nominal model).

        Seed 004 eqs 3-5 generalised to the ICR model [seed004 eq5]; ``delta_lateral``
        is the odometry terrain's predicted skid (0 for ``x_icr = 0``).
        """
        return self._odo[0], self._odo[1], self._lateral

    def signals(self) -> tuple[float, ...]:
        """Values in ``signal_names`` order (m, rad, rad/s, m/s, rad/s, m, rad, m)."""
        x, y, th = self._pose
        w = self.speed_loop.omega
        return (x, y, th, w[0], w[1], self._v, self._w, self._odo[0], self._odo[1], self.distance)
