"""The ``vehicle:`` section of a scenario: one spec per configuration, discriminated by ``model``.

Every spec holds the *nominal* vehicle (what odometry and guidance believe),
its actuators, encoders and ``truth`` (how the real vehicle differs from the
nominal one). Lengths in m, angles in degrees (keys ``*_deg``), times in s.
The union :data:`VehicleSpec` is discriminated on ``model``; an unknown model
name is refused with the list of valid ones.
"""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal, get_args

from pydantic import Field, model_validator

from agvnav.world.strict import Finite, NonNegFloat, PosFloat, StrictModel

__all__ = [
    "VEHICLE_KINDS",
    "VEHICLE_MODELS",
    "AckermannSpec",
    "DifferentialOffsetSpec",
    "DifferentialSpec",
    "DifferentialTruthSpec",
    "Family",
    "MecanumSpec",
    "MecanumTruthSpec",
    "MotorSpec",
    "PidSpec",
    "QuadSteerSpec",
    "SteeredTruthSpec",
    "SteeredVehicleSpec",
    "SteeringSpec",
    "TerrainFigures",
    "TerrainSpec",
    "TrackedSpec",
    "TractorTrailerSpec",
    "TricycleRearSpec",
    "TricycleSpec",
    "VehicleKindSpec",
    "VehicleSpec",
    "WheeledVehicleSpec",
    "vehicle_kind",
]

#: The Plant contract's families (docs/ARCHITECTURE.md): what a vehicle's command is.
Family = Literal["steered", "unicycle", "holonomic"]


class VehicleKindSpec(StrictModel):
    """Base of every ``vehicle:`` spec: the spec class *is* the vehicle kind's registry entry.

    Besides its validated fields (nominal geometry, actuators, encoders, truth), a kind
    states here, once, the facts that the simulator, the route planner, the footprint and
    the benches read; nothing else lists vehicle names. The plant builder is registered
    against the spec class in :mod:`agvnav.vehicles.builders`.
    """

    family: ClassVar[Family]
    """the Plant contract's family: steered ``(v, steer_rate)``, unicycle wheel speeds, holonomic twist."""
    reverses: ClassVar[bool] = True
    """True when the vehicle may back up (a path or route may drive it in reverse)."""
    turns_on_spot: ClassVar[bool] = False
    """True when the vehicle turns at standstill (route planning turns it in place at a node)."""


Fraction = Annotated[float, Field(ge=0.0, lt=1.0)]
RelativeError = Annotated[float, Field(gt=-0.5, lt=0.5)]
Counts = Annotated[int, Field(gt=0)]


class SteeringSpec(StrictModel):
    """Steering servo: rate and angle limits, first-order lag."""

    max_rate_deg_s: PosFloat = 60.0
    """largest steering rate the servo reaches."""
    max_angle_deg: Annotated[float, Field(gt=0.0, le=90.0)] = 90.0
    """steering angle limit (either side)."""
    time_constant_s: NonNegFloat = 0.05
    """first-order lag of the servo (0: ideal)."""


class SteeredTruthSpec(StrictModel):
    """How a steered vehicle differs from its nominal model (odometry error sources).

    ``wheel_radius_error``: relative error of the driven wheel radius (truth =
    nominal x (1 + e)); ``wheelbase_error``: relative error of L;
    ``steering_offset_deg``: the wheel points this much off what the steering
    encoder reads; ``slip_std``: random relative error of each traction
    increment; ``steering_noise_std_deg``: random steering error per step.
    """

    wheel_radius_error: RelativeError = 0.0
    """relative error of the driven wheel radius: truth = nominal x (1 + e)."""
    wheelbase_error: RelativeError = 0.0
    """relative error of the wheelbase L."""
    steering_offset_deg: Annotated[float, Field(ge=-10.0, le=10.0)] = 0.0
    """the wheel points this much off what the steering encoder reads."""
    slip_std: NonNegFloat = 0.0
    """random traction slip: std of the distance error after 1 m rolled (relative, per sqrt(m))."""
    steering_noise_std_deg: NonNegFloat = 0.0
    """random steering angle error per step."""


class SteeredVehicleSpec(VehicleKindSpec):
    family: ClassVar[Family] = "steered"

    wheelbase_m: PosFloat = 1.2
    """L: rear axle midpoint O to the steered wheel centre C."""
    drive_wheel_radius_m: PosFloat = 0.1
    """nominal radius of the driven wheel (C for the stacker, the rear wheels otherwise)."""
    traction_counts_per_rev: Counts = 4096
    """traction encoder counts per wheel revolution."""
    steering_counts_per_rev: Counts = 16384
    """steering encoder counts per revolution."""
    body_length_m: PosFloat = 1.6
    """body length (footprint: 15 % of it behind O, the rest ahead)."""
    body_width_m: PosFloat = 0.9
    """body width (footprint, centred on the x-axis)."""
    steering: SteeringSpec = SteeringSpec()
    """the steering servo."""
    truth: SteeredTruthSpec = SteeredTruthSpec()
    """how the real vehicle differs from the nominal one."""


