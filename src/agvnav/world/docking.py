"""Docking targets of stations (issue 32): reflectors fixed to a station, in the station's own frame.

A station (a pallet rack, a conveyor, a charger) carries two or three reflectors. Their
positions and the docking pose are given in the *station frame*; the map gives the station's
pose in ``map``, which may be wrong by a few centimetres (a rack installed off the drawing):
the vehicle docks relative to the reflectors it sees, whatever the map says. YAML form, a
``docking_targets`` list in the map file (:mod:`agvnav.world.map` reads the rest)::

    docking_targets:
      - id: CH
        station: [12.0, 4.0, 90.0]          # x (m), y (m), heading (deg) of the station frame in map
        reflectors:                          # in the station frame (m); 2 or 3
          - {id: CH_a, x: 0.0, y: -0.40}
          - {id: CH_b, x: 0.0, y: 0.10}
          - {id: CH_c, x: 0.0, y: 0.40}
        radius_m: 0.025
        docking_pose: [0.6, 0.0, 180.0]      # the guided point's pose in the station frame (m, m, deg)
        approach_m: 2.5                      # straight approach along the docking heading
        direction: forward                   # or reverse (the stacker backs in)

Schema errors name the file, the line and the key (:mod:`agvnav.world.strict`). What the schema
cannot see alone is checked by :func:`check_target` against the vehicle and the goniometer when a
scenario is built: at least two reflectors, reflectors far enough apart to be told apart at the
goniometer's resolution from the approach start, and a docking pose the vehicle can reach.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from agvnav.world.strict import (
    Finite,
    KeyPath,
    PosFloat,
    SourcedModel,
    StrictModel,
    load_yaml_document,
    read_document_text,
    validate_document,
)

__all__ = [
    "MIN_SEPARATION_PULSES",
    "DockingTarget",
    "DockingTargets",
    "TargetReflectorSpec",
    "TargetSpec",
    "approach_start",
    "check_target",
    "load_docking_targets",
    "min_approach_m",
    "parse_docking_targets",
]

#: Beam pulses of clear angle required between two target reflections (edge to edge): fewer and the
#: reflections merge or swap within one pulse count's quantisation and the pattern cannot be read.
MIN_SEPARATION_PULSES = 20


class TargetReflectorSpec(StrictModel):
    """One reflector of a docking target, in the station frame."""

    id: str
    """reflector id (unique in the target)."""
    x: Finite
    """x in the station frame (m)."""
    y: Finite
    """y in the station frame (m)."""


class TargetSpec(StrictModel):
    """A station's docking target: its reflectors and docking pose in the station frame."""

    id: str
    """the station's id."""
    station: tuple[Finite, Finite, Finite]
    """x (m), y (m), heading (deg) of the station frame in ``map`` (as drawn; may be wrong)."""
    reflectors: list[TargetReflectorSpec]
    """two or three reflectors fixed to the station (m, station frame)."""
    radius_m: Annotated[float, Field(ge=0.0, le=0.2)] = 0.025
    """radius of the target's cylindrical reflectors (m)."""
    docking_pose: tuple[Finite, Finite, Finite]
    """x (m), y (m), heading (deg) of the guided point when docked, in the station frame."""
    approach_m: PosFloat = 2.5
    """length of the straight approach ending at the docking pose (m)."""
    direction: Literal["forward", "reverse"] = "forward"
    """drive forward or back into the station."""
    max_offset_m: PosFloat = 0.05
    """how far the station may be from its map position (m): the search window and the plausibility bound."""
    max_offset_deg: PosFloat = 2.0
    """how far the station's heading may be from the map's (deg)."""


class DockingTargets(SourcedModel):
    """The ``docking_targets`` section of a map file."""

    docking_targets: list[TargetSpec] = Field(default_factory=list)
    """the stations' docking targets."""


@dataclass(frozen=True)
class DockingTarget:
    """A docking target in SI units and radians (built from :class:`TargetSpec`).

    ``station`` (3,) the station frame's pose in ``map`` as the map says; ``reflector_xy (k, 2)`` the
    reflectors in the station frame (m); ``docking_pose`` (3,) the guided point's pose in the station
    frame; ``direction`` +1 forward, -1 reverse; ``max_offset`` (m, rad) the station's allowed offset.
    """

    id: str
    station: tuple[float, float, float]
    reflector_ids: tuple[str, ...]
    reflector_xy: NDArray[np.float64]
    radius: float
    docking_pose: tuple[float, float, float]
    approach: float
    direction: int
    max_offset: tuple[float, float]

    @classmethod
    def from_spec(cls, spec: TargetSpec) -> DockingTarget:
        """The SI form of ``spec`` (degrees become radians)."""
        xy = np.array([[r.x, r.y] for r in spec.reflectors], dtype=np.float64).reshape(-1, 2)
        xy.setflags(write=False)
        s, d = spec.station, spec.docking_pose
        return cls(
            spec.id, (s[0], s[1], math.radians(s[2])), tuple(r.id for r in spec.reflectors), xy, spec.radius_m,
            (d[0], d[1], math.radians(d[2])), spec.approach_m, 1 if spec.direction == "forward" else -1,
            (spec.max_offset_m, math.radians(spec.max_offset_deg)),
        )


