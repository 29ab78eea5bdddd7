"""The layout planner's input file: hall polygons, routes, goniometer, candidate sites, target.

Validated with the strict located YAML plumbing of :mod:`agvnav.world.strict`, so
every error names the file, the line and the key, e.g.
``warehouse.yaml:12: hall.occluders[3].points: the polygon self-intersects near (12.0, 4.0)``.
The geometric checks (polygons close and are simple, routes inside the hall,
reflectors outside the racks) live in :mod:`agvnav.layout.hall`.

Example::

    name: small
    hall:
      outer: [[0, 0], [20, 0], [20, 12], [0, 12], [0, 0]]   # closed: last point = first
      occluders:
        - {id: rack1, kind: rack, points: [[4, 4], [10, 4], [10, 5], [4, 5], [4, 4]]}
    routes:
      - name: aisle
        path: {start: [2, 2, 0], segments: [{type: line, length_m: 16}]}
    goniometer: {max_range_m: 30, pulses_per_rev: 65535, reflector_radius_m: 0.04}
    candidates:
      sites: [{face: outer, spacing_m: 1.0}, {face: rack1, spacing_m: 1.0}]
    target: {position_3sigma_m: 0.01, heading_3sigma_deg: 0.1, fraction: 0.99, min_visible: 3}
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field

from agvnav.world.scenario import PathSpec
from agvnav.world.strict import (
    Finite,
    NonNegFloat,
    PosFloat,
    SourcedModel,
    StrictModel,
    load_yaml_document,
    read_document_text,
    resolve_document,
    validate_document,
)

__all__ = [
    "CandidateSpec",
    "ExistingReflector",
    "LayoutGoniometer",
    "LayoutSpec",
    "OccluderSpec",
    "RouteSpec",
    "SiteSpec",
    "TargetSpec",
    "VerifySpec",
    "load_layout",
    "parse_layout",
]

Point2 = tuple[Finite, Finite]


class OccluderSpec(StrictModel):
    """A rack, pillar or other obstacle: a closed polygon (last point repeats the first), m."""

    id: str
    """name of the occluder (candidate sites refer to it)."""
    kind: Literal["rack", "pillar", "wall", "other"] = "rack"
    """what it is (racks and pillars both block the beam)."""
    points: Annotated[list[Point2], Field(min_length=4)]
    """polygon vertices x, y (m); the last point must repeat the first."""


class HallSpec(StrictModel):
    """The hall: outer walls and occluders, all closed polygons in the ``map`` frame (m)."""

    outer: Annotated[list[Point2], Field(min_length=4)]
    """outer wall polygon x, y (m); the last point must repeat the first."""
    occluders: list[OccluderSpec] = Field(default_factory=list)
    """racks, pillars and other obstacles that block the laser beam."""


class RouteSpec(StrictModel):
    """One route: a chained path of the vehicle's tracked point (the scenario ``path:`` form)."""

    name: str
    """route name (outputs report per route)."""
    path: PathSpec
    """start pose and chained line/arc segments, as in a scenario's ``path:``."""


class LayoutGoniometer(StrictModel):
    """The rotating laser head (seed 000 §4.1: 8 Hz, 65535 pulses/rev, 30 m, cylinders of 4 cm)."""

    mount: tuple[Finite, Finite, Finite] = (0.0, 0.0, 0.0)
    """x (m), y (m), theta (deg) of the head centre P in base_link."""
    min_range_m: NonNegFloat = 0.3
    """reflectors nearer than this are not seen."""
    max_range_m: PosFloat = 30.0
    """reflectors farther than this are not seen."""
    rate_hz: PosFloat = 8.0
    """revolutions per second."""
    pulses_per_rev: Annotated[int, Field(gt=0)] = 65535
    """angle encoder pulses per revolution: the bearing std is its quantisation (2π/N)/√12."""
    bearing_std_deg: PosFloat | None = None
    """bearing noise std (deg); null: the encoder quantisation."""
    reflector_radius_m: NonNegFloat = 0.04
    """radius of the cylindrical reflectors to be mounted."""