class TricycleSpec(SteeredVehicleSpec):
    """Seed-000 tricycle stacker (seed 003 model B): the front wheel C drives and steers; base_link is O."""

    model: Literal["tricycle"] = "tricycle"
    """vehicle model name."""


class TricycleRearSpec(SteeredVehicleSpec):
    """Seed 003 model A: steered front wheel, driven rear axle (tow tractors); base_link is the rear axle O."""

    model: Literal["tricycle_rear"]
    """vehicle model name."""


class AckermannSpec(SteeredVehicleSpec):
    """Seed 003 §3.2.6: car-like, rear drive, bicycle equivalent; ``track_m`` between the front wheels."""

    model: Literal["ackermann"]
    """vehicle model name."""
    track_m: PosFloat = 0.6
    """distance between the two steered front wheels."""
    steering: SteeringSpec = SteeringSpec(max_angle_deg=35.0)
    """the steering servo (angle of the bicycle-equivalent wheel)."""


class QuadSteerSpec(SteeredVehicleSpec):
    """Four-wheel counter-phase steering (front and rear wheels at equal and opposite angles).

    Its instantaneous centre of rotation lies on the lateral line through the body centre, so it
    moves exactly as a bicycle of wheelbase ``wheelbase_m / 2`` whose driven rear axle is the
    centre (seed 003 §3.2.6): it is simulated and guided as that Ackermann equivalent, base_link
    at the centre, steering angle that of the front wheels' bicycle equivalent; the traction
    encoder reads the centre's speed (a measuring wheel there, an assumption).
    """

    model: Literal["quad_steer"]
    """vehicle model name."""
    wheelbase_m: PosFloat = 1.6
    """front axle to rear axle (the Ackermann equivalent's wheelbase is half of it)."""
    track_m: PosFloat = 0.7
    """distance between the two wheels of an axle."""
    body_length_m: PosFloat = 2.0
    """body length (footprint centred on base_link, the body centre)."""
    steering: SteeringSpec = SteeringSpec(max_angle_deg=30.0)
    """the steering servo (front wheels' bicycle-equivalent angle; the rear ones mirror it)."""


class MotorSpec(StrictModel):
    """Wheel gearmotors: first-order lag, ``asymmetry`` = right minus left relative gain.

    ``no_load_rpm``: output shaft speed at ``supply_v`` (seed 004's gearmotors: 45 rpm at 12 V).
    """

    time_constant_s: PosFloat = 0.1
    """mechanical time constant of each gearmotor."""
    asymmetry: Annotated[float, Field(gt=-1.0, lt=1.0)] = 0.0
    """relative gain difference, right minus left motor."""
    supply_v: PosFloat = 12.0
    """supply voltage: the drivers saturate there."""
    no_load_rpm: PosFloat = 45.0
    """output shaft speed at the supply voltage without load."""


class PidSpec(StrictModel):
    """Speed PID per motor (seed 004: Kp = 10, Ki = 20, Kd = 0.5)."""

    kp: NonNegFloat = 10.0
    """proportional gain (V per rad/s)."""
    ki: NonNegFloat = 20.0
    """integral gain (V per rad)."""
    kd: NonNegFloat = 0.5
    """derivative gain (V per rad/s^2), on the measurement."""
    derivative_time_constant_s: NonNegFloat = 0.02
    """filter of the derivative term (0: none)."""


class DifferentialTruthSpec(StrictModel):
    """Seed 002 / UMBmark error sources of a differential drive.

    ``wheel_diameter_ratio`` E_d (right over left truth diameter), ``track_ratio``
    E_b (true over nominal track), ``wheel_radius_error`` (mean radius, relative),
    ``slip_k`` (variance of the random slip per metre rolled, m).
    """

    wheel_diameter_ratio: Annotated[float, Field(gt=0.5, lt=1.5)] = 1.0
    """E_d: right over left true wheel diameter (UMBmark)."""
    track_ratio: Annotated[float, Field(gt=0.5, lt=1.5)] = 1.0
    """E_b: true over nominal track."""
    wheel_radius_error: RelativeError = 0.0
    """relative error of the mean wheel radius."""
    slip_k: NonNegFloat = 0.0
    """random slip: variance of each wheel's distance per metre rolled (m^2/m)."""


