"""Conflict zones computed from the vehicles' footprints, never drawn (issue 30).

A *resource* is a node (``("node", id)``) or a directed edge (``("edge", id)``; a two-way
edge's reverse twin ``id~r`` is a resource of its own). For each vehicle model the
footprint (the plant's body polygon, :func:`model_footprint`) is swept over every
resource the model may occupy:

* an **edge**: the footprint at the poses along the exact curve (line, arc, clothoid,
  NURBS), heading the tangent when driven forward and the tangent + pi when backing up
  (``Edge.modes``; backing up only for a model that ``reverses``);
* a **node**, for a model that ``turns_on_spot``: the disc swept by the footprint turning
  a full turn about base_link (radius the footprint's farthest vertex, the polygon
  circumscribing the circle); for any other model: the footprints at the node poses of the
  incident edges it may use (where it stops, starts and reverses).

Two resources conflict, for models ``a`` and ``b``, when their swept shapes come closer
than ``margin_m`` (the safety margin: tracking error, positioning error, the arc chain's
deviation from the exact curve). A vehicle of ``b`` must not occupy any resource conflicting
with the one a vehicle of ``a`` occupies.

The sweep is conservative by construction (the bound that makes it so)
-----------------------------------------------------------------------
The edge is sampled at arclengths ``s_0 < ... < s_n``; between two samples the shape is
the convex hull of the two footprints, buffered by ``delta_i``. A body point ``b`` (at
distance ``r <= R`` from base_link, ``R`` the footprint's circumradius about it) is at
``p(s) = c(s) + Rot(psi(s)) b`` with ``c`` the curve parametrised by arclength (``|c'| = 1``,
``|c''| = |kappa|``) and ``psi' = kappa``, so
``|p''| <= |kappa| + r kappa^2 + r |kappa'|``. A C2 function deviates from its linear
interpolant over an interval of length ``h`` by at most ``h^2 / 8 max|p''|``, and the linear
interpolant between ``p(s_i)`` (in footprint ``i``) and ``p(s_i+1)`` (in footprint ``i+1``)
lies in their convex hull. Hence

    ``delta_i = h_i^2 / 8 (k_i (1 + R k_i) + R k'_i)``

with ``k_i``, ``k'_i`` bounds of ``|kappa|`` and ``|dkappa/ds|`` over the interval: 0 on a line
(the hull of the two end footprints is the exact sweep of a translation), constant on an
arc (``k' = 0``), the larger end curvature and the sharpness on a clothoid (curvature linear
in arclength). The step is chosen so that ``delta_i <= SWEEP_TOLERANCE_M``. A NURBS has no
closed-form curvature: ``k`` and ``k'`` are finite differences on a 1 cm sampling, maxed over
the interval and its neighbours and multiplied by 1.5 (an assumption, checked by
:func:`missed_conflicts`, which samples the exact curve); its arclength sampling is the
NURBS's own (:meth:`agvnav.routes.nurbs.Nurbs.sample`).

Large networks: one STRtree of swept shapes per model, queried in bulk ("dwithin
``margin_m``"), so the cost grows with the number of resources, not its square.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cache

import networkx as nx
import numpy as np
import shapely
from numpy.typing import NDArray
from shapely import STRtree
from shapely.geometry.base import BaseGeometry

from agvnav.guidance.clothoid import Clothoid
from agvnav.guidance.paths import ArcSegment, LineSegment
from agvnav.routes.network import Edge, RouteNetwork
from agvnav.routes.nurbs import Nurbs
from agvnav.routes.schema import ClothoidGeometrySpec, NurbsGeometrySpec
from agvnav.vehicles.builders import build_plant
from agvnav.world.vehicle_specs import VEHICLE_MODELS, vehicle_kind

__all__ = [
    "DEFAULT_MARGIN_M",
    "SWEEP_TOLERANCE_M",
    "ConflictZones",
    "Resource",
    "conflict_zones",
    "edge_poses",
    "find_missed_conflicts",
    "missed_conflicts",
    "model_footprint",
    "node_poses",
]

#: A resource: ``("node", node_id)`` or ``("edge", edge_id)``.
Resource = tuple[str, str]

#: Default safety margin (m) between two swept shapes.
DEFAULT_MARGIN_M = 0.1

#: Largest buffer (m) the sampling of a curved edge may need (the conservative bound, module doc).
SWEEP_TOLERANCE_M = 0.01

#: Segments per quarter circle of a turning disc.
_QUAD_SEGS = 16

#: Safety factor on a NURBS's finite-difference curvature bounds (module doc).
_NURBS_BOUND_FACTOR = 1.5


@cache
def model_footprint(model: str) -> NDArray[np.float64]:
    """The body polygon ``(k, 2)`` (m, base_link) of vehicle ``model`` with its default spec.

    It is the truth plant's footprint (:func:`agvnav.vehicles.builders.build_plant`), the
    polygon the simulator checks collisions with. ValueError for an unknown model.
    """
    cls = vehicle_kind(model)
    spec = cls(model=model)  # type: ignore[call-arg]
    state = [0.0] * (4 if cls.family == "steered" else 3)
    return np.array(build_plant(spec, state).footprint, dtype=np.float64)


def _circumradius(poly: NDArray[np.float64]) -> float:
    return float(np.max(np.hypot(poly[:, 0], poly[:, 1])))


@dataclass(frozen=True)
class _Samples:
    """Poses along a curve: ``xy`` (n, 2) m, ``heading`` (n,) rad; per interval its arclength ``ds`` (n-1,) m and
    bounds of ``|kappa|`` (1/m) and ``|dkappa/ds|`` (1/m^2) over it, ``k`` and ``dk`` (n-1,)."""

    xy: NDArray[np.float64]
    heading: NDArray[np.float64]
    ds: NDArray[np.float64]
    k: NDArray[np.float64]
    dk: NDArray[np.float64]

    def reversed(self) -> _Samples:
        """The same poses run backwards along the curve (headings turned by pi)."""
        return _Samples(self.xy[::-1].copy(), self.heading[::-1] + math.pi, self.ds[::-1].copy(),
                        self.k[::-1].copy(), self.dk[::-1].copy())


def _uniform(length: float, step: float) -> NDArray[np.float64]:
    return np.linspace(0.0, length, max(2, math.ceil(length / step) + 1))


#: Fine step (m) of the finite differences that bound a NURBS's curvature.
_NURBS_FINE_M = 0.01


def _nurbs_bounds(n: Nurbs) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Arclengths (m), ``|kappa|`` and ``|kappa'|`` bounds on a fine sampling of ``n`` (module doc)."""
    pts, hd, length = n.sample(_NURBS_FINE_M)
    ds = length / (len(pts) - 1)
    kappa = np.gradient(np.unwrap(hd), ds)
    dkappa = np.gradient(kappa, ds)
    grow = np.maximum.reduce
    k = _NURBS_BOUND_FACTOR * grow([np.abs(kappa), np.roll(np.abs(kappa), 1), np.roll(np.abs(kappa), -1)])
    dk = _NURBS_BOUND_FACTOR * grow([np.abs(dkappa), np.roll(np.abs(dkappa), 1), np.roll(np.abs(dkappa), -1)])
    return np.linspace(0.0, length, len(pts)), k, dk


