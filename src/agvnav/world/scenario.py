"""Scenario files: one YAML document describing a closed-loop run (issue 5 §4).

A scenario names the vehicle, its truth errors, the actuators, the goniometer,
the map, the path, the controller with its gains (or poles), the positioning
method, the noise sources, the duration and the seed. The schema is strict:
unknown keys are rejected, and every error names the offending key *and* the
line of the file it is on, e.g. ``guidance.yaml:23: controller.poles_per_m:
...``. Line numbers come from the YAML composer's node marks: the pydantic
error location (a key path) is walked down the composed node tree.

Angles are in degrees at this edge only (keys ending in ``_deg``); the rest of
agvnav receives radians.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal, Self

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from agvnav._yaml import safe_load_unique

__all__ = [
    "ArcSpec",
    "ControllerSpec",
    "GoniometerSpec",
    "LineSpec",
    "PathSpec",
    "PositioningSpec",
    "Scenario",
    "ScenarioError",
    "StartSpec",
    "SteeringSpec",
    "TractionSpec",
    "TruthErrorSpec",
    "VehicleSpec",
    "builtin_scenario",
    "builtin_scenario_names",
    "default_scenario",
    "load_scenario",
    "parse_scenario",
]

#: Name of the shipped scenario run when ``agvnav simulate`` is given none.
DEFAULT_SCENARIO = "guidance_test"

KeyPath = tuple[str | int, ...]


class ScenarioError(ValueError):
    """A scenario problem located by key path and (when known) file line."""

    def __init__(self, message: str, key: KeyPath = (), line: int | None = None, source: str = "") -> None:
        self.key = tuple(key)
        self.line = line
        self.source = source
        self.detail = message
        where = source or "scenario"
        if line is not None:
            where += f":{line}"
        keytext = format_key(self.key)
        super().__init__(f"{where}: {keytext + ': ' if keytext else ''}{message}")


def format_key(key: KeyPath) -> str:
    """``("path", "segments", 1, "radius_m")`` -> ``path.segments[1].radius_m``."""
    out = ""
    for part in key:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


PosFloat = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]
NonNegFloat = Annotated[float, Field(ge=0.0, allow_inf_nan=False)]
Finite = Annotated[float, Field(allow_inf_nan=False)]
Direction = Literal["forward", "reverse"]


class VehicleSpec(_Strict):
    """Nominal vehicle (what odometry and guidance believe): seed 000 §3.1 tricycle."""

    model: Literal["tricycle"] = "tricycle"
    wheelbase_m: PosFloat = 1.2
    drive_wheel_radius_m: PosFloat = 0.1
    traction_counts_per_rev: Annotated[int, Field(gt=0)] = 4096
    steering_counts_per_rev: Annotated[int, Field(gt=0)] = 16384


class TruthErrorSpec(_Strict):
    """How the truth vehicle differs from the nominal one (issue 3 error sources).

    ``wheel_radius_error``: relative error of the drive-wheel radius (truth =
    nominal x (1 + e)); ``wheelbase_error``: relative error of L;
    ``steering_offset_deg``: the wheel points this much off what the steering
    encoder reads; ``slip_std``: random relative error of each traction
    increment (non-systematic slip); ``steering_noise_std_deg``: random error of
    the steering angle per step; ``reflector_survey_std_m``: the true reflector
    positions differ from the surveyed map the positioning uses by this Gaussian
    error per axis (m; seed 000 §4.1 surveyed its reflectors topographically).
    """

    wheel_radius_error: Annotated[float, Field(gt=-0.5, lt=0.5)] = 0.0
    wheelbase_error: Annotated[float, Field(gt=-0.5, lt=0.5)] = 0.0
    steering_offset_deg: Annotated[float, Field(ge=-10.0, le=10.0)] = 0.0
    slip_std: NonNegFloat = 0.0
    steering_noise_std_deg: NonNegFloat = 0.0
    reflector_survey_std_m: Annotated[float, Field(ge=0.0, le=0.5)] = 0.0


class SteeringSpec(_Strict):
    """Steering actuator: rate and angle limits, first-order lag."""

    max_rate_deg_s: PosFloat = 60.0
    max_angle_deg: Annotated[float, Field(gt=0.0, le=90.0)] = 90.0
    time_constant_s: NonNegFloat = 0.05


class TractionSpec(_Strict):
    """Traction speed profile: cruise speed of C, acceleration limits, stop at the end."""

    speed_m_s: PosFloat = 0.2
    max_accel_m_s2: PosFloat = 0.3
    max_decel_m_s2: PosFloat = 0.3


class GoniometerSpec(_Strict):
    """Rotating laser head (seed 000 §4.1: 8 Hz, 65535 pulses/rev, 30 m)."""

    rate_hz: PosFloat = 8.0
    pulses_per_rev: Annotated[int, Field(gt=0)] = 65535
    mount: tuple[Finite, Finite, Finite] = Field((0.0, 0.0, 0.0), description="x (m), y (m), theta (deg) of P")
    min_range_m: NonNegFloat = 0.3
    max_range_m: PosFloat = 30.0
    p_miss: Annotated[float, Field(ge=0.0, le=1.0)] = 0.0
    spurious_rate_hz: NonNegFloat = 0.0
    jitter_std_s: NonNegFloat = 0.0


class LineSpec(_Strict):
    """A straight segment of ``length_m``; ``start``/``heading_deg`` default to the previous end."""

    type: Literal["line"]
    length_m: PosFloat
    direction: Direction = "forward"
    start: tuple[Finite, Finite] | None = None
    heading_deg: Finite | None = None


class ArcSpec(_Strict):
    """A circular arc of ``radius_m`` turning ``sweep_deg`` (positive = to the left, CCW)."""

    type: Literal["arc"]
    radius_m: PosFloat
    sweep_deg: Annotated[float, Field(allow_inf_nan=False)]
    direction: Direction = "forward"
    start: tuple[Finite, Finite] | None = None
    heading_deg: Finite | None = None

    @model_validator(mode="after")
    def _nonzero(self) -> ArcSpec:
        if self.sweep_deg == 0.0 or abs(self.sweep_deg) > 360.0:
            raise ValueError("sweep_deg must be non-zero and at most 360 in magnitude")
        return self


class PathSpec(_Strict):
    """The planned path of the guided point: a start pose and chained segments.

    A segment may give its own ``start`` (and ``heading_deg``); it must then
    coincide with the previous segment's end to within ``gap_tolerance_m``.
    """

    start: tuple[Finite, Finite, Finite] = Field(description="x (m), y (m), heading (deg)")
    segments: Annotated[list[Annotated[LineSpec | ArcSpec, Field(discriminator="type")]], Field(min_length=1)]
    gap_tolerance_m: PosFloat = 1e-3


class StartSpec(_Strict):
    """Initial placement relative to the path start (seed 000 §4.3: 110 mm off the path).

    ``lateral_offset_m`` displaces the guided point to the left of the path
    (negative: right); ``heading_offset_deg`` turns the vehicle;
    ``steering_deg`` is the initial wheel angle, or ``feedforward`` for the
    steady-state angle of the first segment's curvature.
    """

    lateral_offset_m: Finite = 0.0
    heading_offset_deg: Finite = 0.0
    steering_deg: Annotated[float, Field(gt=-90.0, lt=90.0)] | Literal["feedforward"] = 0.0


class ControllerSpec(_Strict):
    """Guidance law by name, with either closed-loop poles (per metre) or gains."""

    name: Literal["seed_general", "seed_simple", "pure_pursuit", "stanley"] = "seed_simple"
    point: Literal["C", "O"] = "C"
    poles_per_m: list[Finite] | None = None
    gains: dict[str, Finite] | None = None
    params: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _one_of(self) -> ControllerSpec:
        if self.poles_per_m is not None and self.gains is not None:
            raise ValueError("give either poles_per_m or gains, not both")
        return self


class PositioningSpec(_Strict):
    """Positioning method (issue 4) and its initialisation."""

    method: Literal["naive", "angle_propagation", "batch_ml", "ekf"] = "ekf"
    params: dict[str, Any] = Field(default_factory=dict)
    initial_error: tuple[Finite, Finite, Finite] = Field(
        (0.0, 0.0, 0.0), description="x (m), y (m), heading (deg) error of the initial estimate"
    )
    initial_std: tuple[NonNegFloat, NonNegFloat, NonNegFloat] = Field(
        (0.02, 0.02, 1.0), description="x (m), y (m), heading (deg) standard deviations"
    )
    odometry_noise: tuple[NonNegFloat, NonNegFloat, NonNegFloat] = Field(
        (0.001, 0.003, 0.001), description="k_d, k_dtheta, k_theta of the odometry covariance model"
    )


class _Sourced(_Strict):
    """A scenario document that remembers where it came from, for errors naming key and line.

    Shared by :class:`Scenario` and the tracked-robot scenario; subclasses have a
    ``seed`` field.
    """

    # Not part of the schema: where the scenario came from, for error messages.
    _source: str = ""
    _nodes: Any = None
    _base_dir: Path | None = None

    def locate(self, key: KeyPath) -> int | None:
        """1-based file line of the key path ``key`` (None if unknown)."""
        return node_line(self._nodes, key)

    def error(self, key: KeyPath, message: str) -> ScenarioError:
        """A :class:`ScenarioError` for ``key`` with its file line."""
        return ScenarioError(message, key, self.locate(key), self._source)

    @property
    def base_dir(self) -> Path | None:
        """Folder of the scenario file (relative map paths resolve against it)."""
        return self._base_dir

    def with_seed(self, seed: int) -> Self:
        """A copy with another random seed (keeps the source and line map)."""
        if seed < 0:
            raise ValueError(f"seed must be >= 0, got {seed}")
        return self._copy_attached({"seed": int(seed)})

    def _copy_attached(self, update: dict[str, Any]) -> Self:
        """``model_copy(update=...)`` that keeps the source, line map and folder."""
        new = self.model_copy(update=update)
        _attach(new, self._source, self._nodes, self._base_dir)
        return new


class Scenario(_Sourced):
    """A closed-loop run (issue 5 §4). All lengths in m, times in s, angles in deg."""

    name: str = "scenario"
    description: str = ""
    seed: Annotated[int, Field(ge=0)] = 0
    step_s: Annotated[float, Field(gt=0.0, le=0.1)] = 0.02
    duration_s: PosFloat | None = None
    end_hold_s: NonNegFloat = 1.0
    vehicle: VehicleSpec = VehicleSpec()
    truth: TruthErrorSpec = TruthErrorSpec()
    steering: SteeringSpec = SteeringSpec()
    traction: TractionSpec = TractionSpec()
    goniometer: GoniometerSpec = GoniometerSpec()
    map: str | dict[str, Any] = "lab"
    path: PathSpec
    start: StartSpec = StartSpec()
    controller: ControllerSpec = ControllerSpec()
    positioning: PositioningSpec = PositioningSpec()
    min_reflectors_in_view: Annotated[int, Field(ge=3)] = 3


def _attach(sc: _Sourced, source: str, nodes: Any, base_dir: Path | None) -> None:
    object.__setattr__(sc, "__pydantic_private__", {"_source": source, "_nodes": nodes, "_base_dir": base_dir})


def node_line(root: Any, key: KeyPath) -> int | None:
    """Walk a composed YAML node tree along ``key``; return the deepest line reached (1-based).

    For a mapping key that is present, the line of the *key* is returned (that is
    where the user looks); for an unknown key or index, the line of the deepest
    node that exists.
    """
    node, line = root, None
    if node is None:
        return None
    line = node.start_mark.line + 1
    for part in key:
        if isinstance(node, yaml.MappingNode):
            hit = next(((k, v) for k, v in node.value if getattr(k, "value", None) == str(part)), None)
            if hit is None:
                return line
            line, node = hit[0].start_mark.line + 1, hit[1]
        elif isinstance(node, yaml.SequenceNode) and isinstance(part, int) and 0 <= part < len(node.value):
            node = node.value[part]
            line = node.start_mark.line + 1
        else:
            return line
    return line


def _loc_to_key(loc: Sequence[Any], data: Any) -> KeyPath:
    """Drop pydantic's union/discriminator tags ("line", "arc", "str", ...) from an error location."""
    key: list[str | int] = []
    node = data
    for part in loc:
        if isinstance(node, Mapping) and isinstance(part, str) and part in node:
            key.append(part)
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int):
            key.append(part)
            node = node[part] if 0 <= part < len(node) else None
        elif isinstance(node, Mapping) and isinstance(part, str) and part not in node:
            # an unknown/missing key, or a union tag: keep it only if it is the last part
            if part is loc[-1] and part not in ("line", "arc", "str", "dict[str,any]"):
                key.append(part)
        # other tags (function-after[...], etc.) are skipped
    return tuple(key)