class SiteSpec(StrictModel):
    """Candidate sites every ``spacing_m`` along the faces of ``face`` (``outer`` or an occluder id)."""

    face: str
    """``outer`` (the hall walls, inner faces) or the id of an occluder (its outer faces)."""
    spacing_m: PosFloat = 1.0
    """minimum spacing between candidate sites along the faces."""
    offset_m: NonNegFloat | None = None
    """distance of the reflector centre from the face (default: the reflector radius + 1 cm)."""


class CandidateSpec(StrictModel):
    """Where reflectors may be mounted: sites along faces and/or an explicit list of points."""

    sites: list[SiteSpec] = Field(default_factory=list)
    """wall segments and pillar/rack faces with their spacing."""
    explicit: list[Point2] = Field(default_factory=list)
    """explicit candidate positions x, y (m)."""


class ExistingReflector(StrictModel):
    """A reflector already installed: it is kept in every plan."""

    id: str
    """reflector id (kept in the output map)."""
    x: Finite
    """x (m) of its centre."""
    y: Finite
    """y (m) of its centre."""


class TargetSpec(StrictModel):
    """What the plan must achieve along the routes."""

    position_3sigma_m: PosFloat = 0.010
    """predicted 3σ position error (largest axis of the CRLB ellipse) at most this."""
    heading_3sigma_deg: PosFloat = 0.1
    """predicted 3σ heading error at most this."""
    min_visible: Annotated[int, Field(ge=3)] = 3
    """reflectors that must be visible at a route point."""
    min_spread_m: NonNegFloat = 1.0
    """the visible reflectors must not be aligned: their spread across the best-fit line at least this."""
    fraction: Annotated[float, Field(gt=0.0, le=1.0)] = 0.99
    """fraction of route points that must meet the target."""
    route_spacing_m: PosFloat = 0.5
    """spacing of the evaluated route poses along the routes."""


class VerifySpec(StrictModel):
    """How ``--verify`` drives the routes in the closed loop."""

    vehicle: Literal["differential", "tricycle"] = "differential"
    """the vehicle that drives the routes."""
    speed_m_s: PosFloat = 1.0
    """cruise speed."""
    max_length_m: PosFloat = 200.0
    """drive at most this much of each route (long routes are cut)."""
    section_m: PosFloat = 25.0
    """length of a route section in the per-section table."""
    wheel_slip_k: NonNegFloat = 1e-6
    """random slip of each driven wheel in the check, variance per metre rolled (m²/m); the EKF is told the same
    (its odometry noise is this slip mapped to distance and heading)."""


class LayoutSpec(SourcedModel):
    """A reflector layout problem (lengths m, angles deg at this edge)."""

    name: str = "layout"
    """problem name (used in outputs)."""
    seed: Annotated[int, Field(ge=0)] = 0
    """random seed: the plan (tie-breaking) and the verification runs reproduce for it."""
    hall: HallSpec
    """hall polygons."""
    routes: Annotated[list[RouteSpec], Field(min_length=1)]
    """the routes the vehicles drive."""
    goniometer: LayoutGoniometer = LayoutGoniometer()
    """the goniometer on the vehicles."""
    candidates: CandidateSpec
    """where reflectors may be mounted."""
    existing: list[ExistingReflector] = Field(default_factory=list)
    """reflectors already installed (kept)."""
    target: TargetSpec = TargetSpec()
    """the accuracy target."""
    verify: VerifySpec = VerifySpec()
    """closed-loop check settings."""


def parse_layout(text: str, source: str = "<string>", base_dir: Path | None = None) -> LayoutSpec:
    """Parse and validate layout YAML ``text``; a ScenarioError names the key and line."""
    data, nodes = load_yaml_document(text, source)
    return validate_document(LayoutSpec, data, nodes, source, base_dir)


def load_layout(path: str | Path) -> LayoutSpec:
    """Read a layout file (or a shipped one by name: ``warehouse``, ``generated_100x60``); errors name key and line."""
    p = resolve_document(path, Path(__file__).resolve().parent.parent / "data" / "layouts", "layout")
    return parse_layout(read_document_text(p, "layout", str(path)), str(path), p.parent)
