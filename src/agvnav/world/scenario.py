"""Scenario files: one YAML document describing a closed-loop run, for every vehicle.

A scenario names the vehicle (``vehicle.model``: one of
:data:`~agvnav.world.vehicle_specs.VEHICLE_MODELS`, with its nominal geometry,
actuators, encoders and truth errors), the absolute sensors mounted on it (a
``goniometer`` with the reflector map, ``ultrasonic`` rangers with the wall
map, either or both), the map, the path (or the seed-004 square ``route``),
the controller, the positioning, the speed profile, the duration and the seed.
The schema is strict: unknown keys are rejected, and every error names the
offending key *and* the line of the file it is on (:mod:`agvnav.world.strict`).

Angles are in degrees at this edge only (keys ending in ``_deg``); the rest of
agvnav receives radians.
"""

from __future__ import annotations

from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal, Self

from pydantic import Field, field_validator, model_validator

from agvnav.world.obstacles import ObstacleSpec, ReactiveSpec, ScannerSpec
from agvnav.world.strict import (
    Finite,
    KeyPath,
    NonNegFloat,
    PosFloat,
    ScenarioError,
    SourcedModel,
    StrictModel,
    format_key,
    load_yaml_document,
    node_line,
    read_document_text,
    resolve_document,
    resolve_reference,
    validate_document,
)
from agvnav.world.vehicle_specs import VEHICLE_MODELS, VehicleSpec

__all__ = [
    "DEFAULT_SCENARIO",
    "FAULT_KINDS",
    "ArcSpec",
    "ControllerSpec",
    "DockingSpec",
    "DockingTruthSpec",
    "FaultSpec",
    "GoniometerSpec",
    "JobSpec",
    "KeyPath",
    "LineSpec",
    "MissionSpec",
    "PathSpec",
    "PositioningSpec",
    "RouteSpec",
    "SafetySpec",
    "Scenario",
    "ScenarioError",
    "SensorMountSpec",
    "StartSpec",
    "TractionSpec",
    "UltrasonicSpec",
    "WorldTruthSpec",
    "builtin_scenario",
    "builtin_scenario_names",
    "default_scenario",
    "format_key",
    "load_scenario",
    "node_line",
    "parse_scenario",
    "scenario_reference",
]

#: Name of the shipped scenario run when ``agvnav simulate`` is given none.
DEFAULT_SCENARIO = "guidance_test"

Direction = Literal["forward", "reverse"]


class GoniometerSpec(StrictModel):
    """Rotating laser head (seed 000 §4.1: 8 Hz, 65535 pulses/rev, 30 m)."""

    rate_hz: PosFloat = 8.0
    """revolutions of the laser head per second."""
    pulses_per_rev: Annotated[int, Field(gt=0)] = 65535
    """angle encoder pulses per revolution (bearing quantisation)."""
    mount: tuple[Finite, Finite, Finite] = Field((0.0, 0.0, 0.0), description="x (m), y (m), theta (deg) of P")
    """x (m), y (m), theta (deg) of the head centre P in base_link; must lie on the body."""
    min_range_m: NonNegFloat = 0.3
    """reflectors nearer than this are not seen."""
    max_range_m: PosFloat = 30.0
    """reflectors farther than this are not seen."""
    p_miss: Annotated[float, Field(ge=0.0, le=1.0)] = 0.0
    """probability that a reflection is missed."""
    spurious_rate_hz: NonNegFloat = 0.0
    """spurious reflections per second (shiny surfaces)."""
    jitter_std_s: NonNegFloat = 0.0
    """random timing error of each reflection."""


class SensorMountSpec(StrictModel):
    """One ranger: ``mount`` x (m), y (m), theta (deg) in base_link."""

    name: str
    """ranger name (e.g. right_front)."""
    mount: tuple[Finite, Finite, Finite]
    """x (m), y (m), theta (deg) of the ranger in base_link; on the body edge."""