class WheeledVehicleSpec(VehicleKindSpec):
    family: ClassVar[Family] = "unicycle"

    track_m: PosFloat = 0.5
    """distance between the two driven wheels' contact points."""
    wheel_radius_m: PosFloat = 0.08
    """nominal radius of the driven wheels."""
    encoder_counts_per_rev: Counts = 4096
    """wheel encoder counts per revolution."""
    body_length_m: PosFloat = 0.9
    """body length (footprint centred on base_link)."""
    body_width_m: PosFloat = 0.6
    """body width (footprint centred on base_link)."""
    motor: MotorSpec = MotorSpec(no_load_rpm=150.0)
    """the wheel gearmotors."""
    #: gains for the faster AGV motor (3.3x seed 004's speed per volt): seed 004's Kd oscillates at 10 ms
    pid: PidSpec = PidSpec(kp=3.0, ki=6.0, kd=0.0)
    """the wheel speed loops."""
    substep_s: Annotated[float, Field(gt=0.0, le=0.05)] = 0.01
    """period of the speed loops inside each control step."""
    truth: DifferentialTruthSpec = DifferentialTruthSpec()
    """how the real vehicle differs from the nominal one."""


class DifferentialSpec(WheeledVehicleSpec):
    """Two driven wheels plus castors (seed 002, seed 003 §3.2.4): the common AGV/AMR."""

    turns_on_spot: ClassVar[bool] = True
    model: Literal["differential"]
    """vehicle model name."""


class DifferentialOffsetSpec(WheeledVehicleSpec):
    """A differential AGV whose drive axle is off the body centre, castors carrying the other end.

    base_link is the body centre (where the footprint is centred and the goniometer
    mounts), ``axle_offset_m`` ahead of the drive axle's midpoint, so it moves sideways
    by ``axle_offset_m`` times the yaw rate (seed 003 §3.2.4). Turning at standstill
    swings base_link on a circle of that radius, so it does not turn in place at a node.
    """

    turns_on_spot: ClassVar[bool] = False  # base_link swings about the axle
    model: Literal["differential_offset"]
    """vehicle model name."""
    axle_offset_m: Annotated[float, Field(ge=-1.0, le=1.0)] = 0.2
    """base_link (body centre) ahead of the drive axle's midpoint (negative: behind)."""

    @model_validator(mode="after")
    def _axle_under_body(self) -> DifferentialOffsetSpec:
        if abs(self.axle_offset_m) >= 0.5 * self.body_length_m:
            raise ValueError("axle_offset_m must put the drive axle inside the body (|offset| < body_length_m / 2)")
        return self


class TractorTrailerSpec(WheeledVehicleSpec):
    """A differential tugger with one off-axle trailer (seed 003 §3.2.7).

    ``trailer_length_m``: hitch to trailer axle D; ``hitch_offset_m``: tractor axle
    to hitch d (behind); beyond ``max_hitch_angle_deg`` the run ends as a jackknife.
    """

    reverses: ClassVar[bool] = False  # backing up jackknifes the trailer
    model: Literal["tractor_trailer"]
    """vehicle model name."""
    trailer_length_m: PosFloat = 1.5
    """D: hitch to trailer axle."""
    hitch_offset_m: NonNegFloat = 0.4
    """d: tractor axle to hitch, behind the axle."""
    max_hitch_angle_deg: Annotated[float, Field(gt=0.0, lt=180.0)] = 60.0
    """hitch angle at which the run ends as a jackknife."""
    trailer_width_m: PosFloat = 0.8
    """trailer body width."""


class MecanumTruthSpec(StrictModel):
    """Wheel radius error (relative, common) and random roller slip (relative std per step)."""

    wheel_radius_error: RelativeError = 0.0
    """relative error of the wheel radii."""
    roller_slip_std: NonNegFloat = 0.0
    """random relative slip of the rollers per step."""


class MecanumSpec(VehicleKindSpec):
    """Four Swedish (mecanum) wheels, holonomic (seed 003 §3.2.5)."""

    family: ClassVar[Family] = "holonomic"
    turns_on_spot: ClassVar[bool] = True

    model: Literal["mecanum"]
    """vehicle model name."""
    wheel_radius_m: PosFloat = 0.076
    """nominal mecanum wheel radius."""
    half_length_m: PosFloat = 0.3
    """a: half the distance between the front and rear axles."""
    half_width_m: PosFloat = 0.25
    """b: half the distance between the left and right wheels."""
    layout: Literal["X", "O"] = "X"
    """roller layout seen from above: X or O."""
    encoder_counts_per_rev: Counts = 4096
    """wheel encoder counts per revolution."""
    motor: MotorSpec = MotorSpec(no_load_rpm=150.0, time_constant_s=0.08)
    """the wheel gearmotors."""
    pid: PidSpec = PidSpec(kp=3.0, ki=6.0, kd=0.0)
    """the wheel speed loops."""
    substep_s: Annotated[float, Field(gt=0.0, le=0.05)] = 0.01
    """period of the speed loops inside each control step."""
    body_length_m: PosFloat = 0.8
    """body length (footprint centred on base_link)."""
    body_width_m: PosFloat = 0.65
    """body width (footprint centred on base_link)."""
    truth: MecanumTruthSpec = MecanumTruthSpec()
    """how the real vehicle differs from the nominal one."""


