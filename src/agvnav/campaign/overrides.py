"""Scenario overrides by dotted key: ``{"traction.speed_m_s": 0.3}`` on the base scenario's YAML mapping.

A dotted key walks nested mappings (missing ones are created) and, with an
integer part, list items (``path.segments.0.radius_m``). Overrides never
mutate their input: every function returns a new mapping. The result is turned
back into YAML text and validated by :func:`parse_document` (a scenario, or a
fleet scenario when the document has a ``fleet`` key), so the scenario schema,
not this module, decides what a value may be.

A fleet's size is the one key that is not a scenario key: ``fleet.size: N``
keeps the first ``N`` vehicles of ``fleet.vehicles`` (applied after the other
overrides), so a campaign sweeps the fleet size over the vehicles its base
scenario lists (:data:`FLEET_SIZE_KEY`).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from agvnav.world import builtin_map_names
from agvnav.world.fleet import FleetScenario, is_fleet_document, parse_fleet
from agvnav.world.scenario import Scenario, ScenarioError, builtin_scenario, builtin_scenario_names, parse_scenario
from agvnav.world.strict import load_yaml_document

__all__ = [
    "FLEET_SIZE_KEY",
    "BaseScenario",
    "apply_overrides",
    "dump_yaml",
    "load_base",
    "parse_document",
    "replay_mapping",
    "set_dotted",
]

#: The dotted key of a fleet's size: the first N vehicles of ``fleet.vehicles``.
FLEET_SIZE_KEY = "fleet.size"


def parse_document(text: str, source: str, base_dir: Path | None = None) -> Scenario | FleetScenario:
    """A scenario, or a fleet scenario when the document lists a fleet (a ``fleet`` key); ScenarioError located."""
    data, _ = load_yaml_document(text, source, "scenario")
    if is_fleet_document(data):
        return parse_fleet(text, source=source, base_dir=base_dir)
    return parse_scenario(text, source=source, base_dir=base_dir)


@dataclass(frozen=True)
class BaseScenario:
    """The campaign's base scenario: its YAML text and mapping, where it came from, its folder."""

    text: str
    mapping: dict[str, Any]
    source: str
    base_dir: Path | None


def load_base(base: str) -> BaseScenario:
    """Read and validate the base scenario: a shipped name (``guidance_test``) or a file path.

    Raises
    ------
    ScenarioError
        If the file is missing or the scenario is invalid (naming its file, line and key).
    """
    p = Path(base)
    if not p.is_file() and p.suffix == "" and base in builtin_scenario_names():
        p = builtin_scenario(base)
    if not p.is_file():
        raise ScenarioError(f"no such scenario file (shipped: {', '.join(builtin_scenario_names())})", (), None, base)
    text = p.read_text(encoding="utf-8")
    parse_document(text, source=base, base_dir=p.parent)
    mapping, _ = load_yaml_document(text, base)
    return BaseScenario(text, dict(mapping), base, p.parent)


def set_dotted(mapping: Mapping[str, Any], key: str, value: Any) -> dict[str, Any]:
    """A deep copy of ``mapping`` with ``value`` at the dotted ``key``.

    Raises
    ------
    ValueError
        If a part of ``key`` runs into a value that is neither a mapping nor a list,
        or indexes a list out of range.
    """
    out = copy.deepcopy(dict(mapping))
    parts = key.split(".")
    node: Any = out
    for i, part in enumerate(parts):
        last = i == len(parts) - 1
        where = ".".join(parts[: i + 1])
        if isinstance(node, dict):
            if last:
                node[part] = copy.deepcopy(value)
            else:
                node = node.setdefault(part, {})
        elif isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise ValueError(f"{key}: {where} is not an index of a list of {len(node)} items")
            if last:
                node[int(part)] = copy.deepcopy(value)
            else:
                node = node[int(part)]
        else:
            raise ValueError(f"{key}: {'.'.join(parts[:i])} is a value ({node!r}), not a mapping or a list")
    return out


def apply_overrides(mapping: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """``mapping`` with every dotted-key override applied, in order, the fleet's size last (a new mapping)."""
    out = dict(mapping)
    for key, value in overrides.items():
        if key != FLEET_SIZE_KEY:
            out = set_dotted(out, key, value)
    if FLEET_SIZE_KEY in overrides:
        out = fleet_of_size(out, overrides[FLEET_SIZE_KEY])
    return out


def fleet_of_size(mapping: Mapping[str, Any], size: Any) -> dict[str, Any]:
    """A fleet document keeping the first ``size`` of its vehicles (ValueError naming :data:`FLEET_SIZE_KEY`)."""
    fleet = mapping.get("fleet")
    vehicles = fleet.get("vehicles") if isinstance(fleet, Mapping) else None
    if not isinstance(vehicles, list):
        raise ValueError(f"{FLEET_SIZE_KEY}: the base scenario is not a fleet (give it fleet.vehicles)")
    if isinstance(size, bool) or not isinstance(size, int) or not 1 <= size <= len(vehicles):
        raise ValueError(f"{FLEET_SIZE_KEY}: {size!r} is not a fleet size of 1 to {len(vehicles)} (the vehicles the "
                         f"base scenario lists)")
    out = copy.deepcopy(dict(mapping))
    out["fleet"]["vehicles"] = out["fleet"]["vehicles"][:size]
    return out


def dump_yaml(mapping: Mapping[str, Any]) -> str:
    """YAML text of a plain mapping, keys in their order (libyaml's dumper when available)."""
    dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
    return str(yaml.dump(dict(mapping), Dumper=dumper, sort_keys=False, allow_unicode=True))


def replay_mapping(base: BaseScenario, overrides: Mapping[str, Any], seed: int) -> dict[str, Any]:
    """The whole scenario of one run (overrides and ``seed`` applied) for ``agvnav simulate``.

    A map given as a path relative to the base scenario becomes absolute, so the
    file can be written anywhere.
    """
    out = apply_overrides(base.mapping, {**overrides, "seed": int(seed)})
    m = out.get("map")
    if isinstance(m, str) and m not in builtin_map_names() and base.base_dir is not None and not Path(m).is_absolute():
        out["map"] = str((base.base_dir / m).resolve())
    return out