class UltrasonicSpec(StrictModel):
    """HY-SRF05-like rangers (see :mod:`agvnav.sensors.ultrasonic`); default the seed-004 layout."""

    spacing_m: PosFloat = 0.30
    """distance between the side pair (seed 004 eqs 6-7 'dist')."""
    half_angle_deg: Annotated[float, Field(gt=0.0, lt=90.0)] = 15.0
    """half angle of the sound cone."""
    max_incidence_deg: Annotated[float, Field(ge=0.0, le=90.0)] = 20.0
    """largest incidence on a wall that still returns an echo."""
    min_range_m: NonNegFloat = 0.02
    """shortest range measured."""
    max_range_m: PosFloat = 4.0
    """longest range measured."""
    noise_std_m: NonNegFloat = 0.003
    """range noise inside the optimal range."""
    p_miss: Annotated[float, Field(ge=0.0, le=1.0)] = 0.0
    """probability that a ping returns no echo."""
    rate_hz: PosFloat = 20.0
    """pings per second per ranger."""
    sensors: list[SensorMountSpec] | None = None
    """explicit ranger mounts (default: the seed-004 five-ranger layout)."""


class WorldTruthSpec(StrictModel):
    """How the real world differs from the map: ``reflector_survey_std_m`` (m per axis, Gaussian).

    Seed 000 §4.1 surveyed its reflectors topographically; the surveyed map is
    what positioning uses, the displaced one is what the goniometer sees.
    """

    reflector_survey_std_m: Annotated[float, Field(ge=0.0, le=0.5)] = 0.0
    """std per axis of the true reflector positions around the surveyed map."""


class TractionSpec(StrictModel):
    """Speed profile of the tracked point: cruise speed, acceleration limits, stop at the end."""

    speed_m_s: PosFloat = 0.2
    """cruise speed of the tracked point."""
    max_accel_m_s2: PosFloat = 0.3
    """acceleration limit."""
    max_decel_m_s2: PosFloat = 0.3
    """deceleration limit (stops at cusps and at the path end)."""


class LineSpec(StrictModel):
    """A straight segment of ``length_m``; ``start``/``heading_deg`` default to the previous end.

    ``yaw_offset_deg`` (holonomic vehicles only): vehicle heading minus the path
    tangent along the segment (90: sideways travel to the left).
    """

    type: Literal["line"]
    """segment type."""
    length_m: PosFloat
    """length of the line."""
    direction: Direction = "forward"
    """direction of travel: reverse drives backwards along the segment."""
    start: tuple[Finite, Finite] | None = None
    """x, y (m) of the segment start; default the previous segment's end."""
    heading_deg: Finite | None = None
    """path tangent at the start; default the previous segment's end tangent."""
    yaw_offset_deg: Finite = 0.0
    """holonomic vehicles: body heading minus the path tangent (90: sideways to the left)."""


class ArcSpec(StrictModel):
    """A circular arc of ``radius_m`` turning ``sweep_deg`` (positive = to the left, CCW)."""

    type: Literal["arc"]
    """segment type."""
    radius_m: PosFloat
    """radius of the arc."""
    sweep_deg: Finite
    """turned angle, positive to the left (CCW)."""
    direction: Direction = "forward"
    """direction of travel: reverse drives backwards along the segment."""
    start: tuple[Finite, Finite] | None = None
    """x, y (m) of the segment start; default the previous segment's end."""
    heading_deg: Finite | None = None
    """path tangent at the start; default the previous segment's end tangent."""
    yaw_offset_deg: Finite = 0.0
    """holonomic vehicles: body heading minus the path tangent."""

    @model_validator(mode="after")
    def _nonzero(self) -> ArcSpec:
        if self.sweep_deg == 0.0 or abs(self.sweep_deg) > 360.0:
            raise ValueError("sweep_deg must be non-zero and at most 360 in magnitude")
        return self


class PathSpec(StrictModel):
    """The planned path of the guided point: a start pose and chained segments.

    A segment may give its own ``start`` (and ``heading_deg``); it must then
    coincide with the previous segment's end to within ``gap_tolerance_m``.
    """

    start: tuple[Finite, Finite, Finite] = Field(description="x (m), y (m), heading (deg)")
    segments: Annotated[list[Annotated[LineSpec | ArcSpec, Field(discriminator="type")]], Field(min_length=1)]
    """chained line and arc segments (at least one)."""
    gap_tolerance_m: PosFloat = 1e-3
    """largest allowed gap between a given segment start and the previous end."""


class RouteSpec(StrictModel):
    """The seed-004 square route: ``side_m``, start pose (x, y m, heading deg), turning direction."""

    type: Literal["square"] = "square"
    """route type: the seed-004 square."""
    side_m: PosFloat = 3.5
    """side of the square."""
    start: tuple[Finite, Finite, Finite] = (0.0, 0.0, 0.0)
    """x (m), y (m), heading (deg) of the start corner."""
    turn: Literal["left", "right"] = "left"
    """turning direction at the corners."""


