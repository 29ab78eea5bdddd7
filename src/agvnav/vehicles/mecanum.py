"""Omnidirectional base on four Swedish (mecanum) wheels (seed 003 §3.2.3) as a truth vehicle.

Composition: the commanded body twist ``(v_x, v_y, omega)`` goes through the
inverse kinematics of :class:`agvnav.kinematics.MecanumBase` to four wheel-rate
set-points; two seed-004 speed loops (:class:`agvnav.actuators.WheelSpeedLoop`
through its scalar fast path: front pair FL/FR, rear pair RL/RR) turn the wheels;
four quantising :class:`agvnav.sensors.encoders.WheelEncoder` count them.

Truth versus nominal: each wheel's true radius is ``radius_scales[i]`` times the
nominal one, each wheel's ground roll is slipped by
:class:`agvnav.odometry.NonSystematicErrors`, and the rollers lose a fraction
``roller_slip`` of the lateral speed. Four wheels over-determine the three body
speeds, so the true twist is the least-squares one of the true wheel ground
speeds (the wheels scrub the rest). The odometry applies the nominal forward
kinematics (the same least squares with the nominal radius) to the counted
rotations, which gives the body-twist integrals ``(∫v_x, ∫omega, ∫v_y)`` directly.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from agvnav.actuators import WheelSpeedLoop
from agvnav.actuators.scalar import ScalarSpeedLoop
from agvnav.kinematics.omnidirectional import MecanumBase
from agvnav.kinematics.twist import twist_pose
from agvnav.odometry.errors import NonSystematicErrors
from agvnav.sensors.encoders import WheelEncoder, wheel_count
from agvnav.vehicles.geometry import HolonomicGeometry, box_footprint, check_footprint
from agvnav.vehicles.motion import SubstepTrajectory

__all__ = ["MecanumPlant"]

WHEELS = ("fl", "fr", "rl", "rr")


class MecanumPlant(SubstepTrajectory):
    """Truth mecanum base: per-wheel speed loops, true radii, wheel and roller slip, encoders, nominal odometry.

    Parameters
    ----------
    base : the nominal :class:`~agvnav.kinematics.MecanumBase` (radius, a, b, layout); its
        layout must resolve the yaw rate (rank 3).
    counts_per_rev : encoder counts per wheel revolution, >= 1.
    initial_pose : true base_link (centre) pose ``[x, y, heading]`` (m, rad).
    loop : :class:`~agvnav.actuators.WheelSpeedLoop` whose parameters and state both
        wheel pairs copy (default the seed-004 loop).
    radius_scales : true / nominal radius per wheel ``(4,)`` (FL, FR, RL, RR), > 0.
    roller_slip : fraction of the lateral body speed the rollers lose, in [0, 1).
    nonsystematic : random slip and bumps of each wheel's ground roll (default none),
        drawn per sub-step in wheel order.
    substep : speed-loop period (s), > 0.
    footprint : body polygon ``(k, 2)`` (m, base_link); default a box reaching one
        wheel radius beyond the axles and half a radius beyond the wheel contacts.

    Plant role: ``family = "holonomic"``, command the body twist ``(v_x, v_y, omega)``
    (m/s, m/s, rad/s); ``geometry = HolonomicGeometry(r, a, b)``.
    """

    family: ClassVar[str] = "holonomic"
    signal_names: tuple[str, ...] = (
        "x", "y", "psi", *(f"omega_{w}" for w in WHEELS), "v_x", "v_y", "yaw_rate",
        "odo_dd", "odo_dtheta", "odo_dlat", "distance",
    )

    def __init__(
        self,
        base: MecanumBase,
        counts_per_rev: int,
        initial_pose: Sequence[float],
        loop: WheelSpeedLoop | None = None,
        radius_scales: Sequence[float] = (1.0, 1.0, 1.0, 1.0),
        roller_slip: float = 0.0,
        nonsystematic: NonSystematicErrors | None = None,
        substep: float = 0.01,
        *,
        footprint: ArrayLike | None = None,
    ) -> None:
        if base.rank < 3:
            raise ValueError(f"base layout {base.layout!r} with a == b cannot resolve the yaw rate (rank {base.rank})")
        scales = np.asarray(radius_scales, dtype=np.float64).reshape(-1)
        if scales.shape != (4,) or not np.all(np.isfinite(scales) & (scales > 0.0)):
            raise ValueError(f"radius_scales must be 4 positive factors (FL, FR, RL, RR), got {radius_scales!r}")
        if not (math.isfinite(roller_slip) and 0.0 <= roller_slip < 1.0):
            raise ValueError(f"roller_slip must be in [0, 1), got {roller_slip!r}")
        if not (math.isfinite(substep) and substep > 0.0):
            raise ValueError(f"substep must be a positive number of seconds, got {substep!r}")
        self.base = base
        r = base.wheel_radius
        self.true_radii = [float(s) * r for s in scales]
        self.roller_slip = float(roller_slip)
        self.nonsystematic = nonsystematic if nonsystematic is not None else NonSystematicErrors()
        self.encoders = tuple(WheelEncoder(counts_per_rev, r) for _ in WHEELS)
        source = loop if loop is not None else WheelSpeedLoop()
        self.loops = (ScalarSpeedLoop(source), ScalarSpeedLoop(source))
        self.substep = float(substep)
        self.geometry = HolonomicGeometry(r, base.half_length, base.half_width)
        default = box_footprint(base.half_length + r, base.half_length + r, base.half_width + 0.5 * r)
        self.footprint = check_footprint(default if footprint is None else footprint)
        # least squares from wheel ground speeds (m/s) to the body twist: pinv of the r = 1 inverse kinematics
        self._P = np.linalg.pinv(base.inverse_matrix * r).tolist()
        self._start_trajectory(np.asarray(initial_pose, dtype=np.float64), self.substep)
        self._angle = [0.0] * 4
        self._counts = [0] * 4
        self._odo = (0.0, 0.0, 0.0)
        self._twist = (0.0, 0.0, 0.0)
        self.distance = 0.0

    @property
    def wheel_rates(self) -> tuple[float, float, float, float]:
        """True wheel rates now ``(FL, FR, RL, RR)`` (rad/s)."""
        f, r = self.loops[0].omega, self.loops[1].omega
        return f[0], f[1], r[0], r[1]

    def failure(self) -> str | None:
        """No physical failure ends a mecanum run: always None."""
        return None

    def _twist_of(self, ground: Sequence[float]) -> tuple[float, float, float]:
        """Least-squares body twist ``(v_x, v_y, omega)`` of four wheel ground speeds (m/s) [seed003 §3.2.3]."""
        p0, p1, p2 = self._P
        g0, g1, g2, g3 = ground
        return (
            p0[0] * g0 + p0[1] * g1 + p0[2] * g2 + p0[3] * g3,
            p1[0] * g0 + p1[1] * g1 + p1[2] * g2 + p1[3] * g3,
            p2[0] * g0 + p2[1] * g1 + p2[2] * g2 + p2[3] * g3,
        )

    def advance(self, command: Sequence[float], t0: float, dt: float, rng: np.random.Generator) -> None:
        """Hold the body-twist set-point ``(v_x, v_y, omega)`` (m/s, m/s, rad/s) from ``t0`` for ``dt`` s."""
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
        rates = [float(v) for v in self.base.wheel_rates(np.asarray(command, dtype=np.float64).reshape(3))]
        n = max(1, round(dt / self.substep))
        h = dt / n
        x, y, th = self._pose
        states, twists = [(x, y, th)], []
        for _ in range(n):
            vx, vy, w = self._substep_twist(rates, h, rng)
            x, y, th = twist_pose(x, y, th, vx, vy, w, h)
            states.append((x, y, th))
            twists.append((vx, vy, w))
            self.distance += math.hypot(vx, vy) * h
        self._record_step(t0, h, states, twists)
        self._twist = twists[-1]
        self._odo = self._odometry_increment()

    def _substep_twist(self, rates: list[float], h: float, rng: np.random.Generator) -> tuple[float, float, float]:
        """Speed loops for ``h`` s, wheel rotations (trapezoidal), true ground speeds, body twist."""
        mean = []
        for k, loop in enumerate(self.loops):
            w0 = loop.omega[0], loop.omega[1]
            w1 = loop.step((rates[2 * k], rates[2 * k + 1]), h)
            mean += [0.5 * (w0[0] + w1[0]), 0.5 * (w0[1] + w1[1])]
        ns = self.nonsystematic
        ground = []
        for i, wi in enumerate(mean):
            self._angle[i] += wi * h
            ground.append(ns.perturb_scalar(wi * h * self.true_radii[i], rng) / h)
        vx, vy, w = self._twist_of(ground)
        return vx, (1.0 - self.roller_slip) * vy, w

    def _odometry_increment(self) -> tuple[float, float, float]:
        """Nominal ``(∫v_x, ∫omega, ∫v_y)`` from the four counted rotations (nominal forward kinematics)."""
        ds = []
        for i, enc in enumerate(self.encoders):
            c = wheel_count(self._angle[i], enc.angle_resolution)
            ds.append((c - self._counts[i]) * enc.angle_resolution * enc.wheel_radius)
            self._counts[i] = c
        dx, dy, dth = self._twist_of(ds)
        return dx, dth, dy

    def odometry(self) -> tuple[float, float, float]:
        """``(delta_d, delta_theta, delta_lateral)`` of base_link over the last step (m, rad, m), nominal model."""
        return self._odo

    def signals(self) -> tuple[float, ...]:
        """Values in ``signal_names`` order (m, rad, rad/s, m/s, rad/s, m)."""
        x, y, th = self._pose
        return (x, y, th, *self.wheel_rates, *self._twist, *self._odo, self.distance)
