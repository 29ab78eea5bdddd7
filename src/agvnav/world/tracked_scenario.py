"""Scenario files for the seed-004 tracked robot (issue 6): ``vehicle.model: tracked``.

Same conventions as :mod:`agvnav.world.scenario` (strict keys, errors naming key
and line, degrees only in ``*_deg`` keys). :func:`agvnav.world.scenario.parse_scenario`
hands a document whose ``vehicle.model`` is ``tracked`` to :func:`parse_tracked`.

Sections: ``vehicle`` (geometry, motors, PID, encoders), ``terrain`` (truth and
odometry track-ground figures: preset names or explicit values), ``ultrasonic``
(the seed-004 sensor layout and HY-SRF05 model), ``map`` (walls = landmarks),
``route`` (the square), ``controller`` (the hybrid automaton: laps, landmarks,
``compare_landmarks`` to run both modes with the same seed, automaton params).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, ValidationError, model_validator

from agvnav.world.scenario import PathSpec
from agvnav.world.strict import (
    Finite,
    NonNegFloat,
    PosFloat,
    ScenarioError,
    SourcedModel as _Sourced,
    StrictModel as _Strict,
    attach_source as _attach,
    first_error as _first_error,
    node_line,
)

__all__ = ["TerrainFigures", "TrackedScenario", "parse_tracked"]

Fraction = Annotated[float, Field(ge=0.0, lt=1.0)]


class MotorSpec(_Strict):
    """Track gearmotors (seed 004: 12 V, 45 rpm); ``asymmetry`` = right minus left relative gain."""

    time_constant_s: PosFloat = 0.1
    asymmetry: Annotated[float, Field(gt=-1.0, lt=1.0)] = 0.0
    supply_v: PosFloat = 12.0


class PidSpec(_Strict):
    """Speed PID per motor (seed 004: Kp = 10, Ki = 20, Kd = 0.5)."""

    kp: NonNegFloat = 10.0
    ki: NonNegFloat = 20.0
    kd: NonNegFloat = 0.5
    derivative_time_constant_s: NonNegFloat = 0.02


class TrackedVehicleSpec(_Strict):
    """Nominal tracked robot (seed 004: 45 x 40 cm body; gauge and sprocket are assumptions)."""

    model: Literal["tracked"]
    gauge_m: PosFloat = 0.33
    sprocket_radius_m: PosFloat = 0.05
    body_length_m: PosFloat = 0.45
    body_width_m: PosFloat = 0.40
    encoder_counts_per_rev: Annotated[int, Field(gt=0)] = 1440
    motor: MotorSpec = MotorSpec()
    pid: PidSpec = PidSpec()
    substep_s: Annotated[float, Field(gt=0.0, le=0.05)] = 0.01


class TerrainFigures(_Strict):
    """Explicit track-ground figures (see :class:`agvnav.kinematics.tracked.TrackTerrain`)."""

    slip_left: Fraction = 0.0
    slip_right: Fraction = 0.0
    icr_left: PosFloat = 1.0
    icr_right: PosFloat = 1.0
    x_icr_m: Finite = 0.0


TerrainRef = Literal["ideal", "concrete", "artificial_grass"] | TerrainFigures


class TerrainSpec(_Strict):
    """Truth terrain and what odometry believes; ``slip_noise_std``: m of random slip per metre rolled."""

    truth: TerrainRef = "concrete"
    odometry: TerrainRef = "concrete"
    slip_noise_std: NonNegFloat = 0.0


class SensorMountSpec(_Strict):
    """One ranger: ``mount`` x (m), y (m), theta (deg) in base_link."""

    name: str
    mount: tuple[Finite, Finite, Finite]


class UltrasonicSpec(_Strict):
    """HY-SRF05-like rangers (see :mod:`agvnav.sensors.ultrasonic`); default the seed-004 layout."""

    spacing_m: PosFloat = 0.30
    half_angle_deg: Annotated[float, Field(gt=0.0, lt=90.0)] = 15.0
    max_incidence_deg: Annotated[float, Field(ge=0.0, le=90.0)] = 20.0
    min_range_m: NonNegFloat = 0.02
    max_range_m: PosFloat = 4.0
    noise_std_m: NonNegFloat = 0.003
    p_miss: Annotated[float, Field(ge=0.0, le=1.0)] = 0.0
    rate_hz: PosFloat = 20.0
    sensors: list[SensorMountSpec] | None = None


class RouteSpec(_Strict):
    """The seed's square route: ``side_m``, start pose (x, y m, heading deg), turning direction."""

    type: Literal["square"] = "square"
    side_m: PosFloat = 3.5
    start: tuple[Finite, Finite, Finite] = (0.0, 0.0, 0.0)
    turn: Literal["left", "right"] = "left"


