"""LIF 1.0 (VDMA Layout Interchange Format) import and export of route networks (issue 30).

The schema is vendored in ``agvnav/data/lif/LIF.schema`` (with its license note). A LIF file
holds layouts of nodes (``nodePosition``, ``theta`` per vehicle type), edges (``startNodeId``,
``endNodeId``, per vehicle type ``vehicleOrientation``, ``maxSpeed`` and an optional NURBS
``trajectory``) and stations (``interactionNodeIds``).

Export (:func:`export_lif`) writes one layout that validates against the schema:

* a line is an edge without trajectory; an arc is an exact rational quadratic NURBS (pieces of
  at most 90 deg, weights scaled so the smallest is 1, the schema's minimum); a clothoid is a
  cubic B-spline fitted in arclength to within :data:`CLOTHOID_FIT_M`; a NURBS is itself with
  its knots mapped to [0, 1];
* ``direction`` forward / reverse is ``vehicleOrientation`` 0 / pi (TANGENTIAL); ``both`` leaves
  it out (no constraint); a ``two_way`` edge is two LIF edges, ``ID`` and ``ID~r``;
* one ``vehicleTypeEdgeProperties`` entry per allowed agvnav model (the vehicle type ids are the
  model names); stations and chargers become stations of one interaction node;
* every LIF element also carries an ``agvnav`` object (the schema allows extra properties)
  with the exact agvnav geometry, so that agvnav's own files round-trip without loss.

Import (:func:`import_lif`) is lenient: what the schema refuses but has one meaning is fixed
and reported (a missing ``stations`` list, numbers or booleans written as strings, control
point weights below 1); anything else names the first problem with its JSON path
(``$.layouts[0].nodes[2].nodePosition: 'x' is a required property``) in a :class:`LifError`.
A trajectory that does not start and end on its nodes is replaced by a straight line (reported);
vehicle types that are not agvnav models open the edge to every model (reported).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from datetime import UTC, datetime
from functools import cache
from importlib import resources
from typing import Any

import numpy as np
from jsonschema import Draft7Validator
from jsonschema.exceptions import ValidationError
from numpy.typing import NDArray
from scipy.interpolate import make_lsq_spline

from agvnav.geometry.angles import wrap_angle
from agvnav.guidance.clothoid import Clothoid
from agvnav.routes.network import RouteNetwork, network_from_dict
from agvnav.routes.nurbs import Nurbs
from agvnav.routes.schema import (
    ArcGeometrySpec,
    ClothoidGeometrySpec,
    EdgeSpec,
    NurbsGeometrySpec,
)
from agvnav.world.strict import ScenarioError
from agvnav.world.vehicle_specs import VEHICLE_MODELS

__all__ = [
    "CLOTHOID_FIT_M",
    "LIF_VERSION",
    "LifError",
    "LifImport",
    "export_lif",
    "import_lif",
    "lif_problem",
    "lif_schema",
    "parse_lif_text",
]

#: The LIF version written.
LIF_VERSION = "1.0.0"

#: Largest deviation (m) of an exported clothoid's B-spline from the clothoid.
CLOTHOID_FIT_M = 0.0005

#: The extension key agvnav adds to LIF elements.
EXT = "agvnav"


class LifError(ValueError):
    """The document is not LIF: the message names the first problem with its JSON path."""


@cache
def lif_schema() -> dict[str, Any]:
    """The vendored LIF 1.0 JSON schema."""
    text = (resources.files("agvnav") / "data" / "lif" / "LIF.schema").read_text(encoding="utf-8")
    schema: dict[str, Any] = json.loads(text)
    return schema


def _path(parts: Sequence[str | int]) -> str:
    return "$" + "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in parts)


def _errors(document: Any) -> list[ValidationError]:
    errs = list(Draft7Validator(lif_schema()).iter_errors(document))
    return sorted(errs, key=lambda e: [(0, p) if isinstance(p, int) else (1, str(p)) for p in e.absolute_path])


def lif_problem(document: Any) -> str | None:
    """The first schema problem of ``document`` as ``$.json.path: message``, or None when it validates."""
    errs = _errors(document)
    return None if not errs else f"{_path(list(errs[0].absolute_path))}: {errs[0].message}"


# --------------------------------------------------------------------------------------------- export


def _rational_arc(x0: float, y0: float, h0: float, radius: float, sweep: float) -> dict[str, Any]:
    """An arc as a rational quadratic NURBS (pieces of <= 90 deg), knots in [0, 1], weights >= 1."""
    n = max(1, math.ceil(abs(sweep) / (math.pi / 2) - 1e-9))
    step = sweep / n
    side = 1.0 if sweep > 0 else -1.0
    cx, cy = x0 - side * radius * math.sin(h0), y0 + side * radius * math.cos(h0)
    pts: list[tuple[float, float, float]] = []
    w_mid = math.cos(step / 2)
    for k in range(n):
        ha, hb = h0 + k * step, h0 + (k + 1) * step
        pa = (cx + side * radius * math.sin(ha), cy - side * radius * math.cos(ha))
        pb = (cx + side * radius * math.sin(hb), cy - side * radius * math.cos(hb))
        d = radius * math.tan(step / 2) * side
        mid = (pa[0] + d * math.cos(ha), pa[1] + d * math.sin(ha))
        # weights (1, cos(step/2), 1) scaled by 1/cos(step/2): the same curve, the schema's minimum 1 kept
        if k == 0:
            pts.append((*pa, 1.0 / w_mid))
        pts += [(*mid, 1.0), (*pb, 1.0 / w_mid)]
    inner = [k / n for k in range(1, n) for _ in range(2)]
    knots = [0.0] * 3 + inner + [1.0] * 3
    return _trajectory(2, knots, pts)


def _trajectory(degree: int, knots: Sequence[float], cps: Sequence[tuple[float, float, float]]) -> dict[str, Any]:
    return {"degree": degree, "knotVector": [float(k) for k in knots],
            "controlPoints": [{"x": float(x), "y": float(y), "weight": float(w)} for x, y, w in cps]}


def _clothoid_spline(c: Clothoid) -> dict[str, Any]:
    """A cubic B-spline in normalised arclength within :data:`CLOTHOID_FIT_M` of clothoid ``c``."""
    u = np.linspace(0.0, 1.0, 400)
    pts = c.point_at(u * c.length)
    for inner in range(1, 64):
        t = np.concatenate([[0.0] * 4, np.linspace(0.0, 1.0, inner + 2)[1:-1], [1.0] * 4])
        spl = make_lsq_spline(u, pts, t, k=3)
        if float(np.max(np.hypot(*(spl(u) - pts).T))) <= CLOTHOID_FIT_M:
            break
    cps = np.asarray(spl.c)
    cps[0], cps[-1] = pts[0], pts[-1]  # clamped: the ends stand exactly on the nodes
    return _trajectory(3, t.tolist(), [(float(x), float(y), 1.0) for x, y in cps])


def _nurbs_trajectory(g: NurbsGeometrySpec) -> dict[str, Any]:
    lo, hi = g.knot_vector[0], g.knot_vector[-1]
    knots = [(k - lo) / (hi - lo) for k in g.knot_vector]
    wmin = min(p.weight for p in g.control_points)
    return _trajectory(g.degree, knots, [(p.x, p.y, max(1.0, p.weight / wmin)) for p in g.control_points])


def _reversed_trajectory(tr: dict[str, Any]) -> dict[str, Any]:
    return {"degree": tr["degree"], "knotVector": [1.0 - k for k in reversed(tr["knotVector"])],
            "controlPoints": list(reversed(tr["controlPoints"]))}


def _edge_trajectory(net: RouteNetwork, spec: EdgeSpec) -> dict[str, Any] | None:
    g = spec.geometry
    a = net.nodes[spec.source]
    edge = net.edges[spec.id]
    if isinstance(g, ArcGeometrySpec):
        return _rational_arc(a.x, a.y, edge.curve.start_heading, g.radius_m, math.radians(g.sweep_deg))
    if isinstance(g, ClothoidGeometrySpec):
        c = Clothoid.from_curvatures(a.x, a.y, edge.curve.start_heading, g.curvature_start_per_m,
                                     g.curvature_end_per_m, g.length_m)
        return _clothoid_spline(c)
    if isinstance(g, NurbsGeometrySpec):
        return _nurbs_trajectory(g)
    return None


def _edge_properties(spec: EdgeSpec, trajectory: dict[str, Any] | None, reverse_twin: bool) -> list[dict[str, Any]]:
    out = []
    for model in spec.models if spec.models is not None else VEHICLE_MODELS:
        p: dict[str, Any] = {"vehicleTypeId": model, "rotationAllowed": False, "maxSpeed": spec.speed_m_s}
        if spec.direction != "both":
            p["vehicleOrientation"] = 0.0 if spec.direction == "forward" else math.pi
            p["orientationType"] = "TANGENTIAL"
        if trajectory is not None:
            p["trajectory"] = _reversed_trajectory(trajectory) if reverse_twin else trajectory
        out.append(p)
    return out


def export_lif(network: RouteNetwork, timestamp: datetime | None = None) -> dict[str, Any]:
    """The LIF 1.0 document of ``network`` (module doc); ``timestamp`` (UTC) defaults to now.

    The document validates against the vendored schema (a ValueError otherwise: a bug).
    """
    ts = (timestamp or datetime.now(UTC)).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-4] + "Z"
    spec = network.spec
    nodes = []
    for n in spec.nodes:
        props: list[dict[str, Any]] = []
        for model in VEHICLE_MODELS:
            p: dict[str, Any] = {"vehicleTypeId": model}
            if n.heading_deg is not None:
                p["theta"] = float(wrap_angle(math.radians(n.heading_deg)))
            props.append(p)
        nodes.append({"nodeId": n.id, "nodePosition": {"x": float(n.x), "y": float(n.y)},
                      "vehicleTypeNodeProperties": props,
                      EXT: {"kind": n.kind, "heading_deg": n.heading_deg}})
    edges = []
    for e in spec.edges:
        trajectory = _edge_trajectory(network, e)
        ext = {"geometry": e.geometry.model_dump(mode="json"), "direction": e.direction, "two_way": e.two_way,
               "speed_m_s": e.speed_m_s, "models": e.models}
        edges.append({"edgeId": e.id, "startNodeId": e.source, "endNodeId": e.to,
                      "vehicleTypeEdgeProperties": _edge_properties(e, trajectory, False), EXT: ext})
        if e.two_way:
            edges.append({"edgeId": e.id + "~r", "startNodeId": e.to, "endNodeId": e.source,
                          "vehicleTypeEdgeProperties": _edge_properties(e, trajectory, True),
                          EXT: {"twin_of": e.id}})
    stations = [{"stationId": n.id, "interactionNodeIds": [n.id], "stationName": n.id,
                 "stationDescription": n.kind} for n in spec.nodes if n.kind in ("station", "charger")]
    doc = {
        "metaInformation": {"projectIdentification": network.name, "creator": "agvnav", "exportTimestamp": ts,
                            "lifVersion": LIF_VERSION},
        "layouts": [{"layoutId": network.name, "layoutName": network.name, "layoutVersion": "1",
                     "layoutDescription": spec.description, "nodes": nodes, "edges": edges, "stations": stations,
                     EXT: {"tolerances": spec.tolerances.model_dump(mode="json")}}],
    }
    problem = lif_problem(doc)
    if problem is not None:  # pragma: no cover - a bug, not a user mistake
        raise ValueError(f"exported LIF does not validate: {problem}")
    return doc


# --------------------------------------------------------------------------------------------- import


class LifImport:
    """The result of :func:`import_lif`: ``data`` (the route network as plain data, the YAML
    schema's keys), ``fixes`` (what was fixed or approximated, one line each, with its JSON
    path) and ``network`` (the checked :class:`RouteNetwork`)."""

    def __init__(self, data: dict[str, Any], fixes: list[str], network: RouteNetwork) -> None:
        self.data = data
        self.fixes = fixes
        self.network = network


def parse_lif_text(text: str, source: str) -> Any:
    """JSON text -> document; a LifError naming ``source``, line and column when it is not JSON."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise LifError(f"{source}:{exc.lineno}:{exc.colno}: not JSON: {exc.msg}") from None


