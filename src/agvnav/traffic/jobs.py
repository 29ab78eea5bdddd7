"""Transport jobs (issue 30): listed (``fleet.jobs``), generated at a rate (``fleet.job_stream``) or in a file.

A job picks a load at one station and drops it at another, no earlier than its release time; jobs
released together go in priority order (higher first). A generated stream draws Poisson releases
(exponential gaps of mean ``3600 / rate_per_h`` s) and pick/drop stations uniformly among distinct
stations, from its own seed. Every station is checked against the network: an unknown one is a
:class:`~agvnav.world.strict.ScenarioError` naming the file, line and key.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from agvnav.routes.network import RouteNetwork
from agvnav.world.fleet import FleetScenario, JobStreamSpec, TransportJobSpec
from agvnav.world.strict import (
    KeyPath,
    SourcedModel,
    load_yaml_document,
    read_document_text,
    validate_document,
)

__all__ = ["JobsDocument", "TransportJob", "fleet_jobs", "generate_jobs", "load_jobs"]


@dataclass(frozen=True)
class TransportJob:
    """Pick at ``pick``, drop at ``drop`` (station ids); release (s), priority, pick and drop times (s)."""

    id: str
    pick: str
    drop: str
    release_s: float = 0.0
    priority: int = 0
    pick_s: float = 3.0
    drop_s: float = 3.0


class JobsDocument(SourcedModel):
    """A jobs file: ``jobs`` and/or ``job_stream``, as in a fleet scenario's ``fleet`` section."""

    jobs: list[TransportJobSpec] | None = None
    """the jobs."""
    job_stream: JobStreamSpec | None = None
    """jobs generated at a rate."""


def generate_jobs(stream: JobStreamSpec, stations: Sequence[str], prefix: str = "G") -> list[TransportJob]:
    """The jobs of a stream (module doc) among ``stations`` (at least two)."""
    if len(stations) < 2:
        raise ValueError(f"a job stream needs at least two stations, got {list(stations)}")
    rng = np.random.default_rng(stream.seed)
    gaps = rng.exponential(3600.0 / stream.rate_per_h, stream.count)
    out = []
    for i, t in enumerate(np.cumsum(gaps) - gaps[0]):
        a, b = rng.choice(len(stations), 2, replace=False)
        out.append(TransportJob(f"{prefix}{i + 1}", stations[int(a)], stations[int(b)], float(t), 0,
                                stream.pick_s, stream.drop_s))
    return out


def _from_specs(specs: Sequence[TransportJobSpec]) -> list[TransportJob]:
    return [TransportJob(j.id, j.pick, j.drop, j.release_s, j.priority, j.pick_s, j.drop_s) for j in specs]


def _check(doc: SourcedModel, key: KeyPath, jobs: Sequence[TransportJobSpec], stream: JobStreamSpec | None,
           network: RouteNetwork) -> None:
    seen: set[str] = set()
    for i, j in enumerate(jobs):
        if j.id in seen:
            raise doc.error((*key, "jobs", i, "id"), f"duplicate job id {j.id!r}")
        seen.add(j.id)
        for end in ("pick", "drop"):
            st = getattr(j, end)
            if st not in network.nodes:
                raise doc.error((*key, "jobs", i, end), f"unknown station {st!r} in network {network.name!r}")
        if j.pick == j.drop:
            raise doc.error((*key, "jobs", i, "drop"), f"drop station {j.drop!r} is the pick station")
    for i, st in enumerate(stream.stations or [] if stream is not None else []):
        if st not in network.nodes:
            raise doc.error((*key, "job_stream", "stations", i), f"unknown station {st!r} in network {network.name!r}")


def load_jobs(path: str | Path, network: RouteNetwork, free_stations: Sequence[str]) -> list[TransportJob]:
    """The jobs of a jobs file (``jobs`` then a ``job_stream``); errors name the file, line and key."""
    p = Path(path)
    text = read_document_text(p, "jobs file", str(path))
    data, nodes = load_yaml_document(text, str(path), "jobs file")
    doc = validate_document(JobsDocument, data, nodes, str(path), p.parent)
    _check(doc, (), doc.jobs or [], doc.job_stream, network)
    return _collect(doc.jobs or [], doc.job_stream, free_stations)


def _collect(jobs: Sequence[TransportJobSpec], stream: JobStreamSpec | None, free: Sequence[str]
             ) -> list[TransportJob]:
    out = _from_specs(jobs)
    if stream is not None:
        out += generate_jobs(stream, stream.stations or list(free))
    return out


def fleet_jobs(fleet: FleetScenario, network: RouteNetwork, free_stations: Sequence[str]) -> list[TransportJob]:
    """Every transport job of a fleet scenario: ``fleet.jobs``, ``fleet.job_stream``, ``fleet.jobs_file``."""
    spec = fleet.fleet
    _check(fleet, ("fleet",), spec.jobs or [], spec.job_stream, network)
    out = _collect(spec.jobs or [], spec.job_stream, free_stations)
    if spec.jobs_file is not None:
        base = fleet.base_dir if fleet.base_dir is not None else Path()
        p = base / spec.jobs_file
        if not p.is_file():
            raise fleet.error(("fleet", "jobs_file"), f"jobs file {spec.jobs_file!r} not found")
        out += load_jobs(p, network, free_stations)
    ids = [j.id for j in out]
    dup = next((i for i in ids if ids.count(i) > 1), None)
    if dup is not None:
        raise fleet.error(("fleet",), f"duplicate job id {dup!r} (jobs, job_stream and jobs_file together)")
    return out