def _first_error(exc: ValidationError, data: Any) -> tuple[KeyPath, str]:
    errors = exc.errors(include_url=False)
    err = errors[0]
    key = _loc_to_key(err["loc"], data)
    msg = err["msg"]
    if err["type"] == "extra_forbidden":
        msg = "unknown key"
    elif err["type"] == "missing":
        msg = "required key is missing"
    elif err["type"] == "union_tag_invalid":
        msg = "type must be 'line' or 'arc'"
    elif key == ("map",):
        msg = "must be a shipped map name (e.g. lab), a map file path, or a mapping of reflectors and walls"
    if len(errors) > 1:
        msg += f" (and {len(errors) - 1} more problem{'s' if len(errors) > 2 else ''})"
    return key, msg


def parse_scenario(text: str, source: str = "<string>", base_dir: Path | None = None) -> Scenario:
    """Parse and validate scenario YAML ``text``; ScenarioError names key and line."""
    try:
        nodes = yaml.compose(text, Loader=yaml.SafeLoader)
        data = safe_load_unique(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(exc, "problem", None) or str(exc)
        raise ScenarioError(f"invalid YAML: {problem}", (), line, source) from None
    if not isinstance(data, Mapping):
        raise ScenarioError("a scenario must be a YAML mapping of keys", (), 1, source)
    from agvnav.world.tracked_scenario import is_tracked, parse_tracked

    if is_tracked(data):  # issue 6: the seed-004 tracked robot has its own schema
        return parse_tracked(data, nodes, source, base_dir)  # type: ignore[return-value]
    try:
        sc = Scenario.model_validate(data)
    except ValidationError as exc:
        key, msg = _first_error(exc, data)
        raise ScenarioError(msg, key, node_line(nodes, key), source) from None
    _attach(sc, source, nodes, base_dir)
    return sc


def load_scenario(path: str | Path) -> Scenario:
    """Load a scenario file, or a shipped scenario by name (``guidance_test``)."""
    p = Path(path)
    if not p.is_file() and p.suffix == "" and str(path) in builtin_scenario_names():
        p = builtin_scenario(str(path))
    if p.is_dir():
        raise ScenarioError("is a directory, not a scenario file", (), None, str(path))
    if not p.is_file():
        raise ScenarioError(
            f"no such scenario file (shipped scenarios: {', '.join(builtin_scenario_names())})", (), None, str(path)
        )
    return parse_scenario(p.read_text(encoding="utf-8"), source=str(path), base_dir=p.parent)


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