def _get(doc: Any, parts: Sequence[str | int]) -> Any:
    for p in parts:
        doc = doc[p]
    return doc


def _fix_one(doc: Any, err: ValidationError) -> str | None:
    """Fix ``err`` in place when it has one meaning; the fix's description, or None when it cannot be fixed."""
    parts = list(err.absolute_path)
    where = _path(parts)
    if err.validator == "required" and isinstance(err.instance, dict):
        missing = str(err.message).split("'")[1]
        if missing == "stations" and len(parts) == 2 and parts[0] == "layouts":
            err.instance["stations"] = []
            return f"{where}.stations: missing, taken as []"
        return None
    if not parts:
        return None
    parent, key = _get(doc, parts[:-1]), parts[-1]
    value = err.instance
    if err.validator == "type" and isinstance(value, str):
        wanted = err.validator_value
        if wanted in ("number", "integer"):
            try:
                number = float(value)
            except ValueError:
                return None
            if math.isfinite(number):
                parent[key] = number
                return f"{where}: number written as a string {value!r}, read as {number:g}"
        if wanted == "boolean" and value.strip().lower() in ("true", "false"):
            parent[key] = value.strip().lower() == "true"
            return f"{where}: boolean written as a string {value!r}"
        return None
    if err.validator == "minimum" and key == "weight" and isinstance(value, int | float) and value > 0:
        cps = _get(doc, parts[:-2])
        wmin = min(float(c.get("weight", 1.0)) for c in cps)
        for c in cps:
            c["weight"] = max(1.0, float(c.get("weight", 1.0)) / wmin)
        return f"{_path(parts[:-2])}: weights below 1 scaled by {1.0 / wmin:.6g} (the same curve)"
    return None