def parse_docking_targets(text: str, source: str = "<string>") -> DockingTargets:
    """The docking targets of map YAML ``text`` (other map keys are ignored here); located errors."""
    data, nodes = load_yaml_document(text, source, "map")
    doc = validate_document(DockingTargets, {"docking_targets": data.get("docking_targets") or []}, nodes, source,
                            None)
    for i, t in enumerate(doc.docking_targets):
        ids = [r.id for r in t.reflectors]
        if len(ids) < 2:
            raise doc.error(("docking_targets", i, "reflectors"),
                            f"target {t.id!r} has {len(ids)} reflector(s): a station-relative pose needs at least 2")
        if len(ids) > 3:
            raise doc.error(("docking_targets", i, "reflectors"),
                            f"target {t.id!r} has {len(ids)} reflectors: give 2 or 3")
        if len(set(ids)) != len(ids):
            raise doc.error(("docking_targets", i, "reflectors"), f"target {t.id!r}: duplicate reflector ids {ids}")
    ids = [t.id for t in doc.docking_targets]
    for i, ident in enumerate(ids):
        if ident in ids[:i]:
            raise doc.error(("docking_targets", i, "id"), f"duplicate docking target id {ident!r}")
    return doc


def load_docking_targets(path: str | Path) -> DockingTargets:
    """The docking targets of the map file ``path`` (file, line and key in every error)."""
    text = read_document_text(path, "map")
    return parse_docking_targets(text, str(path))


def min_approach_m(turn_radius: float, max_offset: float) -> float:
    """Shortest straight approach (m) that takes up a lateral offset ``max_offset`` (m) at ``turn_radius`` (m).

    A stand-in rule of issue 32 (no seed gives one; docs/docking.md): the shortest S of two full-lock
    arcs, doubled for a follower that converges smoothly. Two opposite arcs of radius R (an S)
    shift the path sideways by ``delta`` over the length
    ``2 sqrt(R delta)`` (for ``delta << R``: ``delta = 2 R (1 - cos a)``, length ``2 R sin a``);
    the follower needs about as much again to settle (the seed-000 law converges over its
    convergence distance): twice that.
    """
    return 4.0 * math.sqrt(max(turn_radius, 0.0) * max_offset)


def check_target(doc: DockingTargets, index: int, pulses_per_rev: int, turn_radius: float,
                 key: KeyPath | None = None) -> DockingTarget:
    """The target ``index`` of ``doc`` checked for a vehicle and a goniometer; ScenarioError with its line.

    * two reflections must be told apart from the approach start (:func:`_check_separation`);
    * the docking pose must be reachable (:func:`_check_reach`; ``turn_radius`` (m) the vehicle's
      smallest, 0 for a vehicle that turns on the spot).
    """
    where: KeyPath = ("docking_targets", index) if key is None else key
    target = DockingTarget.from_spec(doc.docking_targets[index])
    _check_separation(doc, where, target, pulses_per_rev)
    _check_reach(doc, where, target, turn_radius)
    return target


def _check_separation(doc: DockingTargets, where: KeyPath, target: DockingTarget, pulses_per_rev: int) -> None:
    """From the approach start (the farthest point), the angle between two reflectors' centres less each one's
    angular radius ``asin(r / d)`` must hold :data:`MIN_SEPARATION_PULSES` beam pulses (``2 pi / pulses_per_rev``
    each, seed 000 §2.1)."""
    start = approach_start(target)
    resolution = 2.0 * math.pi / pulses_per_rev
    xy = target.reflector_xy
    d = np.hypot(xy[:, 0] - start[0], xy[:, 1] - start[1])
    half = np.arcsin(np.clip(target.radius / np.maximum(d, 1e-9), 0.0, 1.0))
    ux, uy = (xy[:, 0] - start[0]) / np.maximum(d, 1e-9), (xy[:, 1] - start[1]) / np.maximum(d, 1e-9)
    need = MIN_SEPARATION_PULSES * resolution
    for i in range(len(xy)):
        for j in range(i + 1, len(xy)):
            between = math.atan2(abs(float(ux[i] * uy[j] - uy[i] * ux[j])), float(ux[i] * ux[j] + uy[i] * uy[j]))
            sep = between - float(half[i] + half[j])
            if sep < need:
                raise doc.error((*where, "reflectors", j),
                                f"reflectors {target.reflector_ids[i]!r} and {target.reflector_ids[j]!r} are "
                                f"{math.degrees(max(sep, 0.0)) * 1e3:.1f} mdeg apart edge to edge from the approach "
                                f"start {target.approach:g} m out: the goniometer needs "
                                f"{math.degrees(need) * 1e3:.1f} mdeg ({MIN_SEPARATION_PULSES} pulses) to tell "
                                "them apart")


def _check_reach(doc: DockingTargets, where: KeyPath, target: DockingTarget, turn_radius: float) -> None:
    """The straight approach must take up the station's allowed offset at the smallest turning radius
    (:func:`min_approach_m`, a stand-in rule: docs/docking.md)."""
    need = min_approach_m(turn_radius, target.max_offset[0])
    if target.approach < need:
        raise doc.error((*where, "docking_pose"),
                        f"docking pose of {target.id!r} unreachable: taking up the station's allowed offset "
                        f"{target.max_offset[0]:g} m at the vehicle's turning radius {turn_radius:.3g} m needs a "
                        f"straight approach of {need:.3g} m, approach_m is {target.approach:g}")


def approach_start(target: DockingTarget) -> tuple[float, float, float]:
    """The guided point's pose (station frame) at the start of the straight approach (m, m, rad)."""
    x, y, h = target.docking_pose
    back = target.approach * target.direction
    return x - back * math.cos(h), y - back * math.sin(h), h

