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

Speed loop, sub-steps (10 ms), constant-twist motion with an exact ``pose_at``,
sprocket encoders and odometry are those of
:class:`agvnav.vehicles.wheel_pair.WheelPairPlant`, shared with the differential
drive; the tracked robot adds the ICR terrain (its twist matrices) and the random
track slip drawn once per engine step.

Moved from ``agvnav.sim.tracked`` with its arithmetic unchanged (seeded runs stay
bit-identical); new are ``family``, ``geometry``, ``footprint``, ``failure`` and the
3-tuple odometry.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from agvnav.actuators import WheelSpeedLoop
from agvnav.kinematics.tracked import TrackedVehicle, TrackSlipNoise, TrackTerrain
from agvnav.sensors.encoders import WheelEncoder
from agvnav.vehicles.geometry import UnicycleGeometry, box_footprint
from agvnav.vehicles.wheel_pair import WheelPairPlant

__all__ = ["TrackedPlant"]


class TrackedPlant(WheelPairPlant):
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
        self.vehicle = vehicle
        self.r = float(vehicle.sprocket_radius)
        self.odometry_model = TrackedVehicle(vehicle.gauge, self.r, odometry_terrain)
        self.counts_per_rev = int(counts_per_rev)
        self.slip_noise_std = float(slip_noise_std)
        self.slip_noise = TrackSlipNoise(self.slip_noise_std)
        self._noise = (1.0, 1.0)
        half_w = max(0.20, 0.5 * float(vehicle.gauge) + 0.035)
        super().__init__(
            loop,
            WheelEncoder(counts_per_rev, self.r),
            vehicle.twist_matrix,
            self.odometry_model.twist_matrix,
            initial_pose,
            substep,
            UnicycleGeometry(float(vehicle.gauge), self.r),
            box_footprint(0.25, 0.25, half_w) if footprint is None else footprint,
        )

    def _begin_step(self, setpoint: tuple[float, float], dt: float, rng: np.random.Generator) -> None:
        """Random slip of the step: the faster sprocket's set-point distance sets its scale."""
        distance = max(abs(setpoint[0]), abs(setpoint[1])) * self.r * dt
        self._noise = self.slip_noise.factors_scalar(distance, rng)

    def _ground_speeds(self, wr: float, wl: float, h: float, rng: np.random.Generator) -> tuple[float, float]:
        """Track speeds ``r omega`` times the step's random slip factors (m/s); the ICR terrain is in ``T``."""
        return wr * self.r * self._noise[0], wl * self.r * self._noise[1]