class StartSpec(StrictModel):
    """Initial placement relative to the path start (seed 000 §4.3: 110 mm off the path).

    ``lateral_offset_m`` displaces the guided point to the left of the path
    (negative: right); ``heading_offset_deg`` turns the vehicle;
    ``steering_deg`` is the initial wheel angle of a steered vehicle, or
    ``feedforward`` for the steady-state angle of the first segment's curvature.
    """

    lateral_offset_m: Finite = 0.0
    """tracked point displaced this far left of the path start (negative: right)."""
    heading_offset_deg: Finite = 0.0
    """vehicle turned this much from the path tangent."""
    steering_deg: Annotated[float, Field(gt=-90.0, lt=90.0)] | Literal["feedforward"] = 0.0
    """initial steering angle of a steered vehicle, or feedforward."""


class ControllerSpec(StrictModel):
    """Guidance by name (which names fit which vehicle: ``agvnav.guidance`` registry).

    ``name`` None picks the vehicle family's default. Steered vehicles take
    closed-loop ``poles_per_m`` or ``gains`` and the guided ``point`` (C, the
    steered wheel, by default, or O, the rear axle midpoint); other vehicles
    guide base_link (O);
    ``params`` go to the controller. The seed-004 automaton (``hybrid``) drives
    the square ``route`` for ``laps``, with or without wall ``landmarks``;
    ``compare_landmarks`` runs both with the same seed.
    """

    name: str | None = None
    """path follower (null: the vehicle family's default; see agvnav.guidance.FOLLOWERS)."""
    point: Literal["C", "O"] | None = None
    """tracked point of a steered vehicle: C (steered wheel) or O (rear axle midpoint)."""
    poles_per_m: list[Finite] | None = None
    """closed-loop poles per metre travelled (seed-000 laws)."""
    gains: dict[str, Finite] | None = None
    """explicit gains instead of poles (a, b[, c] for the seed-000 laws)."""
    params: dict[str, Any] = Field(default_factory=dict)
    """further follower parameters, e.g. convergence_distance (m)."""
    laps: Annotated[int, Field(ge=1, le=100)] = 10
    """hybrid automaton: laps of the square route."""
    landmarks: bool = True
    """hybrid automaton: use the wall landmarks."""
    compare_landmarks: bool = False
    """hybrid automaton: run with and without landmarks with the same seed."""

    @model_validator(mode="after")
    def _one_of(self) -> ControllerSpec:
        if self.poles_per_m is not None and self.gains is not None:
            raise ValueError("give either poles_per_m or gains, not both")
        return self


class WheelOdometrySpec(StrictModel):
    """A steered vehicle's odometry errors as the filter models them exactly (issue 12).

    Replaces ``odometry_noise`` (Crowley's three coefficients, an upper bound for a
    steered vehicle): the random slip and steering errors are mapped along the
    directions they move the increment (:class:`agvnav.odometry.SteeredOdometryNoise`;
    the steering error acts per control step, ``traction.speed_m_s x step_s`` metres),
    and the calibration tolerances are the prior stds of the wheel-radius scale error
    and the steering offset, which the EKF keeps as consider parameters. A rear-drive
    increment past ``vehicle.steering.max_angle_deg`` is taken at that limit. The other
    methods (naive, angle_propagation, batch_ml) keep no consider parameters: they take
    Crowley's bound of the same random errors (:func:`agvnav.odometry.noise_from_truth`),
    as before this key, not the exact random part alone.
    """

    slip_std: NonNegFloat = 0.0
    """random slip of the drive wheel: std (m) after 1 m rolled (variance slip_std² per metre)."""
    steering_noise_std_deg: NonNegFloat = 0.0
    """random steering-angle error, drawn afresh per control step (std)."""
    wheel_radius_std: Annotated[float, Field(ge=0.0, le=0.2)] = 0.0
    """calibration tolerance of the drive-wheel radius: std of true/nominal - 1 (fraction)."""
    steering_offset_std_deg: Annotated[float, Field(ge=0.0, le=10.0)] = 0.0
    """calibration tolerance of the steering zero (std)."""