def _lenient(doc: Any) -> list[str]:
    """Fix what has one meaning (module doc); LifError naming the first problem that has not."""
    fixes: list[str] = []
    for _ in range(10_000):
        errs = _errors(doc)
        if not errs:
            return fixes
        fixed = None
        for err in errs:
            fixed = _fix_one(doc, err)
            if fixed is None:
                raise LifError(f"not LIF: {_path(list(err.absolute_path))}: {err.message}")
            fixes.append(fixed)
            break
    raise LifError("not LIF: too many problems")  # pragma: no cover


def import_lif(document: Any, layout: str | None = None, use_extensions: bool = True) -> LifImport:
    """A route network from a LIF document (module doc): layout ``layout`` (default the first).

    ``use_extensions``: read agvnav's own ``agvnav`` objects when present (exact geometry, two-way
    edges); without, only the LIF fields are read. LifError when the document is not LIF.
    """
    doc = json.loads(json.dumps(document))  # a copy to fix in place
    fixes = _lenient(doc)
    layouts = doc["layouts"]
    if not layouts:
        raise LifError("not LIF: $.layouts: no layout")
    ids = [lay["layoutId"] for lay in layouts]
    if layout is None:
        index = 0
        if len(layouts) > 1:
            fixes.append(f"$.layouts: {len(layouts)} layouts; imported the first, {ids[0]!r} (others: "
                         f"{', '.join(map(repr, ids[1:]))})")
    elif layout in ids:
        index = ids.index(layout)
    else:
        raise LifError(f"$.layouts: no layout {layout!r} (layouts: {', '.join(ids)})")
    lay = layouts[index]
    base: list[str | int] = ["layouts", index]
    elsewhere = {n["nodeId"] for k, other in enumerate(layouts) if k != index for n in other["nodes"]}
    data = _network_data(lay, base, fixes, use_extensions, doc["metaInformation"], elsewhere)
    try:
        network = network_from_dict(data, source=f"LIF layout {lay['layoutId']!r}")
    except ScenarioError as exc:
        raise LifError(f"not a route network agvnav can drive: {' '.join(str(exc).split())}") from None
    return LifImport(data, fixes, network)


