"""Fleet scenarios (issue 28): several vehicles in one world, each a scenario of its own.

A fleet document is a scenario document whose vehicles are listed under ``fleet.vehicles``.
The top-level keys are shared: the world (``map``, ``world_truth``, ``obstacles``), the time
(``seed``, ``step_s``, ``duration_s``, ``end_hold_s``) and defaults every vehicle takes unless it
gives the same key itself (``vehicle``, ``goniometer``, ``positioning``, ``traction``,
``safety``, ``controller``, ``scanner``, ``reactive``, ``ultrasonic``, ...). Each vehicle has an
``id``, its own ``mission`` (or ``path``), and optionally ``at``: the node it starts at
(a node id, or a pose ``[x, y, heading_deg]`` that must lie on a node of its mission's
network). A vehicle's key replaces the shared key of the same name as a whole (no deep merge).

Each vehicle becomes an ordinary :class:`~agvnav.world.scenario.Scenario`
(:meth:`FleetScenario.vehicle_scenarios`) whose errors name the fleet file, the line, and
the key in the fleet file (``fleet.vehicles[2].mission.start`` for a vehicle's own key,
``goniometer.mount`` for a shared one): a single-vehicle run and a fleet build the same parts.
Vehicle 0 runs with the fleet's ``seed``; vehicle ``i > 0`` with a seed derived from it and
``i`` (:func:`vehicle_seed`), so a fleet of one reproduces the single-vehicle scenario.

The checks that need the vehicles built (start footprints overlapping, a start off every route
of the mission, more vehicles than stations) are :mod:`agvnav.sim.fleet`'s; this module checks
the document: unknown keys, duplicate ids, a vehicle without a mission or path.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import yaml
from pydantic import Field, model_validator

from agvnav.world.obstacles import ObstacleSpec, ReactiveSpec, ScannerSpec
from agvnav.world.scenario import (
    ControllerSpec,
    FaultSpec,
    GoniometerSpec,
    MissionSpec,
    PathSpec,
    PositioningSpec,
    SafetySpec,
    Scenario,
    StartSpec,
    TractionSpec,
    UltrasonicSpec,
    WorldTruthSpec,
    _scenarios_dir,
)
from agvnav.world.strict import (
    Finite,
    KeyPath,
    NonNegFloat,
    PosFloat,
    ScenarioError,
    SourcedModel,
    StrictModel,
    load_yaml_document,
    node_line,
    read_document_text,
    resolve_document,
    validate_document,
)
from agvnav.world.vehicle_specs import VehicleSpec

__all__ = [
    "FLEET_ONLY_KEYS",
    "MAX_FLEET_VEHICLES",
    "PER_VEHICLE_KEYS",
    "SHARED_KEYS",
    "FleetScenario",
    "FleetSpec",
    "FleetVehicleSpec",
    "JobStreamSpec",
    "TrafficSpec",
    "TransportJobSpec",
    "VehicleSections",
    "is_fleet_document",
    "load_fleet",
    "parse_fleet",
    "vehicle_seed",
]

#: Most vehicles a fleet document may list.
MAX_FLEET_VEHICLES = 1000

#: Keys only the fleet as a whole has (the world and the time).
SHARED_KEYS = ("name", "description", "seed", "step_s", "duration_s", "end_hold_s", "map", "world_truth", "obstacles",
               "record_step_s")

#: Keys of the fleet document that no vehicle's scenario has.
FLEET_ONLY_KEYS = ("fleet", "record_step_s")

#: Keys a vehicle may give itself (replacing the shared default of the same name).
PER_VEHICLE_KEYS = (
    "vehicle", "traction", "goniometer", "ultrasonic", "path", "mission", "start", "controller", "positioning",
    "min_reflectors_in_view", "safety", "faults", "scanner", "reactive",
)


class VehicleSections(StrictModel):
    """The scenario sections a fleet's vehicle may give itself; at the top of the file, the fleet's defaults.

    In ``fleet.vehicles[]`` a section replaces the default of the same name as a whole; null (not
    given) takes the default.
    """

    vehicle: VehicleSpec | None = None
    """the vehicle."""
    traction: TractionSpec | None = None
    """the speed profile."""
    goniometer: GoniometerSpec | None = None
    """the goniometer."""
    ultrasonic: UltrasonicSpec | None = None
    """the ultrasonic rangers."""
    controller: ControllerSpec | None = None
    """the path follower."""
    positioning: PositioningSpec | None = None
    """the estimator."""
    min_reflectors_in_view: Annotated[int, Field(ge=3)] | None = None
    """reflectors the goniometer must see all along the route."""
    safety: SafetySpec | None = None
    """the positioning guard."""
    faults: list[FaultSpec] | None = None
    """faults injected into the vehicle."""
    scanner: ScannerSpec | None = None
    """the safety scanner."""
    reactive: ReactiveSpec | None = None
    """the safety fields and reaction."""


class FleetVehicleSpec(VehicleSections):
    """One vehicle of the fleet: its id, where it starts, and the scenario keys it gives itself."""

    id: Annotated[str, Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")]
    """name of the vehicle (unique in the fleet; letters, digits, _ . -)."""
    at: str | tuple[Finite, Finite, Finite] | None = None
    """start of a mission vehicle: a node id of its network, or a pose x (m), y (m), heading (deg) on a node
    (null: the mission's start)."""
    mission: MissionSpec | None = None
    """its mission on a route network."""
    path: PathSpec | None = None
    """its path, instead of a mission."""
    start: StartSpec | None = None
    """initial placement relative to its path start."""


class TransportJobSpec(StrictModel):
    """A transport job (issue 30): pick at station ``pick``, drop at station ``drop``."""

    id: Annotated[str, Field(min_length=1, max_length=64)]
    """name of the job (unique)."""
    pick: str
    """station where the load is picked."""
    drop: str
    """station where it is dropped."""
    release_s: NonNegFloat = 0.0
    """the pick may not start before this time."""
    priority: int = 0
    """higher first among jobs released at the same time."""
    pick_s: NonNegFloat = 3.0
    """time the pick takes."""
    drop_s: NonNegFloat = 3.0
    """time the drop takes."""


class JobStreamSpec(StrictModel):
    """Transport jobs generated at a rate (Poisson releases) between random distinct stations."""

    rate_per_h: PosFloat
    """mean jobs per hour."""
    count: Annotated[int, Field(ge=1, le=100000)]
    """how many jobs."""
    seed: Annotated[int, Field(ge=0)] = 0
    """random seed of the stream."""
    stations: list[str] | None = None
    """stations to pick at and drop to (null: every station of the network that is no vehicle's start)."""
    pick_s: NonNegFloat = 3.0
    """time each pick takes."""
    drop_s: NonNegFloat = 3.0
    """time each drop takes."""


class TrafficSpec(StrictModel):
    """Traffic control of a fleet on its route network (issue 30): routes planned together, kept through an ADG."""

    margin_m: NonNegFloat = 0.2
    """safety margin between two vehicles' swept footprints (m) for the conflict zones: covers positioning and
    tracking errors (widened by each vehicle's guided point offset and body beyond its model's footprint)."""
    home: bool = True
    """each vehicle drives back to its start after its work (false: it parks where its last job ends)."""
    follow_adg: bool = True
    """vehicles stand at the hold points until the ADG lets them enter the next conflict zone; false: the plans
    are driven without hold points (for comparison only: what the traffic control prevents)."""


class FleetSpec(StrictModel):
    """The vehicles of a fleet scenario (issue 28), each driving its own mission or path; the transport jobs."""

    vehicles: Annotated[list[FleetVehicleSpec], Field(min_length=1, max_length=MAX_FLEET_VEHICLES)]
    """the vehicles, each with an id and its mission (or path)."""
    jobs: list[TransportJobSpec] | None = None
    """transport jobs dispatched to the mission vehicles after their own jobs (issue 30)."""
    job_stream: JobStreamSpec | None = None
    """transport jobs generated at a rate (issue 30)."""
    jobs_file: str | None = None
    """a YAML file (relative to the scenario) with ``jobs`` and/or ``job_stream`` as here."""
    traffic: TrafficSpec | None = None
    """traffic control (on whenever there are transport jobs; give it to plan the vehicles' own missions together,
    or to set its margin)."""

    @model_validator(mode="after")
    def _unique_ids(self) -> FleetSpec:
        seen: set[str] = set()
        for v in self.vehicles:
            if v.id in seen:
                raise ValueError(f"duplicate vehicle id {v.id!r}")
            seen.add(v.id)
        return self


class FleetScenario(VehicleSections, SourcedModel):
    """A fleet run: shared world, time and defaults, and ``fleet.vehicles``. Lengths m, times s, angles deg."""

    name: str = "fleet"
    """fleet scenario name (used in outputs)."""
    description: str = ""
    """one-line description."""
    seed: Annotated[int, Field(ge=0)] = 0
    """random seed of the fleet (vehicle 0 runs with it, the others with seeds derived from it)."""
    step_s: Annotated[float, Field(gt=0.0, le=0.1)] = 0.02
    """control period, the same for every vehicle (they are stepped in lockstep)."""
    duration_s: PosFloat | None = None
    """simulated time limit (default: the longest of the vehicles' own limits)."""
    end_hold_s: NonNegFloat = 1.0
    """time recorded after each vehicle stops at its end."""
    map: str | dict[str, Any] = "lab"
    """the shared map: a shipped name, a file path (relative to the scenario), or inline."""
    world_truth: WorldTruthSpec = WorldTruthSpec()
    """how the real world differs from the map (shared)."""
    obstacles: list[ObstacleSpec] | None = None
    """obstacles the map does not hold (shared by every vehicle)."""
    record_step_s: PosFloat | None = None
    """time between two recorded rows of each vehicle's series (s; rounded to whole steps); null: automatic,
    every step unless the fleet's rows would pass 2,000,000 (an 8-hour shift of 50 vehicles records about
    every 0.75 s). The fleet's figures are counted every step whatever the rate."""
    fleet: FleetSpec
    """the vehicles."""

    # Not part of the schema: the raw document (a vehicle's keys replace the shared ones as written).
    _data: Any = None

    @property
    def ids(self) -> list[str]:
        """The vehicle ids, in order."""
        return [v.id for v in self.fleet.vehicles]

    def vehicle_key(self, i: int, key: KeyPath) -> KeyPath:
        """The key in the fleet file of key ``key`` of vehicle ``i``'s scenario (its own key, or the shared one)."""
        if key and key[0] in self._vehicle_data(i):
            return ("fleet", "vehicles", i, *key)
        return key

    def vehicle_error(self, i: int, key: KeyPath, message: str) -> ScenarioError:
        """A located error about key ``key`` of vehicle ``i``'s scenario (see :meth:`vehicle_key`)."""
        return self.error(self.vehicle_key(i, key), message)

    def relocate(self, i: int, exc: ScenarioError) -> ScenarioError:
        """``exc`` raised by vehicle ``i``'s scenario, its key as written in the fleet file, naming the vehicle."""
        key = self.vehicle_key(i, exc.key)
        return ScenarioError(f"vehicle {self.ids[i]!r}: {exc.detail}", key, self.locate(key), self.source)

    def _vehicle_data(self, i: int) -> dict[str, Any]:
        raw = self._raw_vehicle(i)
        return {k: v for k, v in raw.items() if k in PER_VEHICLE_KEYS}

    def _raw_vehicle(self, i: int) -> dict[str, Any]:
        data = getattr(self, "_data", None)
        if data is None:
            return {}
        vehicles = data["fleet"]["vehicles"]
        return dict(vehicles[i])

    def with_seed(self, seed: int) -> FleetScenario:
        """A copy with another fleet seed (keeps the source, line map and the raw document)."""
        if seed < 0:
            raise ValueError(f"seed must be >= 0, got {seed}")
        new = self.copy_attached({"seed": int(seed)})
        new.__pydantic_private__["_data"] = getattr(self, "_data", None)  # type: ignore[index]
        return new

    def vehicle_scenarios(self) -> list[Scenario]:
        """Every vehicle as a :class:`Scenario` (see the module docstring); errors located in the fleet file."""
        return [self.vehicle_scenario(i) for i in range(len(self.fleet.vehicles))]

    def vehicle_scenario(self, i: int) -> Scenario:
        """Vehicle ``i`` as a :class:`Scenario`: the shared keys, then its own; its seed :func:`vehicle_seed`."""
        data: dict[str, Any] = getattr(self, "_data", None) or {}
        nodes = self._nodes
        own = self._vehicle_data(i)
        merged: dict[str, Any] = {k: v for k, v in data.items() if k not in FLEET_ONLY_KEYS}
        merged.update(own)
        vid = self.fleet.vehicles[i].id
        merged["name"] = f"{self.name}.{vid}"
        merged["seed"] = vehicle_seed(self.seed, i)
        v_node = _vehicle_node(nodes, i)
        pairs = []
        if isinstance(nodes, yaml.MappingNode):
            pairs += [(k, v) for k, v in nodes.value if getattr(k, "value", None) not in (*FLEET_ONLY_KEYS, *own)]
        if isinstance(v_node, yaml.MappingNode):
            pairs += [(k, v) for k, v in v_node.value if getattr(k, "value", None) in own]
        mark = (v_node or nodes).start_mark if (v_node or nodes) is not None else None
        v_nodes = yaml.MappingNode("tag:yaml.org,2002:map", pairs, mark, mark) if mark is not None else None
        try:
            return validate_document(Scenario, merged, v_nodes, self.source, self.base_dir)
        except ScenarioError as exc:
            raise self.relocate(i, exc) from None


def vehicle_seed(seed: int, i: int) -> int:
    """Seed of vehicle ``i`` of a fleet seeded ``seed``: ``seed`` itself for vehicle 0, else one derived
    from both (``numpy.random.SeedSequence(seed, spawn_key=(i,))``, 32 bits): independent streams."""
    if i == 0:
        return int(seed)
    return int(np.random.SeedSequence(seed, spawn_key=(i,)).generate_state(1)[0])


def _vehicle_node(nodes: Any, i: int) -> Any:
    """The composed node of ``fleet.vehicles[i]`` (None when absent)."""
    if not isinstance(nodes, yaml.MappingNode):
        return None
    fleet = next((v for k, v in nodes.value if getattr(k, "value", None) == "fleet"), None)
    if not isinstance(fleet, yaml.MappingNode):
        return None
    vehicles = next((v for k, v in fleet.value if getattr(k, "value", None) == "vehicles"), None)
    if not isinstance(vehicles, yaml.SequenceNode) or not 0 <= i < len(vehicles.value):
        return None
    return vehicles.value[i]


def is_fleet_document(data: Any) -> bool:
    """True when a loaded scenario document lists a fleet (a top-level ``fleet`` key)."""
    return isinstance(data, Mapping) and "fleet" in data


def parse_fleet(text: str, source: str = "<string>", base_dir: Path | None = None) -> FleetScenario:
    """Parse and validate fleet scenario YAML ``text``; a ScenarioError names file, line and key."""
    data, nodes = load_yaml_document(text, source, "scenario")
    if not is_fleet_document(data):
        raise ScenarioError("not a fleet scenario: give the fleet key (fleet.vehicles)", (), 1, source)
    _check_unique_ids(data, nodes, source)
    doc = validate_document(FleetScenario, data, nodes, source, base_dir)
    doc.__pydantic_private__["_data"] = data  # type: ignore[index]  # a vehicle's keys replace the shared ones
    line = node_line(nodes, ("fleet", "vehicles"))
    for i, v in enumerate(doc.fleet.vehicles):
        raw = doc._raw_vehicle(i)
        if v.mission is None and v.path is None:
            raise ScenarioError(f"vehicle {v.id!r} has no mission or path: give it one", ("fleet", "vehicles", i),
                                node_line(nodes, ("fleet", "vehicles", i)) or line, source)
        if v.at is not None and v.mission is None and "mission" not in raw:
            raise ScenarioError(f"vehicle {v.id!r}: at places a mission vehicle; a path vehicle starts at its path",
                                ("fleet", "vehicles", i, "at"), node_line(nodes, ("fleet", "vehicles", i, "at")),
                                source)
    return doc


def _check_unique_ids(data: Mapping[str, Any], nodes: Any, source: str) -> None:
    """The second vehicle with an id already used: refused at its ``id`` key."""
    fleet = data.get("fleet")
    vehicles = fleet.get("vehicles") if isinstance(fleet, Mapping) else None
    if not isinstance(vehicles, list):
        return
    seen: dict[str, int] = {}
    for i, v in enumerate(vehicles):
        vid = v.get("id") if isinstance(v, Mapping) else None
        if not isinstance(vid, str):
            continue
        if vid in seen:
            key: KeyPath = ("fleet", "vehicles", i, "id")
            raise ScenarioError(f"duplicate vehicle id {vid!r} (vehicle {seen[vid]} has it)", key,
                                node_line(nodes, key), source)
        seen[vid] = i


def load_fleet(path: str | Path) -> FleetScenario:
    """Load a fleet scenario file, or a shipped one by name (``warehouse_fleet``)."""
    p = resolve_document(path, _scenarios_dir(), "scenario")
    text = read_document_text(p, "scenario", str(path))
    return parse_fleet(text, source=str(path), base_dir=p.parent)
