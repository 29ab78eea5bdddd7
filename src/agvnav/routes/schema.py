"""The route network file: a strict YAML schema (unknown keys refused, errors with key and line).

A network names its **nodes** (stations, decision points, chargers) with a
pose, and its **edges**: directed ``from`` -> ``to``, each with a geometry
(``line``, circular ``arc``, ``clothoid``, or a VDA 5050 ``nurbs``), a speed
limit, the allowed direction of travel and the vehicle models allowed on it.
``two_way: true`` adds the same geometry driven from ``to`` to ``from``.
Angles are degrees here (keys ``*_deg``) and radians everywhere else.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import ConfigDict, Field, field_validator

from agvnav.world.strict import Finite, PosFloat, SourcedModel, StrictModel
from agvnav.world.vehicle_specs import VEHICLE_MODELS

__all__ = [
    "ArcGeometrySpec",
    "ClothoidGeometrySpec",
    "ControlPointSpec",
    "EdgeSpec",
    "GeometrySpec",
    "LineGeometrySpec",
    "NetworkSpec",
    "NodeSpec",
    "NurbsGeometrySpec",
    "TolerancesSpec",
]


class NodeSpec(StrictModel):
    """A node: ``id``, position ``x``, ``y`` (m), optional vehicle ``heading_deg`` when standing there."""

    id: str
    """node name (unique)."""
    x: Finite
    """x (m) in the map frame."""
    y: Finite
    """y (m) in the map frame."""
    heading_deg: Finite | None = None
    """vehicle heading when standing at the node (stations; the start heading of a mission)."""
    kind: Literal["station", "decision", "charger"] = "decision"
    """station (jobs are done there), decision point, or charger (a station that charges)."""


class LineGeometrySpec(StrictModel):
    """A straight edge from the ``from`` node to the ``to`` node."""

    type: Literal["line"] = "line"
    """geometry type."""


class ArcGeometrySpec(StrictModel):
    """A circular arc of ``radius_m`` turning ``sweep_deg`` (positive left), starting at ``from``."""

    type: Literal["arc"]
    """geometry type."""
    radius_m: PosFloat
    """arc radius."""
    sweep_deg: Annotated[float, Field(ge=-360.0, le=360.0, allow_inf_nan=False)]
    """turned angle, positive to the left (CCW); non-zero."""
    heading_deg: Finite | None = None
    """tangent at the start (default: the from node's heading_deg)."""


class ClothoidGeometrySpec(StrictModel):
    """An Euler spiral: curvature linear in arclength from ``curvature_start_per_m`` to ``curvature_end_per_m``."""

    type: Literal["clothoid"]
    """geometry type."""
    length_m: PosFloat
    """arclength of the spiral."""
    curvature_start_per_m: Finite = 0.0
    """curvature at the start (1/m, positive turning left)."""
    curvature_end_per_m: Finite = 0.0
    """curvature at the end (1/m, positive turning left)."""
    heading_deg: Finite | None = None
    """tangent at the start (default: the from node's heading_deg)."""


class ControlPointSpec(StrictModel):
    """A NURBS control point (VDA 5050 ``controlPoints``): ``x``, ``y`` (m) and ``weight`` (> 0)."""

    x: Finite
    """x (m)."""
    y: Finite
    """y (m)."""
    weight: Finite = 1.0
    """rational weight (> 0)."""


class NurbsGeometrySpec(StrictModel):
    """A NURBS as in a VDA 5050 edge ``trajectory``: ``degree``, ``knot_vector``, ``control_points``."""

    type: Literal["nurbs"]
    """geometry type."""
    degree: Annotated[int, Field(ge=1, le=10)]
    """polynomial degree."""
    knot_vector: list[Finite]
    """non-decreasing knots (control points + degree + 1 values)."""
    control_points: Annotated[list[ControlPointSpec], Field(min_length=2)]
    """the first and last stand on the from and to nodes."""


GeometrySpec = Annotated[
    LineGeometrySpec | ArcGeometrySpec | ClothoidGeometrySpec | NurbsGeometrySpec, Field(discriminator="type")
]


class EdgeSpec(StrictModel):
    """A directed edge ``from`` -> ``to`` with a geometry, a speed limit, direction and allowed models."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)

    id: str
    """edge name (unique)."""
    source: str = Field(alias="from")
    """node the edge starts at."""
    to: str
    """node the edge ends at."""
    geometry: GeometrySpec = LineGeometrySpec()
    """line (default), arc, clothoid or nurbs."""
    speed_m_s: PosFloat = 1.0
    """speed limit on the edge."""
    direction: Literal["forward", "reverse", "both"] = "forward"
    """how the vehicle may drive along the edge: facing forward, backing up, or either."""
    models: list[str] | None = None
    """vehicle models allowed on the edge (null: every model)."""
    two_way: bool = False
    """also drivable from 'to' to 'from' (the same geometry, driven backwards along it)."""

    @field_validator("models")
    @classmethod
    def _known_models(cls, value: list[str] | None) -> list[str] | None:
        for m in value or []:
            if m not in VEHICLE_MODELS:
                raise ValueError(f"unknown vehicle model {m!r}; valid models: {', '.join(VEHICLE_MODELS)}")
        return value


class TolerancesSpec(StrictModel):
    """Continuity tolerances at the joints (where an edge ends and another continues)."""

    gap_m: PosFloat = 0.005
    """largest distance between an edge's end and its node (m)."""
    heading_deg: PosFloat = 0.5
    """largest heading jump at a joint (G1)."""
    curvature_per_m: PosFloat = 0.02
    """largest curvature jump at a joint next to a clothoid (G2)."""
    joint_deg: PosFloat = 30.0
    """edge pairs at a node whose tangents differ by less than this are joints (more: a corner)."""


class NetworkSpec(SourcedModel):
    """A route network: nodes and directed edges."""

    name: str = "network"
    """network name."""
    description: str = ""
    """one-line description."""
    tolerances: TolerancesSpec = TolerancesSpec()
    """continuity tolerances."""
    nodes: Annotated[list[NodeSpec], Field(min_length=2)]
    """stations, decision points and chargers."""
    edges: Annotated[list[EdgeSpec], Field(min_length=1)]
    """directed edges between the nodes."""