def _network_data(lay: dict[str, Any], base: list[str | int], fixes: list[str], use_ext: bool,
                  meta: dict[str, Any], elsewhere: set[str]) -> dict[str, Any]:
    kinds = {nid: "station" for s in lay["stations"] for nid in s["interactionNodeIds"]}
    for s in lay["stations"]:
        if str(s.get("stationDescription", "")).lower() == "charger":
            kinds.update(dict.fromkeys(s["interactionNodeIds"], "charger"))
    nodes = [_node(n, kinds, use_ext) for n in lay["nodes"]]
    known = {n["id"] for n in nodes}
    edges: list[dict[str, Any]] = []
    twins: set[str] = set()
    unknown_types: set[str] = set()
    by_id = {n["id"]: n for n in nodes}
    for i, e in enumerate(lay["edges"]):
        where = _path([*base, "edges", i])
        if e["startNodeId"] not in known:
            raise LifError(f"{where}.startNodeId: unknown node {e['startNodeId']!r} (not in this layout)")
        if e["endNodeId"] not in known:
            if e["endNodeId"] in elsewhere:
                fixes.append(f"{where}: leads to node {e['endNodeId']!r} of another layout; left out")
                continue
            raise LifError(f"{where}.endNodeId: unknown node {e['endNodeId']!r}")
        a, b = by_id[e["startNodeId"]], by_id[e["endNodeId"]]
        if math.hypot(b["x"] - a["x"], b["y"] - a["y"]) < _GAP_M:
            fixes.append(f"{where}: joins {a['id']!r} and {b['id']!r} at one position (a turn on the spot, which "
                         "agvnav plans at the node); left out")
            continue
        ext = e.get(EXT) if use_ext else None
        if isinstance(ext, dict) and "twin_of" in ext:
            twins.add(e["edgeId"])
            continue
        edges.append(_edge(e, where, fixes, ext, by_id, unknown_types))
    if unknown_types:
        fixes.append(f"{_path([*base, 'edges'])}: vehicle types {', '.join(sorted(unknown_types))} are not agvnav "
                     "models; their edges are open to every model")
    with_twin = {e["id"] for e in edges if e.get("two_way")}
    for t in sorted(twins):
        if t[:-2] not in with_twin:
            raise LifError(f"{_path(base)}.edges: {t!r} names a two-way edge {t[:-2]!r} that is not in the layout")
    out: dict[str, Any] = {"name": lay["layoutId"], "description": lay.get("layoutDescription", ""),
                           "nodes": nodes, "edges": edges}
    tol = lay.get(EXT, {}).get("tolerances") if use_ext else None
    if isinstance(tol, dict):
        out["tolerances"] = tol
    else:  # LIF says nothing of continuity: tangents within the planner's heading class join, others are corners
        out["tolerances"] = {"heading_deg": _JOINT_DEG, "joint_deg": _JOINT_DEG}
    if not str(meta.get("lifVersion", "")).startswith("1."):
        fixes.append(f"$.metaInformation.lifVersion: {meta.get('lifVersion')!r}, read as LIF {LIF_VERSION}")
    return out