def _interval_max(s_fine: NDArray[np.float64], v: NDArray[np.float64], s: NDArray[np.float64]) -> NDArray[np.float64]:
    """Largest ``v`` (sampled at ``s_fine``) over each interval of ``s``, the fine samples next to the ends included."""
    idx = np.clip(np.searchsorted(s_fine, s), 0, len(s_fine) - 1)
    lo, hi = np.maximum(idx[:-1] - 1, 0), np.minimum(idx[1:] + 1, len(s_fine) - 1)
    return np.array([float(np.max(v[i:j + 1])) for i, j in zip(lo.tolist(), hi.tolist(), strict=True)])


def _curve_samples(network: RouteNetwork, edge: Edge, step: float | None) -> _Samples:
    """The exact curve of ``edge`` (from its source node) sampled about every ``step`` m.

    ``step`` None: the step that keeps the sweep's buffer within :data:`SWEEP_TOLERANCE_M`
    for the model's circumradius is chosen by the caller; lines are always just their ends
    unless a step is given.
    """
    curve = edge.curve
    if isinstance(curve.exact, LineSegment):
        seg = curve.exact
        s = np.array([0.0, seg.length]) if step is None else _uniform(seg.length, step)
        n = len(s) - 1
        return _Samples(seg.point_at(s), np.asarray(seg.heading_at(s)), np.diff(s), np.zeros(n), np.zeros(n))
    h = 0.05 if step is None else step
    if isinstance(curve.exact, ArcSegment):
        arc = curve.exact
        s = _uniform(arc.length, h)
        n = len(s) - 1
        return _Samples(arc.point_at(s), np.asarray(arc.heading_at(s)), np.diff(s),
                        np.full(n, abs(arc.curvature)), np.zeros(n))
    reverse = edge.id.endswith("~r")
    geometry = network.spec.edges[int(edge.key[1])].geometry
    if isinstance(geometry, ClothoidGeometrySpec):
        src = network.nodes[edge.target if reverse else edge.source]
        h0 = curve.end_heading - math.pi if reverse else curve.start_heading
        c = Clothoid.from_curvatures(src.x, src.y, h0, geometry.curvature_start_per_m,
                                     geometry.curvature_end_per_m, geometry.length_m)
        s = _uniform(c.length, h)
        k = np.abs(c.curvature_at(s))
        fwd = _Samples(c.point_at(s), np.asarray(c.heading_at(s)), np.diff(s), np.maximum(k[:-1], k[1:]),
                       np.full(len(s) - 1, abs(c.sharpness)))
    elif isinstance(geometry, NurbsGeometrySpec):
        nurbs = _nurbs(geometry)
        pts, hd, length = nurbs.sample(h)
        s = np.linspace(0.0, length, len(pts))
        s_fine, k_fine, dk_fine = _nurbs_bounds(nurbs)
        fwd = _Samples(pts, hd, np.diff(s), _interval_max(s_fine, k_fine, s), _interval_max(s_fine, dk_fine, s))
    else:  # pragma: no cover - every geometry kind is handled above
        raise ValueError(f"edge {edge.id!r}: unknown geometry")
    return fwd.reversed() if reverse else fwd