class PositioningSpec(StrictModel):
    """Positioning method and its initialisation.

    ``method`` None: ``ekf`` with a goniometer, the seed-004 ``wall_landmarks``
    localizer with rangers only, else ``dead_reckoning``.
    """

    method: Literal["naive", "angle_propagation", "batch_ml", "ekf", "wall_landmarks", "dead_reckoning"] | None = None
    """positioning method (null: ekf with a goniometer, wall_landmarks with rangers only, else dead_reckoning)."""
    params: dict[str, Any] = Field(default_factory=dict)
    """further estimator parameters (see agvnav.positioning.make_estimator)."""
    initial_error: tuple[Finite, Finite, Finite] = Field(
        (0.0, 0.0, 0.0), description="x (m), y (m), heading (deg) error of the initial estimate"
    )
    initial_std: tuple[NonNegFloat, NonNegFloat, NonNegFloat] = Field(
        (0.02, 0.02, 1.0), description="x (m), y (m), heading (deg) standard deviations"
    )
    odometry_noise: tuple[NonNegFloat, NonNegFloat, NonNegFloat] = Field(
        (0.001, 0.003, 0.001), description="k_d, k_dtheta, k_theta of the odometry covariance model"
    )
    wheel_odometry: WheelOdometrySpec | None = None
    """steered vehicles: the exact odometry error model and calibration tolerance (replaces odometry_noise)."""

    @model_validator(mode="after")
    def _one_noise_model(self) -> PositioningSpec:
        if self.wheel_odometry is not None and "odometry_noise" in self.model_fields_set:
            raise ValueError("give either odometry_noise (Crowley's coefficients) or wheel_odometry, not both")
        return self


class SafetySpec(StrictModel):
    """How the autopilot reacts to the estimator's status and uncertainty (issue 12).

    The vehicle slows to ``slow_speed_fraction`` of its speed when positioning is
    degraded (status ``degraded`` or ``dead_reckoning``) or when 3 sigma of the
    estimated position across the vehicle exceeds ``lateral_3sigma_slow_m``; it
    stops at its deceleration limit when positioning is ``lost`` (or the status
    is unknown) or 3 sigma exceeds ``lateral_3sigma_stop_m``. It resumes once
    positioning has been good again for ``resume_after_s``. The guard acts when a
    goniometer positions the vehicle; a vehicle built to dead-reckon (no absolute
    sensor, or the seed-004 wall landmarks) only records its figures.
    """

    enabled: bool = True
    """false: drive on whatever the estimator says (for experiments only)."""
    lateral_3sigma_slow_m: PosFloat = 0.10
    """3 sigma of the estimated lateral position above which the vehicle slows down."""
    lateral_3sigma_stop_m: PosFloat = 0.30
    """3 sigma of the estimated lateral position above which the vehicle stops."""
    slow_speed_fraction: Annotated[float, Field(gt=0.0, le=1.0)] = 0.3
    """fraction of the planned speed while positioning is degraded."""
    resume_after_s: NonNegFloat = 1.0
    """positioning must be good this long before the vehicle resumes (hysteresis)."""

    @model_validator(mode="after")
    def _ordered(self) -> SafetySpec:
        if self.lateral_3sigma_stop_m < self.lateral_3sigma_slow_m:
            raise ValueError("lateral_3sigma_stop_m must be at least lateral_3sigma_slow_m")
        return self


#: Fault kinds of the ``faults:`` list and the fields each one needs (beyond ``kind``/timing).
FAULT_KINDS: dict[str, tuple[str, ...]] = {
    "blind": (),
    "reflector_removed": ("reflector",),
    "reflector_moved": ("reflector", "offset_m"),
    "clutter": ("per_revolution",),
    "wheel_slip": ("slip_fraction",),
    "encoder_dropout": (),
    "counter_wrap": ("jump_m",),
    "odometry_lost": (),
    "reflection_delay": ("delay_s",),
}

#: Fault fields that are not timing and belong to a kind (the rest are refused for that kind).
_FAULT_FIELDS = ("reflector", "offset_m", "per_revolution", "slip_fraction", "jump_m", "delay_s", "stamped")