def _node(n: dict[str, Any], kinds: dict[str, str], use_ext: bool) -> dict[str, Any]:
    out: dict[str, Any] = {"id": n["nodeId"], "x": n["nodePosition"]["x"], "y": n["nodePosition"]["y"]}
    ext = n.get(EXT) if use_ext else None
    if isinstance(ext, dict) and "kind" in ext:
        if ext.get("heading_deg") is not None:
            out["heading_deg"] = ext["heading_deg"]
        out["kind"] = ext["kind"]
        return out
    theta = next((p["theta"] for p in n["vehicleTypeNodeProperties"] if "theta" in p), None)
    if theta is not None:
        out["heading_deg"] = math.degrees(theta)
    out["kind"] = kinds.get(n["nodeId"], "decision")
    return out


def _edge(e: dict[str, Any], where: str, fixes: list[str], ext: Any, nodes: dict[str, dict[str, Any]],
          unknown_types: set[str]) -> dict[str, Any]:
    out: dict[str, Any] = {"id": e["edgeId"], "from": e["startNodeId"], "to": e["endNodeId"]}
    if isinstance(ext, dict) and "geometry" in ext:
        out.update(geometry=ext["geometry"], direction=ext["direction"], two_way=ext["two_way"],
                   speed_m_s=ext["speed_m_s"], models=ext["models"])
        return out
    props = e["vehicleTypeEdgeProperties"]
    if not props:
        raise LifError(f"{where}.vehicleTypeEdgeProperties: empty (no vehicle type may use the edge)")
    speeds = [float(p["maxSpeed"]) for p in props if "maxSpeed" in p]
    if speeds:
        out["speed_m_s"] = min(speeds)
    out["direction"] = _direction(props[0], where, fixes)
    types = sorted({p["vehicleTypeId"] for p in props})
    unknown = [t for t in types if t not in VEHICLE_MODELS]
    unknown_types.update(unknown)
    if not unknown and set(types) != set(VEHICLE_MODELS):
        out["models"] = types
    tr = next((p["trajectory"] for p in props if "trajectory" in p), None)
    if tr is not None:
        geometry = _trajectory_geometry(tr, nodes[e["startNodeId"]], nodes[e["endNodeId"]], where, fixes)
        if geometry is not None:
            out["geometry"] = geometry
    return out