def _nurbs(geometry: NurbsGeometrySpec) -> Nurbs:
    cps = geometry.control_points
    return Nurbs(geometry.degree, tuple(geometry.knot_vector), np.array([[p.x, p.y] for p in cps]),
                 np.array([p.weight for p in cps]))


def _modes(edge: Edge, model: str) -> tuple[int, ...]:
    """The directions of travel ``model`` may drive ``edge`` in (empty when it may not use it)."""
    if not edge.allows(model):
        return ()
    return tuple(m for m in edge.modes if m > 0 or vehicle_kind(model).reverses)


def _second_derivative_bound(radius: float, k: NDArray[np.float64], dk: NDArray[np.float64]) -> NDArray[np.float64]:
    """Bound of ``|p''|`` (1/m) of any body point within ``radius`` of base_link (module doc)."""
    return k * (1.0 + radius * k) + radius * dk


def _step_for(network: RouteNetwork, edge: Edge, radius: float, tolerance: float) -> float | None:
    """Sampling step (m) keeping every ``delta_i <= tolerance`` (module doc); None for a line (its two ends)."""
    if isinstance(edge.curve.exact, LineSegment):
        return None
    probe = _curve_samples(network, edge, 0.05)
    bound = float(np.max(_second_derivative_bound(radius, probe.k, probe.dk)))
    return float(min(1.0, math.sqrt(8.0 * tolerance / max(bound, 1e-9))))


