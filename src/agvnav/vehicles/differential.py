"""Differential-drive AGV: two driven wheels and castors (seed 002 §2, seed 003 §3.2.4) as a truth vehicle.

Composition: the seed-004 speed loop (:class:`agvnav.actuators.WheelSpeedLoop`,
PID + motor pair, through its scalar fast path) turns the wheel-rate set-points
into wheel rotations; the *true* wheel radii and track come from
:class:`agvnav.odometry.SystematicErrors` (Borenstein and Feng's ``E_d``, ``E_b``
and a misalignment of the rolling direction), random wheel slip and bumps from
:class:`agvnav.odometry.NonSystematicErrors`; two quantising
:class:`agvnav.sensors.encoders.WheelEncoder` count the wheel rotations and the
odometry converts them with the *nominal* geometry (seed 002 eq. 16).

Motion: the sub-stepped speed loop, constant-twist sub-steps (exact ``pose_at``),
encoders and odometry of :class:`agvnav.vehicles.wheel_pair.WheelPairPlant`.

``axle_offset``: base_link may lie ``a`` m ahead of the axle midpoint (a body-centred
AGV whose castors carry the other end). A rigid body's point ``a`` ahead of the axle
moves with ``v_y = a omega`` besides the axle's ``v_x`` (seed 003 §3.2.4, velocity of
a body point), so both twist matrices gain ``a`` times their heading row in the
lateral row, and the odometry reports ``delta_lateral = a delta_theta``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from agvnav.actuators import WheelSpeedLoop
from agvnav.odometry.errors import DifferentialGeometry, NonSystematicErrors, SystematicErrors
from agvnav.sensors.encoders import WheelEncoder
from agvnav.vehicles.geometry import UnicycleGeometry, box_footprint
from agvnav.vehicles.motion import differential_twist_matrix
from agvnav.vehicles.wheel_pair import WheelPairPlant

__all__ = ["DifferentialPlant"]


def _offset(twist: list[list[float]], a: float) -> list[list[float]]:
    """The twist matrix of the body point ``a`` m ahead of the axle midpoint: ``v_y += a omega``."""
    vx, vy, w = twist
    return [vx, [vy[0] + a * w[0], vy[1] + a * w[1]], w]


class DifferentialPlant(WheelPairPlant):
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
    axle_offset : base_link's distance ahead of the axle midpoint (m; negative: behind), default 0.

    Plant role: ``family = "unicycle"``, command ``(omega_right, omega_left)``
    wheel-rate set-points (rad/s), ``geometry = UnicycleGeometry(track, wheel_radius)``;
    ``delta_lateral`` of the odometry is ``axle_offset * delta_theta`` (0 on the axle).
    """

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
        axle_offset: float = 0.0,
    ) -> None:
        if not math.isfinite(axle_offset):
            raise ValueError(f"axle_offset must be a finite number of metres, got {axle_offset!r}")
        self.axle_offset = float(axle_offset)
        self.nominal = DifferentialGeometry.symmetric(wheel_radius, track)
        self.systematic = systematic if systematic is not None else SystematicErrors()
        self.nonsystematic = nonsystematic if nonsystematic is not None else NonSystematicErrors()
        self.truth = self.systematic.true_geometry(self.nominal)
        default = box_footprint(0.5 * track, 0.5 * track, 0.5 * track + 0.5 * wheel_radius)
        super().__init__(
            loop if loop is not None else WheelSpeedLoop(),
            WheelEncoder(counts_per_rev, wheel_radius),
            _offset(differential_twist_matrix(self.truth.track, self.systematic.misalignment), axle_offset),
            _offset(differential_twist_matrix(self.nominal.track), axle_offset),
            initial_pose,
            substep,
            UnicycleGeometry(float(track), float(wheel_radius)),
            default if footprint is None else footprint,
        )

    def _begin_step(self, setpoint: tuple[float, float], dt: float, rng: np.random.Generator) -> None:
        """Nothing per step: slip and bumps are drawn per sub-step in :meth:`_ground_speeds`."""
        return

    def _ground_speeds(self, wr: float, wl: float, h: float, rng: np.random.Generator) -> tuple[float, float]:
        """True wheel ground speeds (m/s): true radii, then slip and bumps on the sub-step's roll (seed 002 §3.1)."""
        ns, g = self.nonsystematic, self.truth
        return ns.perturb_scalar(wr * h * g.radius_right, rng) / h, ns.perturb_scalar(wl * h * g.radius_left, rng) / h