class FaultSpec(StrictModel):
    """One injected fault (issue 12); active from ``start_s`` for ``duration_s`` (null: to the end).

    Kinds: ``blind`` (the goniometer sees nothing), ``reflector_removed`` (one
    reflector of the map is gone), ``reflector_moved`` (it stands ``offset_m`` from
    its surveyed position), ``clutter`` (``per_revolution`` spurious reflections at
    random bearings per head revolution), ``wheel_slip`` (the odometry over-reads the
    distance by ``slip_fraction``), ``encoder_dropout`` (the encoders read nothing:
    the motion is lost), ``counter_wrap`` (one odometry increment jumps by ``jump_m``
    at ``start_s``), ``odometry_lost`` (odometry messages are lost; the next one
    carries the whole missed increment), ``reflection_delay`` (reflections reach the
    estimator ``delay_s`` late, stamped on arrival, or with their measurement time
    when ``stamped``).
    """

    kind: Literal[
        "blind", "reflector_removed", "reflector_moved", "clutter", "wheel_slip",
        "encoder_dropout", "counter_wrap", "odometry_lost", "reflection_delay",
    ]
    """blind: no reflections; reflector_removed/reflector_moved: that reflector gone/displaced by offset_m;
    clutter: spurious reflections; wheel_slip: distance over-read; encoder_dropout: no odometry, the motion
    lost; counter_wrap: one jump_m increment at start_s; odometry_lost: messages lost, the next carries the
    missed motion; reflection_delay: reflections delay_s late."""
    start_s: NonNegFloat = 0.0
    """time the fault begins."""
    duration_s: PosFloat | None = None
    """how long it lasts (null: to the end of the run; counter_wrap: ignored)."""
    reflector: str | None = None
    """reflector id (reflector_removed, reflector_moved)."""
    offset_m: tuple[Finite, Finite] | None = None
    """x, y displacement (m) of the moved reflector from its surveyed position."""
    per_revolution: Annotated[float, Field(gt=0.0, le=1000.0)] | None = None
    """clutter: mean spurious reflections per head revolution."""
    slip_fraction: Annotated[float, Field(gt=-1.0, le=10.0)] | None = None
    """wheel_slip: odometry distance reads (1 + slip_fraction) times the true one."""
    jump_m: Finite | None = None
    """counter_wrap: distance (m) added to one odometry increment (a 32-bit wrap: about 6.5e5 m)."""
    delay_s: Annotated[float, Field(gt=0.0, le=10.0)] | None = None
    """reflection_delay: latency of each reflection."""
    stamped: bool | None = None
    """reflection_delay: deliver the measurement time (true) or the arrival time (false, default)."""

    @model_validator(mode="after")
    def _fields_of_kind(self) -> FaultSpec:
        needed = FAULT_KINDS[self.kind]
        missing = [f for f in needed if getattr(self, f) is None]
        if missing:
            raise ValueError(f"a {self.kind} fault needs {', '.join(missing)}")
        allowed = set(needed) | ({"stamped"} if self.kind == "reflection_delay" else set())
        extra = [f for f in _FAULT_FIELDS if f not in allowed and getattr(self, f) is not None]
        if extra:
            raise ValueError(f"a {self.kind} fault takes no {', '.join(extra)}")
        return self

    @property
    def end_s(self) -> float:
        """End of the active window (s; inf when it lasts to the end of the run)."""
        return float("inf") if self.duration_s is None else self.start_s + self.duration_s


class JobSpec(StrictModel):
    """One mission job: ``action`` at ``station`` (none for wait), then a stop of ``duration_s``.

    goto: drive to the station; reverse_into: drive there backing up the last edge;
    pick/drop: drive there and stop ``duration_s`` (the load handled); wait: stop where
    the vehicle stands for ``duration_s``.
    """

    action: Literal["goto", "reverse_into", "pick", "drop", "wait"]
    """what to do."""
    station: str | None = None
    """the station (every action but wait)."""
    duration_s: NonNegFloat = 0.0
    """stop time at the station (pick, drop, wait; optional for goto)."""

    @model_validator(mode="after")
    def _station(self) -> JobSpec:
        if (self.station is None) != (self.action == "wait"):
            raise ValueError("wait takes no station; every other action needs one")
        return self