def edge_poses(network: RouteNetwork, edge: Edge, model: str, step_m: float) -> NDArray[np.float64]:
    """Vehicle poses ``(n, 3)`` (m, m, rad) of ``model`` along ``edge`` every ``step_m`` at most, all its modes.

    Backing up (mode -1) turns the heading by pi. Empty ``(0, 3)`` when the model may not use the edge.
    """
    modes = _modes(edge, model)
    if not modes:
        return np.zeros((0, 3))
    smp = _curve_samples(network, edge, step_m)
    xy, hd = smp.xy, smp.heading
    return np.concatenate([np.column_stack([xy, hd + (math.pi if m < 0 else 0.0)]) for m in modes])


def node_poses(network: RouteNetwork, node: str, model: str, turn_step_rad: float) -> NDArray[np.float64]:
    """Poses ``(n, 3)`` of ``model`` standing at ``node``: a full turn every ``turn_step_rad`` for a model that
    turns on the spot, else the end poses of the incident edges it may use (the node's own heading when none)."""
    nd = network.nodes[node]
    if vehicle_kind(model).turns_on_spot:
        h = np.arange(0.0, 2.0 * math.pi, turn_step_rad)
        return np.column_stack([np.full(h.shape, nd.x), np.full(h.shape, nd.y), h])
    heads = []
    for e in network.edges.values():
        for mode in _modes(e, model):
            turn = math.pi if mode < 0 else 0.0
            if e.source == node:
                heads.append(e.curve.start_heading + turn)
            if e.target == node:
                heads.append(e.curve.end_heading + turn)
    if not heads and nd.heading is not None:
        heads = [nd.heading]
    return np.array([[nd.x, nd.y, h] for h in heads]).reshape(-1, 3)


def _placed(poly: NDArray[np.float64], poses: NDArray[np.float64]) -> NDArray[np.float64]:
    """Footprint ``poly`` (k, 2) placed at ``poses`` (n, 3): vertices (n, k, 2) in the map frame."""
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    x = poses[:, 0:1] + c * poly[None, :, 0] - s * poly[None, :, 1]
    y = poses[:, 1:2] + s * poly[None, :, 0] + c * poly[None, :, 1]
    return np.stack([x, y], axis=-1)


def _polygons(vertices: NDArray[np.float64]) -> NDArray[np.object_]:
    """Shapely polygons of vertices (n, k, 2)."""
    return np.asarray(shapely.polygons(vertices))


def _sweep(poly: NDArray[np.float64], smp: _Samples, mode: int) -> BaseGeometry:
    """The conservative swept shape of ``poly`` along samples ``smp`` in ``mode`` (module doc)."""
    radius = _circumradius(poly)
    poses = np.column_stack([smp.xy, smp.heading + (math.pi if mode < 0 else 0.0)])
    v = _placed(poly, poses)
    pairs = np.concatenate([v[:-1], v[1:]], axis=1)  # (n-1, 2k, 2)
    hulls = shapely.convex_hull(shapely.multipoints(pairs))
    delta = smp.ds**2 / 8.0 * _second_derivative_bound(radius, smp.k, smp.dk)
    return shapely.union_all(shapely.buffer(hulls, delta, quad_segs=4))


def _edge_shape(network: RouteNetwork, edge: Edge, model: str, tolerance: float) -> BaseGeometry | None:
    modes = _modes(edge, model)
    if not modes:
        return None
    poly = model_footprint(model)
    smp = _curve_samples(network, edge, _step_for(network, edge, _circumradius(poly), tolerance))
    return shapely.union_all([_sweep(poly, smp, m) for m in modes])


def _disc(x: float, y: float, radius: float) -> BaseGeometry:
    """A polygon containing the disc (its edges tangent-or-outside the circle)."""
    grow = 1.0 / math.cos(math.pi / (4 * _QUAD_SEGS))
    return shapely.Point(x, y).buffer(radius * grow, quad_segs=_QUAD_SEGS)