def _direction(p: dict[str, Any], where: str, fixes: list[str]) -> str:
    if "vehicleOrientation" not in p:
        return "both"
    o = float(wrap_angle(float(p["vehicleOrientation"])))
    if p.get("orientationType", "TANGENTIAL") == "TANGENTIAL":
        if abs(o) < 1e-6:
            return "forward"
        if abs(abs(o) - math.pi) < 1e-6:
            return "reverse"
    fixes.append(f"{where}.vehicleTypeEdgeProperties[0].vehicleOrientation: {o:.4g} rad "
                 f"({p.get('orientationType', 'TANGENTIAL')}) is not facing forward or backward along the "
                 "edge; read as 'both'")
    return "both"


#: Edges of a LIF without agvnav tolerances whose tangents differ by less than this (deg) continue each other.
_JOINT_DEG = 2.0

#: Largest distance (m) between a trajectory's end and its node accepted on import.
_GAP_M = 0.005


def _trajectory_geometry(tr: dict[str, Any], a: dict[str, Any], b: dict[str, Any], where: str, fixes: list[str]
                         ) -> dict[str, Any] | None:
    cps = tr["controlPoints"]
    degree = int(tr.get("degree", 1))
    pts = np.array([[c["x"], c["y"]] for c in cps], dtype=np.float64)
    w = np.array([c.get("weight", 1.0) for c in cps], dtype=np.float64)
    try:
        n = Nurbs(degree, tuple(float(k) for k in tr["knotVector"]), pts, w)
        ends = n.point_at(np.array(n.domain))
    except ValueError as exc:
        raise LifError(f"{where}: trajectory: {' '.join(str(exc).split())}") from None
    gaps = _gaps(ends, a, b)
    if max(gaps) > _GAP_M:
        fixes.append(f"{where}: trajectory runs from {_xy(ends[0])} to {_xy(ends[1])}, "
                     f"{gaps[0]:.3g} m and {gaps[1]:.3g} m from its nodes; replaced by a straight line")
        return None
    return {"type": "nurbs", "degree": degree, "knot_vector": [float(k) for k in tr["knotVector"]],
            "control_points": [{"x": float(x), "y": float(y), "weight": float(wi)} for (x, y), wi in zip(pts, w,
                                                                                                       strict=True)]}


def _gaps(ends: NDArray[np.float64], a: dict[str, Any], b: dict[str, Any]) -> tuple[float, float]:
    return (float(np.hypot(ends[0, 0] - a["x"], ends[0, 1] - a["y"])),
            float(np.hypot(ends[1, 0] - b["x"], ends[1, 1] - b["y"])))


def _xy(p: NDArray[np.float64]) -> str:
    return f"({p[0]:.3g}, {p[1]:.3g})"