class HybridSpec(_Strict):
    """The guidance: ``hybrid`` (seed 004 Fig. 7 automaton on ``route``) or ``kanayama`` (follows ``path``).

    ``params``: HybridParams fields for ``hybrid``, KanayamaController keywords for
    ``kanayama`` (plus ``convergence_distance``, m); keys ending ``_deg`` /
    ``_deg_s`` are in degrees. ``laps`` and the landmark flags apply to ``hybrid`` only.
    """

    name: Literal["hybrid", "kanayama"] = "hybrid"
    laps: Annotated[int, Field(ge=1, le=100)] = 10
    landmarks: bool = True
    compare_landmarks: bool = False
    params: dict[str, Any] = Field(default_factory=dict)


class TrackedScenario(_Sourced):
    """A closed-loop run of the seed-004 tracked robot. Lengths m, times s, angles deg."""

    name: str = "tracked"
    description: str = ""
    seed: Annotated[int, Field(ge=0)] = 0
    step_s: Annotated[float, Field(gt=0.0, le=0.1)] = 0.1
    duration_s: PosFloat | None = None
    end_hold_s: NonNegFloat = 0.0
    vehicle: TrackedVehicleSpec
    terrain: TerrainSpec = TerrainSpec()
    ultrasonic: UltrasonicSpec = UltrasonicSpec()
    map: str | dict[str, Any]
    route: RouteSpec = RouteSpec()
    path: PathSpec | None = None
    controller: HybridSpec = HybridSpec()

    @model_validator(mode="after")
    def _path_for_kanayama(self) -> TrackedScenario:
        if self.controller.name == "kanayama" and self.path is None:
            raise ValueError("controller kanayama follows a path: give the path key")
        return self

    def with_seed(self, seed: int) -> TrackedScenario:
        """A copy with another random seed (keeps the source and line map)."""
        if seed < 0:
            raise ValueError(f"seed must be >= 0, got {seed}")
        return self.copy_attached({"seed": int(seed)})

    def with_updates(self, **controller: Any) -> TrackedScenario:
        """A copy with controller fields replaced (e.g. ``laps=2, landmarks=False``)."""
        return self.copy_attached({"controller": self.controller.model_copy(update=controller)})

    def hybrid_params_kwargs(self) -> dict[str, float]:
        """``controller.params`` with degree keys converted to radians (HybridParams names)."""
        out: dict[str, float] = {}
        for key, value in self.controller.params.items():
            for suffix in ("_deg_s", "_deg"):
                if key.endswith(suffix):
                    out[key[: -len(suffix)]] = math.radians(float(value))
                    break
            else:
                out[key] = value
        return out


def is_tracked(data: Any) -> bool:
    """True if a parsed YAML document asks for the tracked robot."""
    vehicle = data.get("vehicle") if isinstance(data, Mapping) else None
    return isinstance(vehicle, Mapping) and vehicle.get("model") == "tracked"


def parse_tracked(data: Mapping[str, Any], nodes: Any, source: str, base_dir: Path | None) -> TrackedScenario:
    """Validate a tracked-robot scenario document; ScenarioError names key and line."""
    try:
        sc = TrackedScenario.model_validate(data)
    except ValidationError as exc:
        key, msg = _first_error(exc, data)
        raise ScenarioError(msg, key, node_line(nodes, key), source) from None
    _attach(sc, source, nodes, base_dir)
    return sc