def _node_shape(network: RouteNetwork, node: str, model: str) -> BaseGeometry | None:
    poly = model_footprint(model)
    nd = network.nodes[node]
    if vehicle_kind(model).turns_on_spot:
        return _disc(nd.x, nd.y, _circumradius(poly))
    poses = node_poses(network, node, model, 1.0)
    if len(poses) == 0:
        return None
    return shapely.union_all(_polygons(_placed(poly, poses)))


def _shapes(network: RouteNetwork, model: str, tolerance: float) -> dict[Resource, BaseGeometry]:
    """Swept shape of every resource ``model`` may occupy."""
    out: dict[Resource, BaseGeometry] = {}
    for e in network.edges.values():
        shape = _edge_shape(network, e, model, tolerance)
        if shape is not None:
            out[("edge", e.id)] = shape
    for n in _usable_nodes(network, model):
        shape = _node_shape(network, n, model)
        if shape is not None:
            out[("node", n)] = shape
    return out


def _usable_nodes(network: RouteNetwork, model: str) -> list[str]:
    """The nodes ``model`` may stand at: the ends of the edges it may use, in network order."""
    ends = {n for e in network.edges.values() if _modes(e, model) for n in (e.source, e.target)}
    return [n for n in network.nodes if n in ends]


Table = Mapping[Resource, frozenset[Resource]]

#: Sampled footprints of one model: polygons, the index of each one's resource, the resources.
_Placed = tuple[NDArray[np.object_], NDArray[np.int64], list[Resource]]


@dataclass(frozen=True)
class ConflictZones:
    """Which resources may not be occupied at the same time, per pair of vehicle models (module doc).

    ``network``: the network's name; ``models``: the models computed; ``margin_m``: the safety
    margin (m); ``shapes[model][resource]``: the swept shape (shapely, m, map frame) of every
    resource the model may occupy; ``resources``: every resource of the network;
    ``tables[(a, b)][res_a]``: the resources of ``b`` conflicting with ``res_a`` of ``a``;
    ``edge_ends``: each edge's two end nodes.
    """

    network: str
    models: tuple[str, ...]
    margin_m: float = DEFAULT_MARGIN_M
    shapes: Mapping[str, Mapping[Resource, BaseGeometry]] = field(default_factory=dict, repr=False, compare=False)
    resources: frozenset[Resource] = field(default=frozenset(), repr=False, compare=False)
    tables: Mapping[tuple[str, str], Table] = field(default_factory=dict, repr=False, compare=False)
    edge_ends: Mapping[str, frozenset[str]] = field(default_factory=dict, repr=False, compare=False)

    def _check(self, model: str) -> None:
        if model not in self.models:
            known = ", ".join(self.models)
            raise ValueError(f"vehicle model {model!r} is not in these conflict zones (models: {known})")

    def conflicts(self, model_a: str, res_a: Resource, model_b: str) -> frozenset[Resource]:
        """Every resource a vehicle of ``model_b`` must not occupy while one of ``model_a`` occupies ``res_a``.

        ``res_a`` itself is always included (a resource holds one vehicle). ValueError for a model
        not computed or a resource not in the network.
        """
        self._check(model_a)
        self._check(model_b)
        if res_a not in self.resources:
            raise ValueError(f"resource {res_a!r} is not in network {self.network!r}")
        return self.tables[(model_a, model_b)].get(res_a, frozenset()) | {res_a}

    def pairs(self, model_a: str, model_b: str) -> set[tuple[Resource, Resource]]:
        """Every conflicting pair ``(res_a, res_b)`` for models ``a`` and ``b`` (a resource with itself included
        when both models may occupy it)."""
        self._check(model_a)
        self._check(model_b)
        return {(ra, rb) for ra, rbs in self.tables[(model_a, model_b)].items() for rb in rbs}

    def zones(self) -> list[frozenset[Resource]]:
        """Places where parts of the network that do not touch come too close (for display).

        The connected groups of resources linked by a conflict (any pair of models) between two
        resources sharing no node: two edges without a common end, an edge and a node not its end,
        two nodes. A lane with nothing near it belongs to no zone. Sorted, largest first.
        """
        g: nx.Graph[Resource] = nx.Graph()
        for table in self.tables.values():
            for ra, rbs in table.items():
                for rb in rbs:
                    if ra != rb and not (self.ends(ra) & self.ends(rb)):
                        g.add_edge(ra, rb)
        comps = [frozenset(c) for c in nx.connected_components(g)]
        return sorted(comps, key=lambda c: (-len(c), sorted(c)))

    def ends(self, res: Resource) -> frozenset[str]:
        """The nodes a resource touches: the node itself, or an edge's two ends."""
        kind, rid = res
        return frozenset((rid,)) if kind == "node" else self.edge_ends[rid]