class MissionSpec(StrictModel):
    """A mission on a route network (issue 14), driven instead of a ``path``.

    ``network``: a shipped route network name or a file (relative to the scenario);
    the vehicle starts at station ``start`` and does the ``jobs`` in order.
    """

    network: str
    """route network: shipped name (agvnav/data/routes) or file path."""
    start: str
    """station the vehicle starts at (its heading_deg is the start heading)."""
    jobs: list[JobSpec]
    """the jobs, in order (at least one; in a fleet under traffic control none is allowed: the vehicle then takes
    dispatched transport jobs only)."""
    blocked_edges: list[str] = Field(default_factory=list)
    """edges that may not be used (the route replans around them)."""
    lateral_accel_m_s2: PosFloat = 0.3
    """lateral acceleration limit: caps the speed on curves (v^2 |kappa|)."""
    creep_distance_m: NonNegFloat = 0.3
    """distance before each station driven at the creep speed."""
    creep_speed_m_s: PosFloat = 0.05
    """creep speed of the final approach to a station."""
    turn_rate_deg_s: PosFloat = 30.0
    """turning rate on the spot (differential, tracked, mecanum vehicles)."""
    point_switching: bool = False
    """steered vehicles: guide C on runs driven forward (cruising), O on runs backing up (manoeuvres)."""
    align_heading: bool = True
    """vehicles turning on the spot: position finely at standstill after each stop (the estimate settles, slow
    corrections to 2 mm, the station heading: ``guidance.FinePositioner``)."""


class WalkingPersonSpec(StrictModel):
    """A person walking past the station (a cylinder), hiding the reflectors behind while in the line of sight."""

    path: Annotated[list[tuple[Finite, Finite]], Field(min_length=2)]
    """waypoints x, y in the station frame (m): the person stands at the first until start_s, walks, stays at the
    last."""
    speed_m_s: PosFloat = 0.5
    """walking speed (m/s)."""
    start_s: NonNegFloat = 0.0
    """time the person starts walking (s, from the start of the run)."""
    radius_m: PosFloat = 0.25
    """the person's radius (m)."""


class DockingTruthSpec(StrictModel):
    """Where the station and its target really are (the simulator's truth; the vehicle never reads it)."""

    station_offset: tuple[Finite, Finite, Finite] = (0.0, 0.0, 0.0)
    """true station pose minus its map pose, in the station frame: x (mm), y (mm), heading (deg)."""
    missing: list[str] = Field(default_factory=list)
    """target reflectors that are not there (damaged, removed)."""
    moved: dict[str, tuple[Finite, Finite]] = Field(default_factory=dict)
    """target reflectors moved on the station: id -> (dx, dy) in the station frame (mm)."""
    clutter: list[tuple[Finite, Finite]] = Field(default_factory=list)
    """shiny objects (reflections like a reflector's) near the station: (x, y) in the station frame (m)."""
    person: tuple[Finite, Finite] | None = None
    """a person (0.4 m square) standing at (x, y) in the station frame (m), hiding what is behind."""
    person_walking: WalkingPersonSpec | None = None
    """a person walking past the station (in the station frame), hiding what is behind while in the way."""


class DockingSpec(StrictModel):
    """Dock at a station relative to its target reflectors (issue 32), driven instead of a ``path``.

    The vehicle starts at the approach start of the map's target (``approach_m`` before the
    docking pose, as the map places the station) and docks relative to the target it sees.
    Beside a ``mission`` the vehicle starts at the mission's start and drives its network; the
    network node named as the target is the docking node, where a VDA 5050 ``finePositioning``
    runs this docking (``agvnav.vda5050.vehicle``).
    """

    target: str
    """id of a docking target in the map's ``docking_targets``."""
    speed_m_s: PosFloat = 0.15
    """approach speed (m/s)."""
    tolerance_mm: PosFloat = 3.0
    """docking position tolerance of the guided point (mm): 3 sigma of the estimate and the final error."""
    heading_tolerance_deg: PosFloat = 0.1
    """docking heading tolerance (deg)."""
    truth: DockingTruthSpec = DockingTruthSpec()
    """the station and its target as they really are."""
    guide_on: Literal["station", "map"] = "station"
    """station: dock on the station-relative pose (judged); map: stop on the global pose where the map places
    the station, as a mission's station stop does (the comparison, never judged)."""


