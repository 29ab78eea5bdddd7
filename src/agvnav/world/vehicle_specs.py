"""The ``vehicle:`` section of a scenario: one spec per configuration, discriminated by ``model``.

Every spec holds the *nominal* vehicle (what odometry and guidance believe),
its actuators, encoders and ``truth`` (how the real vehicle differs from the
nominal one). Lengths in m, angles in degrees (keys ``*_deg``), times in s.
The union :data:`VehicleSpec` is discriminated on ``model``; an unknown model
name is refused with the list of valid ones.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from agvnav.world.strict import Finite, NonNegFloat, PosFloat, StrictModel

__all__ = [
    "VEHICLE_MODELS",
    "AckermannSpec",
    "DifferentialSpec",
    "DifferentialTruthSpec",
    "MecanumSpec",
    "MecanumTruthSpec",
    "MotorSpec",
    "PidSpec",
    "SteeredTruthSpec",
    "SteeredVehicleSpec",
    "SteeringSpec",
    "TerrainFigures",
    "TerrainSpec",
    "TrackedSpec",
    "TractorTrailerSpec",
    "TricycleRearSpec",
    "TricycleSpec",
    "VehicleSpec",
    "WheeledVehicleSpec",
]

Fraction = Annotated[float, Field(ge=0.0, lt=1.0)]
RelativeError = Annotated[float, Field(gt=-0.5, lt=0.5)]
Counts = Annotated[int, Field(gt=0)]


class SteeringSpec(StrictModel):
    """Steering servo: rate and angle limits, first-order lag."""

    max_rate_deg_s: PosFloat = 60.0
    max_angle_deg: Annotated[float, Field(gt=0.0, le=90.0)] = 90.0
    time_constant_s: NonNegFloat = 0.05


class SteeredTruthSpec(StrictModel):
    """How a steered vehicle differs from its nominal model (odometry error sources).

    ``wheel_radius_error``: relative error of the driven wheel radius (truth =
    nominal x (1 + e)); ``wheelbase_error``: relative error of L;
    ``steering_offset_deg``: the wheel points this much off what the steering
    encoder reads; ``slip_std``: random relative error of each traction
    increment; ``steering_noise_std_deg``: random steering error per step.
    """

    wheel_radius_error: RelativeError = 0.0
    wheelbase_error: RelativeError = 0.0
    steering_offset_deg: Annotated[float, Field(ge=-10.0, le=10.0)] = 0.0
    slip_std: NonNegFloat = 0.0
    steering_noise_std_deg: NonNegFloat = 0.0


class SteeredVehicleSpec(StrictModel):
    wheelbase_m: PosFloat = 1.2
    drive_wheel_radius_m: PosFloat = 0.1
    traction_counts_per_rev: Counts = 4096
    steering_counts_per_rev: Counts = 16384
    body_length_m: PosFloat = 1.6
    body_width_m: PosFloat = 0.9
    steering: SteeringSpec = SteeringSpec()
    truth: SteeredTruthSpec = SteeredTruthSpec()


class TricycleSpec(SteeredVehicleSpec):
    """Seed-000 tricycle stacker (seed 003 model B): the front wheel C drives and steers; base_link is O."""

    model: Literal["tricycle"] = "tricycle"


class TricycleRearSpec(SteeredVehicleSpec):
    """Seed 003 model A: steered front wheel, driven rear axle (tow tractors); base_link is the rear axle O."""

    model: Literal["tricycle_rear"]


class AckermannSpec(SteeredVehicleSpec):
    """Seed 003 §3.2.6: car-like, rear drive, bicycle equivalent; ``track_m`` between the front wheels."""

    model: Literal["ackermann"]
    track_m: PosFloat = 0.6
    steering: SteeringSpec = SteeringSpec(max_angle_deg=35.0)


class MotorSpec(StrictModel):
    """Wheel gearmotors: first-order lag, ``asymmetry`` = right minus left relative gain.

    ``no_load_rpm``: output shaft speed at ``supply_v`` (seed 004's gearmotors: 45 rpm at 12 V).
    """

    time_constant_s: PosFloat = 0.1
    asymmetry: Annotated[float, Field(gt=-1.0, lt=1.0)] = 0.0
    supply_v: PosFloat = 12.0
    no_load_rpm: PosFloat = 45.0


class PidSpec(StrictModel):
    """Speed PID per motor (seed 004: Kp = 10, Ki = 20, Kd = 0.5)."""

    kp: NonNegFloat = 10.0
    ki: NonNegFloat = 20.0
    kd: NonNegFloat = 0.5
    derivative_time_constant_s: NonNegFloat = 0.02


class DifferentialTruthSpec(StrictModel):
    """Seed 002 / UMBmark error sources of a differential drive.

    ``wheel_diameter_ratio`` E_d (right over left truth diameter), ``track_ratio``
    E_b (true over nominal track), ``wheel_radius_error`` (mean radius, relative),
    ``slip_k`` (variance of the random slip per metre rolled, m).
    """

    wheel_diameter_ratio: Annotated[float, Field(gt=0.5, lt=1.5)] = 1.0
    track_ratio: Annotated[float, Field(gt=0.5, lt=1.5)] = 1.0
    wheel_radius_error: RelativeError = 0.0
    slip_k: NonNegFloat = 0.0


class WheeledVehicleSpec(StrictModel):
    track_m: PosFloat = 0.5
    wheel_radius_m: PosFloat = 0.08
    encoder_counts_per_rev: Counts = 4096
    body_length_m: PosFloat = 0.9
    body_width_m: PosFloat = 0.6
    motor: MotorSpec = MotorSpec(no_load_rpm=150.0)
    #: gains for the faster AGV motor (3.3x seed 004's speed per volt): seed 004's Kd oscillates at 10 ms
    pid: PidSpec = PidSpec(kp=3.0, ki=6.0, kd=0.0)
    substep_s: Annotated[float, Field(gt=0.0, le=0.05)] = 0.01
    truth: DifferentialTruthSpec = DifferentialTruthSpec()


class DifferentialSpec(WheeledVehicleSpec):
    """Two driven wheels plus castors (seed 002, seed 003 §3.2.4): the common AGV/AMR."""

    model: Literal["differential"]


class TractorTrailerSpec(WheeledVehicleSpec):
    """A differential tugger with one off-axle trailer (seed 003 §3.2.7).

    ``trailer_length_m``: hitch to trailer axle D; ``hitch_offset_m``: tractor axle
    to hitch d (behind); beyond ``max_hitch_angle_deg`` the run ends as a jackknife.
    """

    model: Literal["tractor_trailer"]
    trailer_length_m: PosFloat = 1.5
    hitch_offset_m: NonNegFloat = 0.4
    max_hitch_angle_deg: Annotated[float, Field(gt=0.0, lt=180.0)] = 60.0
    trailer_width_m: PosFloat = 0.8


class MecanumTruthSpec(StrictModel):
    """Wheel radius error (relative, common) and random roller slip (relative std per step)."""

    wheel_radius_error: RelativeError = 0.0
    roller_slip_std: NonNegFloat = 0.0


class MecanumSpec(StrictModel):
    """Four Swedish (mecanum) wheels, holonomic (seed 003 §3.2.5)."""

    model: Literal["mecanum"]
    wheel_radius_m: PosFloat = 0.076
    half_length_m: PosFloat = 0.3
    half_width_m: PosFloat = 0.25
    layout: Literal["X", "O"] = "X"
    encoder_counts_per_rev: Counts = 4096
    motor: MotorSpec = MotorSpec(no_load_rpm=150.0, time_constant_s=0.08)
    pid: PidSpec = PidSpec(kp=3.0, ki=6.0, kd=0.0)
    substep_s: Annotated[float, Field(gt=0.0, le=0.05)] = 0.01
    body_length_m: PosFloat = 0.8
    body_width_m: PosFloat = 0.65
    truth: MecanumTruthSpec = MecanumTruthSpec()


class TerrainFigures(StrictModel):
    """Explicit track-ground figures (see :class:`agvnav.kinematics.tracked.TrackTerrain`)."""

    slip_left: Fraction = 0.0
    slip_right: Fraction = 0.0
    icr_left: PosFloat = 1.0
    icr_right: PosFloat = 1.0
    x_icr_m: Finite = 0.0


TerrainRef = Literal["ideal", "concrete", "artificial_grass"] | TerrainFigures


class TerrainSpec(StrictModel):
    """Truth terrain and what odometry believes; ``slip_noise_std``: m of random slip per metre rolled."""

    truth: TerrainRef = "concrete"
    odometry: TerrainRef = "concrete"
    slip_noise_std: NonNegFloat = 0.0


class TrackedSpec(StrictModel):
    """Seed-004 tracked robot (45 x 40 cm body; gauge and sprocket radius are assumptions)."""

    model: Literal["tracked"]
    gauge_m: PosFloat = 0.33
    sprocket_radius_m: PosFloat = 0.05
    body_length_m: PosFloat = 0.45
    body_width_m: PosFloat = 0.40
    encoder_counts_per_rev: Counts = 1440
    motor: MotorSpec = MotorSpec()
    pid: PidSpec = PidSpec()
    substep_s: Annotated[float, Field(gt=0.0, le=0.05)] = 0.01
    terrain: TerrainSpec = TerrainSpec()

    @model_validator(mode="after")
    def _body_holds_tracks(self) -> TrackedSpec:
        if self.gauge_m >= self.body_width_m + 0.2:
            raise ValueError("gauge_m must not exceed the body width by more than 0.2 m")
        return self


VehicleSpec = Annotated[
    TricycleSpec | TricycleRearSpec | AckermannSpec | DifferentialSpec | TractorTrailerSpec | MecanumSpec | TrackedSpec,
    Field(discriminator="model"),
]

#: Every vehicle model a scenario may name, in the order the docs list them.
VEHICLE_MODELS: tuple[str, ...] = (
    "tricycle",
    "tricycle_rear",
    "ackermann",
    "differential",
    "tractor_trailer",
    "mecanum",
    "tracked",
)