def _model_key(network: RouteNetwork, model: str) -> tuple[object, ...]:
    """What the shapes of ``model`` depend on: footprint, turning on the spot, backing up, the edges it may use."""
    kind = vehicle_kind(model)
    usable = frozenset(e.id for e in network.edges.values() if e.allows(model))
    return (model_footprint(model).tobytes(), kind.turns_on_spot, kind.reverses, usable)


def _check_models(network: RouteNetwork, models: Sequence[str]) -> tuple[str, ...]:
    out = tuple(dict.fromkeys(models))
    if not out:
        raise ValueError("conflict zones need at least one vehicle model")
    for m in out:
        if m not in VEHICLE_MODELS:
            raise ValueError(f"unknown vehicle model {m!r}; valid models: {', '.join(VEHICLE_MODELS)}")
    return out


def conflict_zones(
    network: RouteNetwork, models: Sequence[str], margin_m: float = DEFAULT_MARGIN_M,
    tolerance_m: float = SWEEP_TOLERANCE_M,
) -> ConflictZones:
    """The conflict zones of ``network`` for vehicle ``models`` (module doc).

    ``margin_m`` (m, >= 0): two swept shapes closer than this conflict; ``tolerance_m`` (m, > 0):
    the largest buffer the sampling of a curve may add (smaller: tighter and slower).
    """
    names = _check_models(network, models)
    if not (math.isfinite(margin_m) and margin_m >= 0.0):
        raise ValueError(f"margin_m must be a finite number >= 0, got {margin_m!r}")
    if not (math.isfinite(tolerance_m) and tolerance_m > 0.0):
        raise ValueError(f"tolerance_m must be a positive finite number, got {tolerance_m!r}")
    kinds = {m: _model_key(network, m) for m in names}
    by_kind: dict[tuple[object, ...], dict[Resource, BaseGeometry]] = {}
    for m in names:  # models alike in footprint, turning, reversing and allowed edges share their shapes
        if kinds[m] not in by_kind:
            by_kind[kinds[m]] = _shapes(network, m, tolerance_m)
    shapes = {m: by_kind[kinds[m]] for m in names}
    keys = {k: list(v) for k, v in by_kind.items()}
    trees = {k: STRtree(list(v.values())) for k, v in by_kind.items()}
    tables: dict[tuple[str, str], Table] = {}
    done: dict[tuple[object, object], Table] = {}
    for a in names:
        for b in names:
            pair = (kinds[a], kinds[b])
            if pair not in done:
                ia, ib = trees[kinds[b]].query(list(shapes[a].values()), predicate="dwithin", distance=margin_m)
                table: dict[Resource, set[Resource]] = {}
                for x, y in zip(ia.tolist(), ib.tolist(), strict=True):
                    table.setdefault(keys[kinds[a]][x], set()).add(keys[kinds[b]][y])
                done[pair] = {k: frozenset(v) for k, v in table.items()}
            tables[(a, b)] = done[pair]
    ends = {e.id: frozenset((e.source, e.target)) for e in network.edges.values()}
    resources = frozenset([("node", n) for n in network.nodes] + [("edge", e) for e in network.edges])
    return ConflictZones(network.name, names, margin_m, shapes, resources, tables, ends)