class Scenario(SourcedModel):
    """A closed-loop run of any vehicle. All lengths in m, times in s, angles in deg."""

    name: str = "scenario"
    """scenario name (used in outputs)."""
    description: str = ""
    """one-line description (agvnav scenarios lists it)."""
    seed: Annotated[int, Field(ge=0)] = 0
    """random seed: the same seed reproduces the run bit for bit."""
    step_s: Annotated[float, Field(gt=0.0, le=0.1)] = 0.02
    """control period of the closed loop."""
    duration_s: PosFloat | None = None
    """simulated time limit (default: 1.5 x the nominal drive time plus margins)."""
    end_hold_s: NonNegFloat = 1.0
    """time recorded after the vehicle stops at the path end."""
    vehicle: VehicleSpec
    """the vehicle: one section per model, below."""
    world_truth: WorldTruthSpec = WorldTruthSpec()
    """how the real world differs from the map."""
    traction: TractionSpec = TractionSpec()
    """speed profile of the tracked point."""
    goniometer: GoniometerSpec | None = None
    """laser goniometer mounted on the vehicle (null: none)."""
    ultrasonic: UltrasonicSpec | None = None
    """ultrasonic rangers mounted on the vehicle (null: none)."""
    map: str | dict[str, Any] = "lab"
    """a shipped map name (lab, hall), a map file path (relative to the scenario), or an inline map."""
    path: PathSpec | None = None
    """the planned path of the tracked point."""
    route: RouteSpec | None = None
    """the seed-004 square route (tracked robot with the hybrid automaton)."""
    mission: MissionSpec | None = None
    """a mission on a route network, instead of a path (issue 14)."""
    docking: DockingSpec | None = None
    """dock at a station relative to its target reflectors, instead of a path (issue 32); beside a mission, the
    docking at the target's node (VDA 5050 finePositioning)."""
    start: StartSpec = StartSpec()
    """initial placement relative to the path start."""
    controller: ControllerSpec = ControllerSpec()
    """the path follower."""
    positioning: PositioningSpec = PositioningSpec()
    """the estimator."""
    min_reflectors_in_view: Annotated[int, Field(ge=3)] = 3
    """reflectors the goniometer must see all along the path."""
    safety: SafetySpec = SafetySpec()
    """how the vehicle slows and stops when positioning degrades or is lost."""
    faults: list[FaultSpec] = Field(default_factory=list)
    """faults injected into the run (goniometer, reflectors, odometry), for testing integrity."""
    obstacles: list[ObstacleSpec] | None = None
    """obstacles the map does not hold: static boxes/cylinders, people or vehicles crossing (issue 18)."""
    scanner: ScannerSpec | None = None
    """a planar safety laser scanner on the vehicle (null: none; issue 18)."""
    reactive: ReactiveSpec | None = None
    """safety fields, slow/stop/resume and local avoidance (null: no reaction; issue 18)."""

    @field_validator("map", mode="before")
    @classmethod
    def _map_kind(cls, value: Any) -> Any:
        if not isinstance(value, (str, Mapping)):
            raise ValueError(
                "must be a shipped map name (e.g. lab), a map file path, or a mapping of reflectors and walls"
            )
        return value

    @model_validator(mode="before")
    @classmethod
    def _default_model(cls, data: Any) -> Any:
        """``vehicle.model`` may be omitted for the seed-000 tricycle (the first scenarios' default)."""
        if isinstance(data, Mapping):
            vehicle = data.get("vehicle", {})
            if isinstance(vehicle, Mapping) and "model" not in vehicle:
                return {**data, "vehicle": {"model": "tricycle", **vehicle}}
        return data

    @model_validator(mode="after")
    def _path_or_route(self) -> Scenario:
        given = [k for k in ("path", "route", "mission", "docking") if getattr(self, k) is not None]
        if not given:
            raise ValueError("give a path (or a mission, a docking, or for the seed-004 automaton a route)")
        if self.docking is not None and (self.path is not None or self.route is not None):
            raise ValueError("a docking replaces the path: give one of path, route, docking (a docking may go with "
                             "a mission: the VDA 5050 vehicle docks at the target's node)")
        if self.mission is not None and (self.path is not None or self.route is not None):
            raise ValueError("a mission replaces the path: give one of path, mission, route")
        if self.route is not None and self.vehicle.model != "tracked":
            raise ValueError("route (the seed-004 square) is for the tracked robot; other vehicles follow a path")
        if self.route is not None and self.controller.name not in (None, "hybrid"):
            raise ValueError("the seed-004 route is driven by the hybrid automaton (controller.name: hybrid)")
        if self.route is None and self.controller.name == "hybrid":
            raise ValueError("the hybrid automaton drives the seed-004 square: give the route key")
        if self.positioning.wheel_odometry is not None and self.vehicle.model not in ("tricycle", "tricycle_rear"):
            raise ValueError("positioning.wheel_odometry models a steered drive wheel (tricycle, tricycle_rear); "
                             "give odometry_noise for this vehicle")
        if self.route is not None and self.ultrasonic is None:
            raise ValueError("the hybrid automaton's landmarks are seen by ultrasonic rangers: give the ultrasonic key")
        return self

    @property
    def model(self) -> str:
        """The vehicle model name (e.g. ``"tricycle"``)."""
        return self.vehicle.model

    def with_seed(self, seed: int) -> Self:
        """A copy with another random seed (keeps the source and line map)."""
        if seed < 0:
            raise ValueError(f"seed must be >= 0, got {seed}")
        return self.copy_attached({"seed": int(seed)})

    def with_controller(self, **fields: Any) -> Self:
        """A copy with controller fields replaced (e.g. ``laps=2, landmarks=False``)."""
        return self.copy_attached({"controller": self.controller.model_copy(update=fields)})


