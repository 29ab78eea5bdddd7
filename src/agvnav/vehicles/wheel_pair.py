"""The shared core of the two-sided (unicycle-family) plants: differential drive and tracks.

A right and a left wheel (or sprocket) are driven by the seed-004 speed loop
(:class:`agvnav.actuators.WheelSpeedLoop` through its scalar fast path) in
``substep`` sub-steps of each engine step. In a sub-step each side turns at the
mean of its start and end rates (trapezoidal rule of the motor's first-order
response); the subclass turns those rates into true ground speeds (its truth
model: wheel radii and slip, or track slip); a *true* twist matrix ``T (3, 2)``
maps the ground speeds ``[v_R, v_L]`` to the body twist ``[v_x, v_y, omega]``,
held over the sub-step (SE(2) exponential), so ``pose_at`` is exact. Two
quantising wheel encoders (:mod:`agvnav.sensors.encoders`) count the rotations;
the *nominal* twist matrix applied to the counted distances gives the odometry
increments ``(∫v_x, ∫omega, ∫v_y)`` (seed 002 eq. 16 for an ideal differential
base, seed 004 eqs 3-5 generalised to the ICR model for tracks).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from agvnav.actuators import WheelSpeedLoop
from agvnav.actuators.scalar import ScalarSpeedLoop
from agvnav.kinematics.scalar import track_twist
from agvnav.kinematics.twist import twist_pose
from agvnav.odometry.scalar import track_increments
from agvnav.sensors.encoders import WheelEncoder, wheel_count
from agvnav.vehicles.geometry import UnicycleGeometry, check_footprint
from agvnav.vehicles.motion import SubstepTrajectory

__all__ = ["WheelPairPlant"]


def _twist_rows(name: str, matrix: ArrayLike) -> list[list[float]]:
    """A finite ``(3, 2)`` twist matrix as nested Python floats (the scalar fast paths' form)."""
    m = np.asarray(matrix, dtype=np.float64)
    if m.shape != (3, 2) or not np.all(np.isfinite(m)):
        raise ValueError(f"{name} must be a finite (3, 2) matrix, got shape {m.shape}")
    return [[float(v) for v in row] for row in m.tolist()]


class WheelPairPlant(SubstepTrajectory, ABC):
    """Speed loops, constant-twist sub-steps, two wheel encoders and nominal odometry; see the module docstring.

    Subclasses implement :meth:`_ground_speeds` and :meth:`_begin_step` (per-step
    randomness, if any). Plant role: ``family = "unicycle"``, command the wheel or
    sprocket rate set-points ``(omega_right, omega_left)`` (rad/s).

    Parameters
    ----------
    loop : the :class:`~agvnav.actuators.WheelSpeedLoop` (parameters and state copied).
    encoder : the :class:`~agvnav.sensors.encoders.WheelEncoder` model of both sides (nominal radius).
    true_twist, nominal_twist : twist matrices ``(3, 2)`` of the truth and of the odometry.
    initial_pose : true base_link pose ``[x, y, heading]`` (m, rad).
    substep : speed-loop period (s), > 0.
    geometry : the nominal :class:`UnicycleGeometry`. footprint : body polygon ``(k, 2)`` (m).
    """

    family: ClassVar[str] = "unicycle"
    signal_names: tuple[str, ...] = (
        "x", "y", "psi", "omega_right", "omega_left", "v", "yaw_rate", "odo_dd", "odo_dtheta", "distance",
    )

    def __init__(
        self,
        loop: WheelSpeedLoop,
        encoder: WheelEncoder,
        true_twist: ArrayLike,
        nominal_twist: ArrayLike,
        initial_pose: Sequence[float],
        substep: float,
        geometry: UnicycleGeometry,
        footprint: ArrayLike,
    ) -> None:
        if not (math.isfinite(substep) and substep > 0):
            raise ValueError(f"substep must be a positive number of seconds, got {substep!r}")
        self.speed_loop = ScalarSpeedLoop(loop)
        self.encoder = encoder
        self.substep = float(substep)
        self.geometry = geometry
        self.footprint = check_footprint(footprint)
        self._T = _twist_rows("true_twist", true_twist)
        self._To = _twist_rows("nominal_twist", nominal_twist)
        self._start_trajectory(np.asarray(initial_pose, dtype=np.float64), self.substep)
        self._angle = [0.0, 0.0]  # true wheel/sprocket rotations (rad)
        self._counts = [0, 0]
        self._odo = (0.0, 0.0, 0.0)
        self._v = self._w = 0.0
        self.distance = 0.0

    def failure(self) -> str | None:
        """No physical failure ends a run of a two-sided base: always None."""
        return None

    @abstractmethod
    def _begin_step(self, setpoint: tuple[float, float], dt: float, rng: np.random.Generator) -> None:
        """Draw the truth model's per-step randomness for set-points (rad/s) held ``dt`` s, if it has any."""

    @abstractmethod
    def _ground_speeds(self, wr: float, wl: float, h: float, rng: np.random.Generator) -> tuple[float, float]:
        """True ground speeds ``(v_R, v_L)`` (m/s) of sides turning at ``wr``, ``wl`` (rad/s) for ``h`` s."""

    def advance(self, command: Sequence[float], t0: float, dt: float, rng: np.random.Generator) -> None:
        """Hold rate set-points ``(omega_right, omega_left)`` (rad/s) from ``t0`` (s) for ``dt`` s."""
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
        n = max(1, round(dt / self.substep))
        h = dt / n
        sp = (float(command[0]), float(command[1]))
        self._begin_step(sp, dt, rng)
        x, y, th = self._pose
        states, twists = [(x, y, th)], []
        dist = 0.0
        for _ in range(n):
            vx, vy, w = self._substep_twist(sp, h, rng)
            x, y, th = twist_pose(x, y, th, vx, vy, w, h)
            states.append((x, y, th))
            twists.append((vx, vy, w))
            dist += math.hypot(vx, vy) * h
        self._record_step(t0, h, states, twists)
        self._v, self._w = twists[-1][0], twists[-1][2]
        self.distance += dist
        self._odo = self._odometry_increment()

    def _substep_twist(self, setpoint: tuple[float, float], h: float, rng: np.random.Generator) -> tuple[float, ...]:
        """Speed loop for ``h`` s, rotations (trapezoidal), true ground speeds, body twist."""
        loop = self.speed_loop
        w0 = loop.omega[0], loop.omega[1]
        w1 = loop.step(setpoint, h)
        wr, wl = 0.5 * (w0[0] + w1[0]), 0.5 * (w0[1] + w1[1])
        self._angle[0] += wr * h
        self._angle[1] += wl * h
        v_r, v_l = self._ground_speeds(wr, wl, h, rng)
        return track_twist(v_r, v_l, self._T)

    def _odometry_increment(self) -> tuple[float, float, float]:
        """Nominal ``(ΔD, Δθ, Δlateral)`` from the quantised counts [seed002 eq16] [seed004 eq3] [seed004 eq4]."""
        res, radius = self.encoder.angle_resolution, self.encoder.wheel_radius
        ds = []
        for i in (0, 1):
            c = wheel_count(self._angle[i], res)
            ds.append((c - self._counts[i]) * res * radius)
            self._counts[i] = c
        dd, dth = track_increments(ds[0], ds[1], self._To)
        t1 = self._To[1]
        return dd, dth, t1[0] * ds[0] + t1[1] * ds[1]

    def odometry(self) -> tuple[float, float, float]:
        """``(delta_d, delta_theta, delta_lateral)`` of base_link over the last step (m, rad, m), nominal model."""
        return self._odo

    def signals(self) -> tuple[float, ...]:
        """Values in ``signal_names`` order (m, rad, rad/s, m/s, rad/s, m, rad, m)."""
        x, y, th = self._pose
        w = self.speed_loop.omega
        return (x, y, th, w[0], w[1], self._v, self._w, self._odo[0], self._odo[1], self.distance)
