"""The campaign's task functions: pure, top-level, seeded; each run becomes one small flat record.

A record holds ``run`` (index), ``seed``, ``outcome`` (``"completed"``,
``"failed"``: the run ended without completing its path, or ``"error"``: it
raised), ``reason`` (empty when completed), ``sim_time_s``, ``cpu_time_s`` (CPU
time of the run's thread, s), ``overrides`` (the swept values as JSON text),
one ``param.<dotted key>`` per swept parameter and one ``metric.<name>`` per
collected metric (numbers; booleans as 1.0/0.0; None when undefined). An
exception inside a run becomes an ``error`` record; it never escapes.

:func:`simulate_metrics` is the only function here that knows the simulator's
API, so a change there is one edit.
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agvnav.campaign.overrides import apply_overrides, dump_yaml, parse_document
from agvnav.sim import simulate
from agvnav.sim.fleet import simulate_fleet
from agvnav.sim.metrics import RunMetrics
from agvnav.world import builtin_map_names, load_builtin_map
from agvnav.world.fleet import FleetScenario
from agvnav.world.scenario import Scenario
from agvnav.world.strict import load_yaml_document

__all__ = [
    "METRIC_SECTIONS",
    "SimSummary",
    "flatten",
    "is_metric_name",
    "metric_names",
    "run_batch",
    "run_one",
    "simulate_metrics",
]

Record = dict[str, Any]
#: One run of a batch: (run index, swept overrides, seed).
RunItem = tuple[int, Mapping[str, Any], int]


@dataclass(frozen=True)
class SimSummary:
    """What a campaign keeps of one simulation: flat numeric metrics, completion, reason, simulated time (s)."""

    metrics: dict[str, float | None]
    completed: bool
    reason: str
    sim_time_s: float | None


#: Nested metric sections of a run, collected as ``<section>.<name>`` (their names vary by vehicle); a fleet
#: run's metrics are its figures, ``fleet.<name>`` (``fleet.deliveries_per_hour``, ``fleet.jobs_completed``).
METRIC_SECTIONS = ("integrity", "extra", "fleet")

#: Fleet figures that are timing, not results (never collected).
FLEET_TIMING = ("cpu_time_s", "wall_time_s", "real_time_factor_cpu", "us_per_vehicle_step")


def metric_names() -> list[str]:
    """Names of the metrics every run reports (the fields of :class:`agvnav.sim.RunMetrics`)."""
    return [f.name for f in dataclasses.fields(RunMetrics)]


def is_metric_name(name: str) -> bool:
    """True for a :func:`metric_names` name or a ``<section>.<name>`` of :data:`METRIC_SECTIONS`."""
    return name in metric_names() or (name.split(".", 1)[0] in METRIC_SECTIONS and "." in name)


def flatten(values: Mapping[str, Any], prefix: str = "") -> dict[str, float | None]:
    """Nested mapping -> ``{"a.b": number}``; booleans become 1.0/0.0, None stays; other values are dropped."""
    out: dict[str, float | None] = {}
    for key, value in values.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            out.update(flatten(value, name + "."))
        elif value is None:
            out[name] = None
        elif isinstance(value, bool | int | float):
            out[name] = float(value)
    return out


def simulate_metrics(scenario: Scenario | FleetScenario) -> SimSummary:
    """Run ``scenario`` with :func:`agvnav.sim.simulate` (a fleet with :func:`agvnav.sim.fleet.simulate_fleet`);
    the adapter between campaigns and the simulator."""
    if isinstance(scenario, FleetScenario):
        return fleet_metrics(scenario)
    result = simulate(scenario)
    raw = result.metrics
    metrics = flatten(raw() if callable(raw) else raw.to_dict())  # the tracked automaton's metrics are a method
    metrics.update(flatten({s: getattr(result, s, None) or {} for s in METRIC_SECTIONS}))
    outcome = getattr(result, "outcome", None)
    completed = outcome == "completed" if outcome is not None else metrics.get("path_completed", 1.0) == 1.0
    reason = "" if completed else str(getattr(result, "reason", None) or "path not completed")
    return SimSummary(metrics, completed, reason, metrics.get("sim_time_s"))


def fleet_metrics(fleet: FleetScenario) -> SimSummary:
    """Run a fleet scenario; its figures (without timing) as ``fleet.<name>``, completed when every vehicle did."""
    result = simulate_fleet(fleet)
    figures = {k: v for k, v in result.figures.items() if k not in FLEET_TIMING}
    metrics = flatten({"fleet": figures})
    return SimSummary(metrics, result.completed, "" if result.completed else str(result.reason or "failed"),
                      metrics.get("fleet.sim_time_s"))


def _record(index: int, overrides: Mapping[str, Any], seed: int) -> Record:
    rec: Record = {"run": int(index), "seed": int(seed), "overrides": json.dumps(dict(overrides), sort_keys=True)}
    rec.update({f"param.{k}": v for k, v in overrides.items()})
    return rec


def _scenario(
    base: Mapping[str, Any], overrides: Mapping[str, Any], source: str, base_dir: str | None,
    maps: dict[str, dict[str, Any]],
) -> Scenario | FleetScenario:
    """The scenario of one set of overrides, a shipped map (``map: lab``) given inline.

    Every run builds its world from the scenario: a shipped map named there is read and
    parsed from its YAML file each time (about 8 ms, more than a short run's simulation),
    the same map inline is only validated (under 1 ms; ``WorldMap.from_dict`` of
    ``to_dict`` gives an equal map). ``maps`` caches the inline form by name for a batch.
    """
    mapping = apply_overrides(base, overrides)
    name = mapping.get("map")
    if isinstance(name, str) and name in builtin_map_names():
        if name not in maps:
            maps[name] = load_builtin_map(name).to_dict()
        mapping = {**mapping, "map": maps[name]}
    return parse_document(dump_yaml(mapping), source=source, base_dir=Path(base_dir) if base_dir else None)


def _simulate_record(rec: Record, scenario: Scenario | FleetScenario, seed: int,
                     metrics: Sequence[str] | None) -> Record:
    t0 = time.thread_time()
    try:
        summary = simulate_metrics(scenario.with_seed(seed))
    except Exception as exc:  # any failure of a run is its outcome, never the campaign's
        return {**rec, "outcome": "error", "reason": _reason(exc), "cpu_time_s": time.thread_time() - t0}
    chosen = summary.metrics if metrics is None else {m: summary.metrics.get(m) for m in metrics}
    return {
        **rec,
        "outcome": "completed" if summary.completed else "failed",
        "reason": summary.reason,
        "sim_time_s": summary.sim_time_s,
        "cpu_time_s": time.thread_time() - t0,
        **{f"metric.{k}": v for k, v in chosen.items()},
    }


def _reason(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def run_one(
    scenario_text: str,
    overrides: Mapping[str, Any],
    seed: int,
    metrics: Sequence[str] | None = None,
    *,
    index: int = 0,
    source: str = "<campaign>",
    base_dir: str | None = None,
) -> Record:
    """Run the scenario ``scenario_text`` with dotted-key ``overrides`` and ``seed``; one flat record.

    ``metrics`` None keeps every metric. ``base_dir`` resolves a relative map path.
    """
    return run_batch(scenario_text, [(index, overrides, seed)], metrics, source=source, base_dir=base_dir)[0]


def run_batch(
    scenario_text: str,
    runs: Sequence[RunItem],
    metrics: Sequence[str] | None = None,
    *,
    source: str = "<campaign>",
    base_dir: str | None = None,
) -> list[Record]:
    """Run many ``(index, overrides, seed)`` of one base scenario; one record each, in order.

    The Dask task: pure (same arguments, same records except the timings), and a
    run that raises is an ``error`` record. Runs with the same overrides share
    one parsed scenario.
    """
    parsed: dict[str, Scenario | FleetScenario | Exception] = {}
    maps: dict[str, dict[str, Any]] = {}
    out = []
    base: Mapping[str, Any] | None = None
    for index, overrides, seed in runs:
        rec = _record(index, overrides, seed)
        key = rec["overrides"]
        if key not in parsed:
            try:
                if base is None:
                    base = load_yaml_document(scenario_text, source)[0]
                parsed[key] = _scenario(base, overrides, source, base_dir, maps)
            except Exception as exc:  # an invalid run is an error record
                parsed[key] = exc
        sc = parsed[key]
        if isinstance(sc, Exception):
            out.append({**rec, "outcome": "error", "reason": _reason(sc), "cpu_time_s": 0.0})
        else:
            out.append(_simulate_record(rec, sc, seed, metrics))
    return out
