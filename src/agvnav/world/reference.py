"""The scenario reference generated from the schema: every key, its unit, default and meaning.

:func:`schema_rows` walks the pydantic models of :mod:`agvnav.world.scenario`
(and every vehicle spec of the ``vehicle.model`` union) and returns one
:class:`KeyDoc` per key; :func:`scenario_reference` renders them as Markdown.
docs/scenarios.md is this output (a test regenerates it and compares), so the
reference cannot drift from the schema.
"""

from __future__ import annotations

import inspect
import types
import typing
from dataclasses import dataclass
from typing import Any, Literal, get_args, get_origin

from pydantic import BaseModel
from pydantic.fields import FieldInfo

from agvnav.world.fleet import (
    PER_VEHICLE_KEYS,
    SHARED_KEYS,
    FleetVehicleSpec,
    JobStreamSpec,
    TrafficSpec,
    TransportJobSpec,
)
from agvnav.world.limits import limits_reference
from agvnav.world.scenario import Scenario
from agvnav.world.strict import attribute_docs
from agvnav.world.vehicle_specs import VEHICLE_KINDS

__all__ = ["VEHICLE_SPECS", "KeyDoc", "fleet_reference", "scenario_reference", "schema_rows", "unit_of"]

#: The vehicle specs in the order the reference lists them (the kinds' registry).
VEHICLE_SPECS: tuple[type[BaseModel], ...] = tuple(VEHICLE_KINDS.values())

# key suffix -> unit, longest suffix first
_UNITS = (
    ("_deg_s", "deg/s"),
    ("_m_s2", "m/s²"),
    ("_m_s", "m/s"),
    ("_rad_s", "rad/s"),
    ("_deg", "deg"),
    ("_hz", "Hz"),
    ("_rpm", "rpm"),
    ("_per_rev", "counts/rev"),
    ("_per_m", "1/m"),
    ("_m", "m"),
    ("_s", "s"),
    ("_v", "V"),
)


def unit_of(key: str) -> str:
    """The unit a key's suffix names (``speed_m_s`` -> ``m/s``), or ``-`` for none."""
    for suffix, unit in _UNITS:
        if key.endswith(suffix):
            return unit
    return "-"


@dataclass(frozen=True)
class KeyDoc:
    """One scenario key: dotted ``key``, ``type``, ``unit``, ``default`` and ``meaning``."""

    key: str
    type: str
    unit: str
    default: str
    meaning: str


def _models_in(annotation: Any) -> list[type[BaseModel]]:
    """The pydantic models inside an annotation (through Optional, unions, Annotated)."""
    if inspect.isclass(annotation) and issubclass(annotation, BaseModel):
        return [annotation]
    out: list[type[BaseModel]] = []
    for arg in get_args(annotation):
        out += _models_in(arg)
    return out


