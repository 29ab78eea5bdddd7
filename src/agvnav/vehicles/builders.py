"""The plant builder of every vehicle kind: a validated ``vehicle:`` spec -> its truth vehicle (Plant role).

One builder per spec class (:data:`agvnav.world.vehicle_specs.VEHICLE_KINDS`, the kinds'
registry) turns the spec into a plant of this package with its actuators, encoders and
truth errors, starting at a given true state. A new vehicle kind is its spec class, its
plant (or an existing one) and one entry in :data:`PLANT_BUILDERS`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.actuators import PID, MotorPair, SteeringActuator, WheelSpeedLoop
from agvnav.kinematics import MecanumBase, TrackedVehicle, TrackTerrain, TractorTrailer, terrain_preset
from agvnav.odometry import NonSystematicErrors, SystematicErrors, TricycleErrors
from agvnav.vehicles.differential import DifferentialPlant
from agvnav.vehicles.geometry import box_footprint
from agvnav.vehicles.mecanum import MecanumPlant
from agvnav.vehicles.steered import SteeredPlant
from agvnav.vehicles.tracked import TrackedPlant
from agvnav.vehicles.tractor_trailer import TractorTrailerPlant
from agvnav.vehicles.tricycle import TricyclePlant
from agvnav.world.vehicle_specs import (
    AckermannSpec,
    DifferentialOffsetSpec,
    DifferentialSpec,
    MecanumSpec,
    MotorSpec,
    PidSpec,
    QuadSteerSpec,
    SteeredVehicleSpec,
    SteeringSpec,
    TerrainFigures,
    TrackedSpec,
    TractorTrailerSpec,
    TricycleRearSpec,
    TricycleSpec,
    VehicleKindSpec,
    WheeledVehicleSpec,
)

__all__ = [
    "PLANT_BUILDERS",
    "Plant",
    "build_plant",
    "footprint",
    "speed_loop",
    "steering_actuator",
    "terrain",
]

def steering_actuator(spec: SteeringSpec) -> SteeringActuator:
    """The servo of a steered vehicle (rate and angle limits, first-order lag)."""
    return SteeringActuator(
        max_angle=math.radians(spec.max_angle_deg) - (1e-9 if spec.max_angle_deg >= 90.0 else 0.0),
        max_rate=math.radians(spec.max_rate_deg_s),
        tau=spec.time_constant_s,
    )


def _steered_errors(spec: SteeredVehicleSpec) -> tuple[TricycleErrors, NonSystematicErrors]:
    tr = spec.truth
    systematic = TricycleErrors(
        radius_scale=1.0 + tr.wheel_radius_error,
        wheelbase_scale=1.0 + tr.wheelbase_error,
        steering_offset=math.radians(tr.steering_offset_deg),
    )
    return systematic, NonSystematicErrors(slip_k=tr.slip_std**2, steering_std=math.radians(tr.steering_noise_std_deg))


def footprint(spec: SteeredVehicleSpec | WheeledVehicleSpec | MecanumSpec | TrackedSpec) -> NDArray[np.float64]:
    """The body polygon in base_link (m) from ``body_length_m``/``body_width_m``.

    Steered vehicles: 15 % of the length behind O (an assumption), the rest ahead;
    the others: centred on base_link.
    """
    half = 0.5 * spec.body_width_m
    if spec.family == "steered":
        return box_footprint(0.85 * spec.body_length_m, 0.15 * spec.body_length_m, half)
    return box_footprint(0.5 * spec.body_length_m, 0.5 * spec.body_length_m, half)


def _steered_args(spec: SteeredVehicleSpec, state: Sequence[float]) -> tuple[Any, ...]:
    """The positional arguments both steered plants share: geometry, encoders, servo, errors, state."""
    systematic, nonsystematic = _steered_errors(spec)
    return (
        spec.wheelbase_m,
        spec.drive_wheel_radius_m,
        spec.traction_counts_per_rev,
        spec.steering_counts_per_rev,
        steering_actuator(spec.steering),
        systematic,
        nonsystematic,
        state,
    )


def _tricycle(spec: TricycleSpec, state: Sequence[float]) -> TricyclePlant:
    return TricyclePlant(*_steered_args(spec, state), footprint=footprint(spec))


def _steered_rear(spec: TricycleRearSpec | AckermannSpec, state: Sequence[float]) -> SteeredPlant:
    return SteeredPlant(
        spec.model, *_steered_args(spec, state), track=getattr(spec, "track_m", None), footprint=footprint(spec)
    )


def _quad_steer(spec: QuadSteerSpec, state: Sequence[float]) -> SteeredPlant:
    """The Ackermann equivalent of a counter-phase quad-steer vehicle: wheelbase L/2, base_link at the centre."""
    half = 0.5 * spec.body_length_m
    args = list(_steered_args(spec, state))
    args[0] = 0.5 * spec.wheelbase_m
    return SteeredPlant("ackermann", *args, track=spec.track_m,
                        footprint=box_footprint(half, half, 0.5 * spec.body_width_m))


def speed_loop(motor: MotorSpec, pid: PidSpec) -> WheelSpeedLoop:
    """Seed 004's PID speed loops on a motor pair, from the scenario's motor and PID specs."""
    return WheelSpeedLoop(
        MotorPair(
            tau=motor.time_constant_s,
            gain=(motor.no_load_rpm * 2.0 * math.pi / 60.0) / motor.supply_v,
            asymmetry=motor.asymmetry,
            u_max=motor.supply_v,
        ),
        PID(kp=pid.kp, ki=pid.ki, kd=pid.kd, derivative_tau=pid.derivative_time_constant_s,
            u_min=-motor.supply_v, u_max=motor.supply_v, size=2),
    )


def _differential(spec: WheeledVehicleSpec, state: Sequence[float], axle_offset: float = 0.0) -> DifferentialPlant:
    tr = spec.truth
    return DifferentialPlant(
        spec.wheel_radius_m * (1.0 + tr.wheel_radius_error),
        spec.track_m,
        spec.encoder_counts_per_rev,
        state[:3],
        speed_loop(spec.motor, spec.pid),
        SystematicErrors(e_d=tr.wheel_diameter_ratio, e_b=tr.track_ratio),
        NonSystematicErrors(slip_k=tr.slip_k),
        spec.substep_s,
        footprint=footprint(spec),
        axle_offset=axle_offset,
    )


def _differential_offset(spec: DifferentialOffsetSpec, state: Sequence[float]) -> DifferentialPlant:
    """A differential plant whose base_link (the body centre) is ``axle_offset_m`` ahead of the axle."""
    return _differential(spec, state, spec.axle_offset_m)


def _tractor_trailer(spec: TractorTrailerSpec, state: Sequence[float]) -> TractorTrailerPlant:
    trailer = TractorTrailer(spec.trailer_length_m, spec.hitch_offset_m, math.radians(spec.max_hitch_angle_deg))
    return TractorTrailerPlant(_differential(spec, state), trailer, 0.0)


def _mecanum(spec: MecanumSpec, state: Sequence[float]) -> MecanumPlant:
    base = MecanumBase(spec.wheel_radius_m, spec.half_length_m, spec.half_width_m, spec.layout)
    scale = 1.0 + spec.truth.wheel_radius_error
    loop = speed_loop(spec.motor, spec.pid)
    return MecanumPlant(
        base, spec.encoder_counts_per_rev, state[:3], loop, (scale,) * 4, spec.truth.roller_slip_std,
        substep=spec.substep_s, footprint=footprint(spec),
    )


def terrain(ref: str | TerrainFigures) -> TrackTerrain:
    """A track-ground terrain from a preset name or explicit figures."""
    if isinstance(ref, TerrainFigures):
        return TrackTerrain(ref.slip_left, ref.slip_right, ref.icr_left, ref.icr_right, ref.x_icr_m, "scenario")
    return terrain_preset(ref)


def _tracked(spec: TrackedSpec, state: Sequence[float]) -> TrackedPlant:
    vehicle = TrackedVehicle(spec.gauge_m, spec.sprocket_radius_m, terrain(spec.terrain.truth))
    return TrackedPlant(
        vehicle,
        speed_loop(spec.motor, spec.pid),
        terrain(spec.terrain.odometry),
        spec.encoder_counts_per_rev,
        state[:3],
        spec.substep_s,
        spec.terrain.slip_noise_std,
        footprint=footprint(spec),
    )


#: The truth vehicles a builder returns (each implements the engine's Plant role).
Plant = TricyclePlant | SteeredPlant | DifferentialPlant | TractorTrailerPlant | MecanumPlant | TrackedPlant

#: A builder takes its own spec class (Any here: a Callable's parameter cannot narrow per dict entry).
PlantBuilder = Callable[[Any, Sequence[float]], Plant]

#: One builder per vehicle kind (spec class): ``(vehicle spec, true initial state) -> Plant``.
PLANT_BUILDERS: dict[type[VehicleKindSpec], PlantBuilder] = {
    TricycleSpec: _tricycle,
    TricycleRearSpec: _steered_rear,
    AckermannSpec: _steered_rear,
    QuadSteerSpec: _quad_steer,
    DifferentialSpec: _differential,
    DifferentialOffsetSpec: _differential_offset,
    TractorTrailerSpec: _tractor_trailer,
    MecanumSpec: _mecanum,
    TrackedSpec: _tracked,
}


def build_plant(spec: VehicleKindSpec, state: Sequence[float]) -> Plant:
    """The truth vehicle of ``spec`` (any vehicle spec) starting at ``state`` (pose, plus steering angle)."""
    try:
        builder = PLANT_BUILDERS[type(spec)]
    except KeyError:
        raise ValueError(f"no plant builder for vehicle spec {type(spec).__name__}") from None
    return builder(spec, state)
