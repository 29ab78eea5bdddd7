"""A route network built from its file: edge geometries, a networkx graph and the joint report.

Each edge becomes an :class:`EdgeCurve`: exact line and arc segments, or a
clothoid (Fresnel integrals, :class:`agvnav.guidance.clothoid.Clothoid`) or a
NURBS (:class:`agvnav.routes.nurbs.Nurbs`) sampled every
:data:`SAMPLE_STEP_M` and followed as a chain of arcs
(:func:`agvnav.guidance.clothoid.arc_chain`) whose deviation from the exact
curve is measured and reported (``EdgeCurve.approx_error_m``).

Checks at load time, each a :class:`~agvnav.world.strict.ScenarioError`
naming the key and its line: an edge to an unknown node, an edge whose
geometry ends farther than ``tolerances.gap_m`` from its node, an arc or
clothoid without a start heading, a NURBS with invalid knots or weights, and a
heading jump at a joint (two edges meeting at a node with tangents within
``joint_deg``) beyond ``tolerances.heading_deg``. The curvature jumps (G2) at
joints next to a clothoid are reported by :meth:`RouteNetwork.joints`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path as FsPath
from typing import Any

import networkx as nx
import numpy as np
from numpy.typing import NDArray

from agvnav.geometry.angles import wrap_angle
from agvnav.guidance.clothoid import ArcChain, Clothoid, arc_chain
from agvnav.guidance.paths import ArcSegment, LineSegment, Segment
from agvnav.routes.nurbs import Nurbs, nurbs_problem
from agvnav.routes.schema import EdgeSpec, NetworkSpec, NodeSpec
from agvnav.world.strict import (
    KeyPath,
    ScenarioError,
    load_yaml_document,
    read_document_text,
    resolve_document,
    resolve_reference,
    validate_document,
)

__all__ = [
    "EDGE_KINDS",
    "SAMPLE_STEP_M",
    "Edge",
    "EdgeCurve",
    "Joint",
    "Node",
    "RouteNetwork",
    "load_network",
    "network_from_dict",
    "network_reference",
    "parse_network",
]

#: Geometry kinds, in the order the results report them.
EDGE_KINDS = ("line", "arc", "clothoid", "nurbs")

#: Sampling step (m) of clothoids and NURBS for their arc chains.
SAMPLE_STEP_M = 0.05


@dataclass(frozen=True, eq=False)
class EdgeCurve:
    """The geometry of one edge in its direction of increasing arclength.

    ``points`` (k, 2) m, ``headings`` (k,) rad and ``curvatures`` (k,) 1/m sample
    the exact curve; ``exact`` holds the line or arc segment when the edge is one.
    """

    kind: str
    points: NDArray[np.float64]
    headings: NDArray[np.float64]
    curvatures: NDArray[np.float64]
    length: float
    exact: Segment | None = None

    @property
    def start_heading(self) -> float:
        """Tangent heading (rad) at the start."""
        return float(self.headings[0])

    @property
    def end_heading(self) -> float:
        """Tangent heading (rad) at the end."""
        return float(self.headings[-1])

    def reversed(self) -> EdgeCurve:
        """The same curve run from its end to its start (tangents turned by pi, curvatures negated)."""
        exact: Segment | None = None
        if isinstance(self.exact, LineSegment):
            exact = LineSegment(self.exact.end, self.exact.heading + math.pi, self.exact.length)
        elif isinstance(self.exact, ArcSegment):
            a = self.exact
            exact = ArcSegment(a.end, a.end_heading + math.pi, a.radius, -a.sweep)
        return EdgeCurve(
            self.kind, self.points[::-1].copy(), np.asarray(wrap_angle(self.headings[::-1] + math.pi)),
            -self.curvatures[::-1], self.length, exact,
        )

    def chain(self, start: NDArray[np.float64], direction: int, heading: float | None = None) -> ArcChain:
        """Path segments of the edge starting at ``start`` (2,) m, driven in ``direction`` (+1/-1).

        Lines and arcs are exact; clothoids and NURBS are arc chains with their measured
        error. ``heading`` (rad) replaces the start tangent (to join the previous edge
        exactly G1 when the two differ within the network's tolerance).
        """
        gap = float(np.hypot(*(np.asarray(start) - self.points[0])))
        h0 = self.start_heading if heading is None else heading
        if isinstance(self.exact, LineSegment):
            return ArcChain((LineSegment(start, h0, self.exact.length, direction),), gap)
        if isinstance(self.exact, ArcSegment):
            a = self.exact
            return ArcChain((ArcSegment(start, h0, a.radius, a.sweep, direction),), gap)
        return arc_chain(self.points, self.headings, direction, start, h0)

    @property
    def approx_error_m(self) -> float:
        """Largest deviation (m) of the followed segments from the exact curve (0 for lines and arcs)."""
        return 0.0 if self.exact is not None else self.chain(self.points[0], 1).max_error_m


@dataclass(frozen=True)
class Node:
    """A network node: id, position (m), heading when standing there (rad or None), kind."""

    id: str
    x: float
    y: float
    heading: float | None
    kind: str


@dataclass(frozen=True, eq=False)
class Edge:
    """One drivable edge: ``source`` -> ``target`` along ``curve``.

    ``modes``: the allowed directions of travel (+1 facing forward, -1 backing up);
    ``models``: the allowed vehicle models (None: all); ``key``: where it is in the file.
    """

    id: str
    source: str
    target: str
    curve: EdgeCurve
    speed: float
    modes: tuple[int, ...]
    models: frozenset[str] | None
    key: KeyPath

    def allows(self, model: str) -> bool:
        """True when vehicle ``model`` may use this edge."""
        return self.models is None or model in self.models


@dataclass(frozen=True)
class Joint:
    """Continuity where edge ``incoming`` ends and ``outgoing`` starts at ``node``.

    ``heading_jump`` (rad) and ``curvature_jump`` (1/m); ``g1``/``g2`` whether they are
    within tolerance; ``g2_required`` when a clothoid is involved.
    """

    node: str
    incoming: str
    outgoing: str
    heading_jump: float
    curvature_jump: float
    g1: bool
    g2: bool
    g2_required: bool


class RouteNetwork:
    """Nodes, edges (with their reverse twins for ``two_way``), a networkx MultiDiGraph and the joints."""

    def __init__(self, spec: NetworkSpec) -> None:
        self.spec = spec
        self.nodes: dict[str, Node] = {}
        for i, n in enumerate(spec.nodes):
            if n.id in self.nodes:
                raise spec.error(("nodes", i, "id"), f"duplicate node id {n.id!r}")
            self.nodes[n.id] = _node(n)
        self.edges: dict[str, Edge] = {}
        for i, e in enumerate(spec.edges):
            for edge in _edges(spec, i, e, self.nodes):
                if edge.id in self.edges:
                    raise spec.error(("edges", i, "id"), f"duplicate edge id {edge.id!r}")
                self.edges[edge.id] = edge
        self.graph: nx.MultiDiGraph[str] = nx.MultiDiGraph()
        self.graph.add_nodes_from(self.nodes)
        for edge in self.edges.values():
            self.graph.add_edge(edge.source, edge.target, key=edge.id, length=edge.curve.length)
        self._joints = self._check_joints()

    @property
    def name(self) -> str:
        """The network's name."""
        return self.spec.name

    @property
    def stations(self) -> list[str]:
        """Ids of the stations and chargers, in file order."""
        return [n.id for n in self.nodes.values() if n.kind in ("station", "charger")]

    def joints(self) -> list[Joint]:
        """The continuity report: one :class:`Joint` per pair of edges continuing each other at a node."""
        return list(self._joints)

    def _check_joints(self) -> list[Joint]:
        tol = self.spec.tolerances
        out: list[Joint] = []
        for node in self.nodes:
            for _, _, a in self.graph.in_edges(node, keys=True):
                for _, _, b in self.graph.out_edges(node, keys=True):
                    joint = _joint(node, self.edges[a], self.edges[b], tol.heading_deg, tol.curvature_per_m)
                    if joint is None or joint.heading_jump > math.radians(tol.joint_deg):
                        continue
                    if _is_twin(a, b):
                        continue
                    if not joint.g1:
                        raise self.spec.error(
                            self.edges[b].key,
                            f"heading jump of {math.degrees(joint.heading_jump):.3g} deg at node {node!r} after edge "
                            f"{a!r} (tolerance {tol.heading_deg:g} deg)",
                        )
                    out.append(joint)
        return out


def _is_twin(a: str, b: str) -> bool:
    return a == _twin_id(b) or b == _twin_id(a)


def _twin_id(edge_id: str) -> str:
    return edge_id[:-2] if edge_id.endswith("~r") else edge_id + "~r"


def _joint(node: str, a: Edge, b: Edge, heading_tol_deg: float, curv_tol: float) -> Joint | None:
    dh = abs(float(wrap_angle(b.curve.start_heading - a.curve.end_heading)))
    dk = abs(float(b.curve.curvatures[0] - a.curve.curvatures[-1]))
    g2_req = "clothoid" in (a.curve.kind, b.curve.kind)
    return Joint(node, a.id, b.id, dh, dk, dh <= math.radians(heading_tol_deg), dk <= curv_tol, g2_req)


def _node(n: NodeSpec) -> Node:
    h = None if n.heading_deg is None else math.radians(n.heading_deg)
    return Node(n.id, float(n.x), float(n.y), h, n.kind)


def _edges(spec: NetworkSpec, i: int, e: EdgeSpec, nodes: dict[str, Node]) -> list[Edge]:
    """The edge of entry ``i`` (and its reverse twin when ``two_way``)."""
    key: KeyPath = ("edges", i)
    for end, name in (("from", e.source), ("to", e.to)):
        if name not in nodes:
            raise spec.error((*key, end), f"unknown node {name!r}")
    a, b = nodes[e.source], nodes[e.to]
    curve = _curve(spec, key, e, a, b)
    gap = float(np.hypot(curve.points[-1, 0] - b.x, curve.points[-1, 1] - b.y))
    if gap > spec.tolerances.gap_m:
        raise spec.error(
            (*key, "geometry"), f"ends {gap:.4g} m from node {b.id!r} (gap tolerance {spec.tolerances.gap_m:g} m)"
        )
    modes = {"forward": (1,), "reverse": (-1,), "both": (1, -1)}[e.direction]
    models = None if e.models is None else frozenset(e.models)
    out = [Edge(e.id, a.id, b.id, curve, e.speed_m_s, modes, models, key)]
    if e.two_way:
        out.append(Edge(_twin_id(e.id), b.id, a.id, curve.reversed(), e.speed_m_s, modes, models, key))
    return out


def _start_heading(spec: NetworkSpec, key: KeyPath, given: float | None, node: Node) -> float:
    if given is not None:
        return math.radians(given)
    if node.heading is None:
        raise spec.error((*key, "geometry", "heading_deg"), f"needs a start heading (node {node.id!r} gives none)")
    return node.heading


def _curve(spec: NetworkSpec, key: KeyPath, e: EdgeSpec, a: Node, b: Node) -> EdgeCurve:
    g = e.geometry
    start = np.array([a.x, a.y])
    try:
        if g.type == "line":
            d = np.array([b.x - a.x, b.y - a.y])
            seg: Segment = LineSegment(start, math.atan2(d[1], d[0]), float(np.hypot(*d)))
            return _exact_curve("line", seg)
        if g.type == "arc":
            if g.sweep_deg == 0.0:
                raise spec.error((*key, "geometry", "sweep_deg"), "must be non-zero")
            h = _start_heading(spec, key, g.heading_deg, a)
            return _exact_curve("arc", ArcSegment(start, h, g.radius_m, math.radians(g.sweep_deg)))
        if g.type == "clothoid":
            h = _start_heading(spec, key, g.heading_deg, a)
            c = Clothoid.from_curvatures(a.x, a.y, h, g.curvature_start_per_m, g.curvature_end_per_m, g.length_m)
            s = np.linspace(0.0, c.length, max(2, math.ceil(c.length / SAMPLE_STEP_M) + 1))
            return EdgeCurve("clothoid", c.point_at(s), c.heading_at(s), c.curvature_at(s), c.length)
        return _nurbs_curve(spec, key, g.degree, g.knot_vector, [(p.x, p.y, p.weight) for p in g.control_points], a)
    except ValueError as exc:
        if isinstance(exc, ScenarioError):
            raise
        raise spec.error((*key, "geometry"), " ".join(str(exc).split())) from None


def _exact_curve(kind: str, seg: Segment) -> EdgeCurve:
    s = np.linspace(0.0, seg.length, max(2, math.ceil(seg.length / 0.1) + 1))
    k = np.full(s.shape, seg.curvature)
    return EdgeCurve(kind, seg.point_at(s), np.asarray(seg.heading_at(s)), k, seg.length, seg)


def _nurbs_curve(
    spec: NetworkSpec, key: KeyPath, degree: int, knots: list[float], cps: list[tuple[float, float, float]], a: Node
) -> EdgeCurve:
    w = [c[2] for c in cps]
    problem = nurbs_problem(degree, knots, w, len(cps))
    if problem is not None:
        sub = "control_points" if "weight" in problem else ("knot_vector" if "knot" in problem else "degree")
        raise spec.error((*key, "geometry", sub), problem.replace("controlPoints", "control_points"))
    first = float(np.hypot(cps[0][0] - a.x, cps[0][1] - a.y))
    if first > spec.tolerances.gap_m:
        raise spec.error((*key, "geometry", "control_points", 0), f"starts {first:.4g} m from node {a.id!r}")
    n = Nurbs(degree, tuple(knots), np.array([c[:2] for c in cps]), np.array(w))
    pts, hd, length = n.sample(SAMPLE_STEP_M)
    ds = length / (len(pts) - 1)
    curv = np.gradient(np.unwrap(hd), ds)
    return EdgeCurve("nurbs", pts, hd, curv, length)


def parse_network(text: str, source: str = "<string>", base_dir: FsPath | None = None) -> RouteNetwork:
    """Parse and check route network YAML ``text`` (top-level key ``network`` optional)."""
    data, nodes = load_yaml_document(text, source, "route network")
    if set(data) == {"network"}:
        data, nodes = data["network"], _child(nodes, "network")
    spec = validate_document(NetworkSpec, data, nodes, source, base_dir)
    return RouteNetwork(spec)


def network_from_dict(data: dict[str, Any], source: str = "<generated>") -> RouteNetwork:
    """A network from plain data (generated networks); errors as for files, without lines."""
    return RouteNetwork(validate_document(NetworkSpec, data, None, source, None))


def _child(nodes: Any, name: str) -> Any:
    for k, v in getattr(nodes, "value", []):
        if getattr(k, "value", None) == name:
            return v
    return nodes


def _networks_dir() -> FsPath:
    """The folder of the shipped route networks (``agvnav/data/routes``)."""
    return FsPath(str(resources.files("agvnav") / "data" / "routes"))


def load_network(path: str | FsPath) -> RouteNetwork:
    """Load a route network file, or a shipped one by name (``agvnav/data/routes/<name>.yaml``).

    For a name typed by the user: a local file of that name wins, a folder never does
    (:func:`~agvnav.world.strict.resolve_document`). A name written in a scenario resolves
    with :func:`network_reference`.
    """
    p = resolve_document(path, _networks_dir(), "route network")
    return parse_network(read_document_text(p, "route network", str(path)), str(path), p.parent)


def network_reference(name: str, base_dir: FsPath | None) -> FsPath:
    """The file of the route network a document names (``mission.network: hall_loop``).

    A shipped name is always the shipped network (never a file or folder of that name in
    the current folder); any other name is a path relative to ``base_dir``, the folder of
    the naming document (:func:`~agvnav.world.strict.resolve_reference`). A ScenarioError
    for a folder or a missing file.
    """
    return resolve_reference(name, base_dir, _networks_dir(), "route network")