def find_missed_conflicts(
    network: RouteNetwork, models: Sequence[str], zones: ConflictZones, step_m: float = 0.05,
) -> list[tuple[str, Resource, str, Resource]]:
    """The brute-force check: footprints placed at poses sampled along every resource, intersected directly.

    Every pair ``(model_a, res_a, model_b, res_b)`` whose sampled footprints come within
    ``zones.margin_m`` of each other but which ``zones`` does not list as conflicting. Poses
    every ``step_m`` (m) along the exact curves (:func:`edge_poses`), and, at a node, every
    ``step_m / R`` rad of a full turn for a model that turns on the spot (:func:`node_poses`).
    """
    if not (math.isfinite(step_m) and step_m > 0.0):
        raise ValueError(f"step_m must be a positive finite number, got {step_m!r}")
    names = _check_models(network, models)
    kinds = {m: _model_key(network, m) for m in names}
    placed: dict[tuple[object, ...], _Placed] = {}
    for m in names:
        if kinds[m] not in placed:
            placed[kinds[m]] = _sampled_footprints(network, m, step_m)
    missed: list[tuple[str, Resource, str, Resource]] = []
    for a in names:
        for b in names:
            touching = _touching(placed[kinds[a]], placed[kinds[b]], zones.pairs(a, b), zones.margin_m)
            missed += [(a, ra, b, rb) for ra, rb in sorted(touching)]
    return missed


def _touching(a: _Placed, b: _Placed, known: set[tuple[Resource, Resource]], margin: float
              ) -> set[tuple[Resource, Resource]]:
    """Resource pairs not in ``known`` with sampled footprints within ``margin`` (m) of each other.

    Only the pairs whose sampled footprints' bounding boxes come within ``margin`` are
    candidates; of those, the ones already known conflicting need no check.
    """
    boxes_a, boxes_b = _boxes(a), _boxes(b)
    ia, ib = STRtree(boxes_b).query(boxes_a, predicate="dwithin", distance=margin)
    out: set[tuple[Resource, Resource]] = set()
    for i, j in zip(ia.tolist(), ib.tolist(), strict=True):
        pair = (a[2][i], b[2][j])
        if pair in known:
            continue
        pa, pb = a[0][a[1] == i], b[0][b[1] == j]
        if len(STRtree(pb).query(pa, predicate="dwithin", distance=margin)[0]):
            out.add(pair)
    return out


def _boxes(placed: _Placed) -> NDArray[np.object_]:
    """The bounding box of each resource's sampled footprints (an empty geometry for none)."""
    polys, owner, resources = placed
    bounds = shapely.bounds(polys)
    out = []
    for i in range(len(resources)):
        sel = bounds[owner == i]
        if len(sel) == 0:
            out.append(shapely.Polygon())
            continue
        out.append(shapely.box(sel[:, 0].min(), sel[:, 1].min(), sel[:, 2].max(), sel[:, 3].max()))
    return np.asarray(out, dtype=object)


def missed_conflicts(network: RouteNetwork, models: Sequence[str], zones: ConflictZones, step_m: float = 0.05) -> int:
    """How many conflicting pairs the brute-force check finds that ``zones`` misses (0 when sound)."""
    return len(find_missed_conflicts(network, models, zones, step_m))


def _sampled_footprints(network: RouteNetwork, model: str, step_m: float) -> _Placed:
    """Footprint polygons at every sampled pose of ``model``, the index of the resource of each, the resources."""
    poly = model_footprint(model)
    turn = step_m / _circumradius(poly)
    chunks: list[NDArray[np.float64]] = []
    owner: list[NDArray[np.int64]] = []
    resources: list[Resource] = []
    for e in network.edges.values():
        chunks.append(edge_poses(network, e, model, step_m))
        resources.append(("edge", e.id))
    for n in _usable_nodes(network, model):
        chunks.append(node_poses(network, n, model, turn))
        resources.append(("node", n))
    owner = [np.full(len(c), i, dtype=np.int64) for i, c in enumerate(chunks)]
    poses = np.concatenate(chunks) if chunks else np.zeros((0, 3))
    index = np.concatenate(owner) if owner else np.zeros(0, dtype=np.int64)
    return _polygons(_placed(poly, poses)), index, resources