def _model_error(data: Mapping[str, Any], nodes: Any, source: str) -> ScenarioError | None:
    """A clear error for an unknown ``vehicle.model``, listing the valid ones."""
    vehicle = data.get("vehicle")
    model = vehicle.get("model") if isinstance(vehicle, Mapping) else None
    if model is None or model in VEHICLE_MODELS:
        return None
    key: KeyPath = ("vehicle", "model")
    return ScenarioError(
        f"unknown vehicle model {model!r}; valid models: {', '.join(VEHICLE_MODELS)}",
        key,
        node_line(nodes, key),
        source,
    )


def parse_scenario(text: str, source: str = "<string>", base_dir: Path | None = None) -> Scenario:
    """Parse and validate scenario YAML ``text``; a ScenarioError names key and line."""
    data, nodes = load_yaml_document(text, source, "scenario")
    if "fleet" in data:  # issue 28: agvnav.world.fleet.load_fleet reads it, agvnav simulate runs it
        raise ScenarioError("a fleet scenario (fleet.vehicles), not a single vehicle's: run it with agvnav simulate "
                            "(agvnav.world.fleet.load_fleet reads it)", ("fleet",), node_line(nodes, ("fleet",)),
                            source)
    err = _model_error(data, nodes, source)
    if err is not None:
        raise err
    return validate_document(Scenario, data, nodes, source, base_dir)


def load_scenario(path: str | Path) -> Scenario:
    """Load a scenario file, or a shipped scenario by name (``guidance_test``).

    A name typed by the user: a local file of that name wins, a folder never does
    (:func:`~agvnav.world.strict.resolve_document`).
    """
    p = resolve_document(path, _scenarios_dir(), "scenario")
    text = read_document_text(p, "scenario", str(path))
    return parse_scenario(text, source=str(path), base_dir=p.parent)


def scenario_reference(name: str, base_dir: Path | None) -> Path:
    """The file of the scenario a document names (a campaign's ``base: guidance_test``).

    A shipped name is always the shipped scenario; any other name a path relative to
    ``base_dir``, the naming document's folder (:func:`~agvnav.world.strict.resolve_reference`).
    """
    return resolve_reference(name, base_dir, _scenarios_dir(), "scenario")


def _scenarios_dir() -> Path:
    return Path(str(resources.files("agvnav") / "data" / "scenarios"))


def builtin_scenario_names() -> list[str]:
    """Names of the scenarios shipped in ``agvnav/data/scenarios``, sorted."""
    return sorted(p.stem for p in _scenarios_dir().glob("*.yaml"))


def builtin_scenario(name: str) -> Path:
    """Path of the shipped scenario ``name``; ValueError listing the names if unknown."""
    p = _scenarios_dir() / f"{name}.yaml"
    if not p.is_file():
        raise ValueError(f"unknown scenario {name!r}; shipped: {builtin_scenario_names()}")
    return p


def default_scenario() -> Scenario:
    """The embedded default: seed 000 §4.3 guidance test in the lab (arc R 1.24 m, 3 m line)."""
    return load_scenario(builtin_scenario(DEFAULT_SCENARIO))