def _type_name(annotation: Any) -> str:
    origin = get_origin(annotation)
    if origin is Literal:
        return " | ".join(repr(a) for a in get_args(annotation))
    if origin is typing.Annotated:
        return _type_name(get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        return " | ".join(_type_name(a) for a in get_args(annotation))
    if origin is not None:
        args = ", ".join(_type_name(a) for a in get_args(annotation))
        return f"{getattr(origin, '__name__', str(origin))}[{args}]"
    if inspect.isclass(annotation) and issubclass(annotation, BaseModel):
        return "mapping"
    return getattr(annotation, "__name__", str(annotation)).replace("NoneType", "null")


def _default(info: FieldInfo) -> str:
    if info.is_required():
        return "required"
    value = info.get_default(call_default_factory=True)
    if isinstance(value, BaseModel):
        return "(section)"
    return "null" if value is None else repr(value)


def _meaning(info: FieldInfo, doc: str | None, models: list[type[BaseModel]]) -> str:
    text = info.description or doc  # the Field's description, else the attribute docstring
    if text:
        return " ".join(text.split())  # a multi-line attribute docstring: one table cell
    if models:
        return " ".join((inspect.getdoc(models[0]) or "").split("\n\n")[0].split())
    return ""


def schema_rows(model: type[BaseModel], prefix: str = "") -> list[KeyDoc]:
    """One :class:`KeyDoc` per key of ``model`` and of its sub-sections, depth first."""
    rows: list[KeyDoc] = []
    docs = attribute_docs(model)
    for name, info in model.model_fields.items():
        key = f"{prefix}{name}"
        models = [m for m in _models_in(info.annotation) if m not in VEHICLE_SPECS]
        meaning = _meaning(info, docs.get(name), models)
        rows.append(KeyDoc(key, _type_name(info.annotation), unit_of(name), _default(info), meaning))
        is_list = "list[" in _type_name(info.annotation)
        for sub in models:
            rows += schema_rows(sub, f"{key}[]." if is_list else f"{key}.")
    return rows


def _table(rows: list[KeyDoc]) -> list[str]:
    lines = ["| key | type | unit | default | meaning |", "| --- | --- | --- | --- | --- |"]
    for r in rows:
        cells = (f"`{r.key}`", r.type, r.unit, r.default, r.meaning)
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return lines


def fleet_reference() -> list[str]:
    """The fleet section (issue 28): how a fleet document is laid out, and the keys of ``fleet.vehicles[]``."""
    own = ", ".join(f"`{k}`" for k in PER_VEHICLE_KEYS)
    shared = ", ".join(f"`{k}`" for k in SHARED_KEYS)
    rows = [r for r in schema_rows(FleetVehicleSpec, "fleet.vehicles[].") if r.key.count(".") == 2
            and r.key.rsplit(".", 1)[1] in ("id", "at")]
    return [
        "## Fleet scenarios: `fleet.vehicles`",
        "",
        "A fleet scenario (`agvnav simulate warehouse_fleet`) runs several vehicles in one world, stepped in lockstep:",
        "each vehicle's body hides reflectors from the others' goniometers, shows on their safety scanners and",
        "ultrasonic rangers, and a footprint contact between two vehicles (true poses) is a collision that ends the",
        f"run. The top-level keys are those above: the world and the time are shared ({shared}), and {own}",
        "are defaults a vehicle may give itself (its key replaces the shared one as a whole). A mission or a path is",
        "each vehicle's own. Vehicle 0 runs with the fleet's `seed`, vehicle i > 0 with a seed derived from it and i.",
        "Refused with file, line and key: duplicate ids, start footprints that overlap, a start pose off every node",
        "of the vehicle's network, more mission vehicles on a network than it has stations.",
        "",
        *_table(rows),
        "",
        "A fleet run writes `metrics.json` (`fleet`: vehicles, completed, jobs_completed, deliveries_per_hour,",
        "collisions, min_separation_m...; `vehicles`: one row per vehicle with the time it was slowed or stopped and",
        "why; `runs`: each vehicle's single-run metrics), `timing.json`, `timeseries.csv` (every vehicle's series",
        "in long form, `vehicle` its index first) and the plots `fleet_tracks.png`, `fleet_timeline.png`.",
        "",
        "### Transport jobs and traffic control: `fleet.jobs`, `fleet.job_stream`, `fleet.traffic`",
        "",
        "A fleet with transport jobs (or a `fleet.traffic` section) runs under traffic control (issue 30): every",
        "vehicle drives a mission on one route network (its own jobs first; `jobs: []` for none), the jobs are",
        "dispatched (nearest idle vehicle), all routes planned together over the conflict zones, and each vehicle",
        "stands at the node before a zone until the plan's action dependency graph lets it in (from the progress",
        "the others report). `fleet.jobs_file` names a YAML file with `jobs` and/or `job_stream` as here. The rows",
        "of `vehicles` add `dispatched_jobs`, `traffic_wait_s` and where (`traffic_wait_by_zone_s`,",
        "`traffic_wait_by_node_s`); `fleet` adds `traffic_wait_s`, `unserved_jobs`, `traffic_conflicts`.",
        "",
        *_table([*schema_rows(TrafficSpec, "fleet.traffic."), *schema_rows(TransportJobSpec, "fleet.jobs[]."),
                 *schema_rows(JobStreamSpec, "fleet.job_stream.")]),
    ]


def scenario_reference(outputs: list[str] | None = None) -> str:
    """The Markdown scenario reference: top-level keys, then the ``vehicle`` keys of every model.

    ``outputs``: Markdown lines documenting the output files (from :mod:`agvnav.report`),
    appended as their own section.
    """
    lines = [
        "# Scenario reference",
        "",
        "Generated from the schema (`agvnav.world.reference`; regenerate with",
        "`python -m agvnav.report.reference > docs/scenarios.md`). Units: SI, angles in degrees",
        "in keys ending `_deg`. Unknown keys are refused; every error names the file, line and key.",
        "",
        "## Top-level keys",
        "",
        *_table([r for r in schema_rows(Scenario) if r.key != "vehicle"]),
        "",
        "## `vehicle`: one section per `vehicle.model`",
    ]
    for spec in VEHICLE_SPECS:
        model = spec.model_fields["model"].annotation
        name = get_args(model)[0]
        doc = " ".join((inspect.getdoc(spec) or "").split("\n\n")[0].split())
        lines += ["", f"### `model: {name}`", "", doc, "", *_table(schema_rows(spec, "vehicle."))]
    lines += ["", *fleet_reference(), "", *limits_reference()]
    if outputs:
        lines += ["", *outputs]
    return "\n".join(lines) + "\n"