class TerrainFigures(StrictModel):
    """Explicit track-ground figures (see :class:`agvnav.kinematics.tracked.TrackTerrain`)."""

    slip_left: Fraction = 0.0
    """longitudinal slip of the left track (fraction)."""
    slip_right: Fraction = 0.0
    """longitudinal slip of the right track (fraction)."""
    icr_left: PosFloat = 1.0
    """ICR factor of the left track (>= 1: the ICR lies outside the track)."""
    icr_right: PosFloat = 1.0
    """ICR factor of the right track."""
    x_icr_m: Finite = 0.0
    """longitudinal offset of the ICRs from base_link."""


TerrainRef = Literal["ideal", "concrete", "artificial_grass"] | TerrainFigures


class TerrainSpec(StrictModel):
    """Truth terrain and what odometry believes; ``slip_noise_std``: m of random slip per metre rolled."""

    truth: TerrainRef = "concrete"
    """the ground the robot really drives on: a preset name or explicit figures."""
    odometry: TerrainRef = "concrete"
    """the figures odometry was calibrated with."""
    slip_noise_std: NonNegFloat = 0.0
    """random slip: m of error per metre rolled per track."""


class TrackedSpec(VehicleKindSpec):
    """Seed-004 tracked robot (45 x 40 cm body; gauge and sprocket radius are assumptions)."""

    family: ClassVar[Family] = "unicycle"
    turns_on_spot: ClassVar[bool] = True

    model: Literal["tracked"]
    """vehicle model name."""
    gauge_m: PosFloat = 0.33
    """distance between the track centre lines."""
    sprocket_radius_m: PosFloat = 0.05
    """radius of the drive sprockets."""
    body_length_m: PosFloat = 0.45
    """body length (footprint; the rangers mount on its edge)."""
    body_width_m: PosFloat = 0.40
    """body width (footprint; the rangers mount on its edge)."""
    encoder_counts_per_rev: Counts = 1440
    """sprocket encoder counts per revolution."""
    motor: MotorSpec = MotorSpec()
    """the track gearmotors (seed 004: 12 V, 45 rpm)."""
    pid: PidSpec = PidSpec()
    """the track speed loops (seed 004: Kp 10, Ki 20, Kd 0.5)."""
    substep_s: Annotated[float, Field(gt=0.0, le=0.05)] = 0.01
    """period of the speed loops inside each control step."""
    terrain: TerrainSpec = TerrainSpec()
    """track-ground interaction: truth and what odometry believes."""

    @model_validator(mode="after")
    def _body_holds_tracks(self) -> TrackedSpec:
        if self.gauge_m >= self.body_width_m + 0.2:
            raise ValueError("gauge_m must not exceed the body width by more than 0.2 m")
        return self


VehicleSpec = Annotated[
    TricycleSpec | TricycleRearSpec | AckermannSpec | QuadSteerSpec
    | DifferentialSpec | TractorTrailerSpec | MecanumSpec | TrackedSpec | DifferentialOffsetSpec,
    Field(discriminator="model"),
]


def _kinds() -> dict[str, type[VehicleKindSpec]]:
    """``model`` name -> spec class, read off the union's members (their ``model`` literal)."""
    members: tuple[type[VehicleKindSpec], ...] = get_args(get_args(VehicleSpec)[0])
    return {get_args(cls.model_fields["model"].annotation)[0]: cls for cls in members}


#: The registry of vehicle kinds: model name -> spec class (in the order the docs list them).
VEHICLE_KINDS: dict[str, type[VehicleKindSpec]] = _kinds()

#: Every vehicle model a scenario may name, in the order the docs list them.
VEHICLE_MODELS: tuple[str, ...] = tuple(VEHICLE_KINDS)


def vehicle_kind(model: str) -> type[VehicleKindSpec]:
    """The registry entry (spec class) of vehicle ``model``; ValueError naming the valid models if unknown."""
    try:
        return VEHICLE_KINDS[model]
    except KeyError:
        raise ValueError(f"unknown vehicle model {model!r}; valid models: {', '.join(VEHICLE_MODELS)}") from None
