"""Generated route networks: the shipped hall loop (with clothoid or plain-arc corners) and grids.

:func:`hall_loop` is the layout of ``agvnav/data/routes/hall_loop.yaml`` in the
30 m x 16 m ``hall`` map: a one-way loop (east along y = 3, north along x = 26,
west along y = 11, south along x = 4) whose corners are clothoid-arc-clothoid
turns (or, with ``clothoids=False``, plain quarter circles of the same radius,
for the comparison the missions benchmark makes), a NURBS bend on the top
lane, a two-way bottom lane and a dock ``D`` entered backing up through a
spur. Corner nodes are placed where the exact Fresnel geometry ends.
:func:`warehouse_network` is ``agvnav/data/routes/warehouse.yaml`` in the 60 m x 40 m
``warehouse`` map (see that function). :func:`grid_network` builds a square grid of two-way
lines for planning speed.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

from agvnav.guidance.clothoid import Clothoid

__all__ = ["corner_extent", "grid_network", "hall_loop", "warehouse_grid", "warehouse_network"]

#: Corner radius (m) and clothoid length (m) of the hall loop.
CORNER_RADIUS_M = 2.0
CLOTHOID_LENGTH_M = 1.2


def _turn_points(heading: float, radius: float, clothoid_length: float) -> list[np.ndarray]:
    """Relative joints (m) of a left 90 deg clothoid-arc-clothoid turn starting with ``heading`` (rad)."""
    c1 = Clothoid.from_curvatures(0.0, 0.0, heading, 0.0, 1.0 / radius, clothoid_length)
    p1, h1 = c1.point_at(clothoid_length), float(c1.heading_at(clothoid_length))
    h2 = heading + math.pi / 2 - (h1 - heading)
    centre = p1 + radius * np.array([-math.sin(h1), math.cos(h1)])
    p2 = centre + radius * np.array([math.sin(h2), -math.cos(h2)])
    c3 = Clothoid.from_curvatures(float(p2[0]), float(p2[1]), h2, 1.0 / radius, 0.0, clothoid_length)
    return [p1, p2, c3.point_at(clothoid_length)]


def corner_extent(radius: float, clothoid_length: float) -> float:
    """Distance (m) from the corner of two perpendicular lanes to where the 90 deg turn starts.

    The turn clothoid (0 -> 1/R over ``clothoid_length``), arc, clothoid (1/R -> 0)
    is symmetric, so it starts and ends the same distance from the corner.
    Without clothoids (``clothoid_length = 0``) the extent is the radius.
    """
    if clothoid_length == 0.0:
        return radius
    return float(_turn_points(0.0, radius, clothoid_length)[2][0])


def _corner_edges(name: str, a: str, b: str, heading_deg: float, clothoids: bool, speed: float = 0.8
                  ) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Nodes and edges of one left 90 deg corner from node ``a`` (heading) to node ``b``."""
    r = CORNER_RADIUS_M
    if not clothoids:
        return [], [{"id": name, "from": a, "to": b, "speed_m_s": speed,
                     "geometry": {"type": "arc", "radius_m": r, "sweep_deg": 90.0, "heading_deg": heading_deg}}]
    lc = CLOTHOID_LENGTH_M
    turn = math.degrees(lc / (2.0 * r))
    p1, p2, _ = _turn_points(math.radians(heading_deg), r, lc)
    arc_sweep = 90.0 - 2.0 * turn
    return [{"rel": (f"{name}_1", p1)}, {"rel": (f"{name}_2", p2)}], [
        {"id": f"{name}a", "from": a, "to": f"{name}_1", "speed_m_s": speed,
         "geometry": {"type": "clothoid", "length_m": lc, "curvature_start_per_m": 0.0,
                      "curvature_end_per_m": 1.0 / r, "heading_deg": heading_deg}},
        {"id": f"{name}b", "from": f"{name}_1", "to": f"{name}_2", "speed_m_s": speed,
         "geometry": {"type": "arc", "radius_m": r, "sweep_deg": arc_sweep, "heading_deg": heading_deg + turn}},
        {"id": f"{name}c", "from": f"{name}_2", "to": b, "speed_m_s": speed,
         "geometry": {"type": "clothoid", "length_m": lc, "curvature_start_per_m": 1.0 / r,
                      "curvature_end_per_m": 0.0, "heading_deg": heading_deg + 90.0 - turn}},
    ]


def hall_loop(clothoids: bool = True) -> dict[str, Any]:
    """The shipped hall loop network as plain data (see the module doc)."""
    d = corner_extent(CORNER_RADIUS_M, CLOTHOID_LENGTH_M if clothoids else 0.0)
    x0, x1, y0, y1 = 4.0, 26.0, 3.0, 11.0
    nodes: list[dict[str, Any]] = [
        {"id": "SW", "x": x0 + d, "y": y0, "heading_deg": 0.0},
        {"id": "S1", "x": 8.0, "y": y0, "heading_deg": 0.0, "kind": "station"},
        {"id": "P", "x": 19.0, "y": y0, "heading_deg": 0.0},
        {"id": "Q", "x": 22.0, "y": y0, "heading_deg": 0.0},
        {"id": "SE", "x": x1 - d, "y": y0, "heading_deg": 0.0},
        {"id": "ES", "x": x1, "y": y0 + d, "heading_deg": 90.0},
        {"id": "S2", "x": x1, "y": 7.0, "heading_deg": 90.0, "kind": "station"},
        {"id": "EN", "x": x1, "y": y1 - d, "heading_deg": 90.0},
        {"id": "NE", "x": x1 - d, "y": y1, "heading_deg": 180.0},
        {"id": "S3", "x": 20.0, "y": y1, "heading_deg": 180.0, "kind": "station"},
        {"id": "S4", "x": 10.0, "y": y1, "heading_deg": 180.0, "kind": "station"},
        {"id": "NW", "x": x0 + d, "y": y1, "heading_deg": 180.0},
        {"id": "WN", "x": x0, "y": y1 - d, "heading_deg": 270.0},
        {"id": "C1", "x": x0, "y": 7.0, "heading_deg": 270.0, "kind": "charger"},
        {"id": "WS", "x": x0, "y": y0 + d, "heading_deg": 270.0},
        {"id": "D1", "x": 17.0, "y": 5.0, "heading_deg": 270.0},
        {"id": "D", "x": 17.0, "y": 7.0, "heading_deg": 270.0, "kind": "station"},
    ]
    lane = {"speed_m_s": 1.0}
    edges: list[dict[str, Any]] = [
        {"id": "b1", "from": "SW", "to": "S1", **lane, "two_way": True, "direction": "both"},
        {"id": "b2", "from": "S1", "to": "P", **lane, "two_way": True, "direction": "both"},
        {"id": "b3", "from": "P", "to": "Q", **lane, "two_way": True, "direction": "both"},
        {"id": "b4", "from": "Q", "to": "SE", **lane, "two_way": True, "direction": "both"},
        {"id": "r1", "from": "ES", "to": "S2", **lane},
        {"id": "r2", "from": "S2", "to": "EN", **lane},
        {"id": "t1", "from": "NE", "to": "S3", **lane},
        {"id": "t2", "from": "S3", "to": "S4", "speed_m_s": 0.6, "geometry": {
            # three collinear control points at each end: zero curvature there, G2 with the lanes
            "type": "nurbs", "degree": 3,
            "knot_vector": [0.0, 0.0, 0.0, 0.0, 0.25, 0.5, 0.75, 1.0, 1.0, 1.0, 1.0],
            "control_points": [{"x": 20.0, "y": y1}, {"x": 18.5, "y": y1}, {"x": 17.0, "y": y1},
                               {"x": 15.0, "y": y1 - 1.2, "weight": 1.5},
                               {"x": 13.0, "y": y1}, {"x": 11.5, "y": y1}, {"x": 10.0, "y": y1}]}},
        {"id": "t3", "from": "S4", "to": "NW", **lane},
        {"id": "l1", "from": "WN", "to": "C1", **lane},
        {"id": "l2", "from": "C1", "to": "WS", **lane},
        {"id": "d1", "from": "P", "to": "D1", "speed_m_s": 0.3, "two_way": True, "direction": "both",
         "geometry": {"type": "arc", "radius_m": 2.0, "sweep_deg": -90.0, "heading_deg": 180.0}},
        {"id": "d2", "from": "D1", "to": "D", "speed_m_s": 0.3, "two_way": True, "direction": "both"},
    ]
    for name, a, b, h in (("cSE", "SE", "ES", 0.0), ("cNE", "EN", "NE", 90.0), ("cNW", "NW", "WN", 180.0),
                          ("cSW", "WS", "SW", 270.0)):
        extra_nodes, corner = _corner_edges(name, a, b, h, clothoids)
        start = next(n for n in nodes if n["id"] == a)
        for item in extra_nodes:
            nid, rel = item["rel"]
            nodes.append({"id": nid, "x": float(start["x"] + rel[0]), "y": float(start["y"] + rel[1])})
        edges += corner
    kind = "clothoid" if clothoids else "plain-arc"
    return {"name": f"hall_loop{'' if clothoids else '_arcs'}",
            "description": f"one-way loop in the hall with {kind} corners, a NURBS bend, a two-way lane and a dock",
            "nodes": nodes, "edges": edges}


def _add_corners(nodes: list[dict[str, Any]], edges: list[dict[str, Any]],
                 corners: list[tuple[str, str, str, float]], clothoids: bool) -> None:
    """Append the left 90 deg corners ``(name, from, to, heading_deg)`` and their joint nodes."""
    for name, a, b, h in corners:
        extra_nodes, corner = _corner_edges(name, a, b, h, clothoids)
        start = next(n for n in nodes if n["id"] == a)
        for item in extra_nodes:
            nid, rel = item["rel"]
            nodes.append({"id": nid, "x": round(float(start["x"] + rel[0]), 6),
                          "y": round(float(start["y"] + rel[1]), 6)})
        edges += corner


def _chain(ids: list[str], prefix: str, speed: float, two_way: bool = False) -> list[dict[str, Any]]:
    """Line edges joining consecutive node ids (``prefix`` numbered)."""
    extra: dict[str, Any] = {"two_way": True, "direction": "both"} if two_way else {}
    return [{"id": f"{prefix}{k + 1}", "from": a, "to": b, "speed_m_s": speed, **extra}
            for k, (a, b) in enumerate(itertools.pairwise(ids))]


def warehouse_network(clothoids: bool = True) -> dict[str, Any]:
    """The shipped warehouse route network (``warehouse.yaml``) as plain data.

    In the 60 m x 40 m ``warehouse`` map (four rows of racks, aisles at y = 12, 18
    and 24 m, pillars at (5, 18) and (55, 18)): a counter-clockwise loop of two-way
    main lanes (south y = 5, north y = 34, 1.2 m/s) and one-way columns (west
    x = 7.5 southbound, east x = 52.5 northbound, 1.0 m/s) between the racks and the
    pillars; one-way aisles (y = 12 and 24 eastbound, y = 18 westbound, 0.8 m/s)
    left off the columns. Every turn is a left 90 deg clothoid-arc-clothoid
    (R 2 m, clothoids 1.2 m; ``clothoids=False``: plain quarter circles). Twelve
    stations: S1 on the south lane, A1 A2 / B1 B2 / C1 C2 in the three aisles,
    E1 on the east column, N1 N2 on the north lane, the charger CH on the west
    column, and the dock D south of the south lane, entered backing up through
    the spur P -> D1 -> D (0.3 m/s).
    """
    d = corner_extent(CORNER_RADIUS_M, CLOTHOID_LENGTH_M if clothoids else 0.0)
    xw, xe, ys, yn = 7.5, 52.5, 5.0, 34.0
    aisles = (12.0, 18.0, 24.0)

    def node(nid: str, x: float, y: float, h: float, kind: str = "decision") -> dict[str, Any]:
        out: dict[str, Any] = {"id": nid, "x": round(x, 6), "y": round(y, 6), "heading_deg": h}
        if kind != "decision":
            out["kind"] = kind
        return out

    nodes = [
        # south lane, eastbound (two-way)
        node("SW", xw + d, ys, 0.0), node("S1", 14.0, ys, 0.0, "station"), node("P", 32.0, ys, 0.0),
        node("Q", 36.0, ys, 0.0), node("SE", xe - d, ys, 0.0),
        # east column, northbound
        node("E0", xe, ys + d, 90.0), node("EA1", xe, aisles[0] + d, 90.0), node("EB2", xe, aisles[1] - d, 90.0),
        node("E1", xe, 21.0, 90.0, "station"), node("EC1", xe, aisles[2] + d, 90.0), node("EN", xe, yn - d, 90.0),
        # north lane, westbound (two-way)
        node("NE", xe - d, yn, 180.0), node("N1", 40.0, yn, 180.0, "station"),
        node("N2", 20.0, yn, 180.0, "station"), node("NW", xw + d, yn, 180.0),
        # west column, southbound
        node("WN", xw, yn - d, 270.0), node("WC0", xw, aisles[2] + d, 270.0),
        node("CH", xw, 21.0, 270.0, "charger"), node("WB1", xw, aisles[1] - d, 270.0),
        node("WA0", xw, aisles[0] + d, 270.0), node("WS", xw, ys + d, 270.0),
        # aisle 1 (y = 12) eastbound, aisle 2 (y = 18) westbound, aisle 3 (y = 24) eastbound
        node("A0", xw + d, aisles[0], 0.0), node("A1", 16.0, aisles[0], 0.0, "station"),
        node("A2", 40.0, aisles[0], 0.0, "station"), node("A9", xe - d, aisles[0], 0.0),
        node("B0", xe - d, aisles[1], 180.0), node("B1", 44.0, aisles[1], 180.0, "station"),
        node("B2", 22.0, aisles[1], 180.0, "station"), node("B9", xw + d, aisles[1], 180.0),
        node("C0", xw + d, aisles[2], 0.0), node("C1", 18.0, aisles[2], 0.0, "station"),
        node("C2", 38.0, aisles[2], 0.0, "station"), node("C9", xe - d, aisles[2], 0.0),
        # the dock spur south of the south lane
        node("D1", 30.0, 3.0, 270.0), node("D", 30.0, 1.5, 90.0, "station"),
    ]
    edges = [
        *_chain(["SW", "S1", "P", "Q", "SE"], "s", 1.2, two_way=True),
        *_chain(["E0", "EA1", "EB2", "E1", "EC1", "EN"], "e", 1.0),
        *_chain(["NE", "N1", "N2", "NW"], "n", 1.2, two_way=True),
        *_chain(["WN", "WC0", "CH", "WB1", "WA0", "WS"], "w", 1.0),
        *_chain(["A0", "A1", "A2", "A9"], "a", 0.8),
        *_chain(["B0", "B1", "B2", "B9"], "b", 0.8),
        *_chain(["C0", "C1", "C2", "C9"], "c", 0.8),
        {"id": "d1", "from": "P", "to": "D1", "speed_m_s": 0.3, "two_way": True, "direction": "both",
         "geometry": {"type": "arc", "radius_m": 2.0, "sweep_deg": 90.0, "heading_deg": 180.0}},
        {"id": "d2", "from": "D1", "to": "D", "speed_m_s": 0.3, "two_way": True, "direction": "both"},
    ]
    _add_corners(nodes, edges, [
        ("kSE", "SE", "E0", 0.0), ("kNE", "EN", "NE", 90.0), ("kNW", "NW", "WN", 180.0), ("kSW", "WS", "SW", 270.0),
        ("kA0", "WA0", "A0", 270.0), ("kA9", "A9", "EA1", 0.0), ("kB0", "EB2", "B0", 90.0),
        ("kB9", "B9", "WB1", 180.0), ("kC0", "WC0", "C0", 270.0), ("kC9", "C9", "EC1", 0.0),
    ], clothoids)
    kind = "clothoid" if clothoids else "plain-arc"
    return {"name": f"warehouse{'' if clothoids else '_arcs'}",
            "description": f"60 m x 40 m warehouse: two-way main lanes, one-way columns and aisles, {kind} turns, "
                           "12 stations, a charger and a dock",
            "nodes": nodes, "edges": edges}


def grid_network(side: int, spacing: float = 5.0) -> dict[str, Any]:
    """A ``side`` x ``side`` grid of nodes joined by two-way lines (both directions of travel)."""
    if side < 2:
        raise ValueError(f"side must be at least 2, got {side}")
    nodes = [{"id": f"n{i}_{j}", "x": i * spacing, "y": j * spacing, "kind": "station"}
             for i in range(side) for j in range(side)]
    edges = []
    for i in range(side):
        for j in range(side):
            if i + 1 < side:
                edges.append({"id": f"h{i}_{j}", "from": f"n{i}_{j}", "to": f"n{i + 1}_{j}", "two_way": True})
            if j + 1 < side:
                edges.append({"id": f"v{i}_{j}", "from": f"n{i}_{j}", "to": f"n{i}_{j + 1}", "two_way": True})
    return {"name": f"grid{side}x{side}", "nodes": nodes, "edges": edges}


def warehouse_grid(cols: int = 7, rows: int = 5, spacing: float = 8.0, spur: float = 2.2,
                   one_way: bool = False) -> dict[str, Any]:
    """``agvnav/data/routes/warehouse_grid.yaml``: a traffic layout in the 60 m x 40 m ``warehouse`` map (issue 30).

    A ``cols`` x ``rows`` grid of two-way lanes (junctions ``Jc_r`` every ``spacing`` m from (6, 4) m), and
    at every junction two diagonal dead-end spurs clear of the lanes (``spur`` m in x and in y): a station
    ``Sc_r`` to the north-east (pick and drop places) and a parking place ``Pc_r`` to the south-west.
    For vehicles that turn on the spot (every joint is
    a corner); the traffic benchmark runs its Monte Carlo fleets here.

    ``one_way`` (``warehouse_oneway.yaml``, the layout an exclusive-resource controller such as openTCS
    needs: two vehicles never meet head-on, and every loop of lanes is long, so that a cycle of vehicles
    each waiting for the next needs many of them): one-way aisles along the rows, alternating in direction
    (row 1 west), joined by the outer ring (counter-clockwise) only; the spurs stay two-way dead ends.
    """
    nodes: list[dict[str, Any]] = []
    edges: list[dict[str, Any]] = []
    for c in range(cols):
        for r in range(rows):
            x, y = 6.0 + c * spacing, 4.0 + r * spacing
            j = f"J{c}_{r}"
            nodes += [{"id": j, "x": x, "y": y},
                      {"id": f"S{c}_{r}", "x": x + spur, "y": y + spur, "heading_deg": 45.0, "kind": "station"},
                      {"id": f"P{c}_{r}", "x": x - spur, "y": y - spur, "heading_deg": 225.0, "kind": "station"}]
            edges += [{"id": f"{j}-S", "from": j, "to": f"S{c}_{r}", "speed_m_s": 0.5, "two_way": True},
                      {"id": f"{j}-P", "from": j, "to": f"P{c}_{r}", "speed_m_s": 0.5, "two_way": True}]
            if c + 1 < cols:
                edges.append(_lane(j, f"J{c + 1}_{r}", "E", None if not one_way else _row_east(r, rows)))
            if r + 1 < rows and (not one_way or c in (0, cols - 1)):
                edges.append(_lane(j, f"J{c}_{r + 1}", "N", None if not one_way else c == cols - 1))
    kind = "one-way" if one_way else "two-way"
    return {"name": "warehouse_oneway" if one_way else "warehouse_grid",
            "description": f"{cols} x {rows} grid of {kind} lanes, a station and a "
            "parking spur at every junction (vehicles that turn on the spot)",
            "tolerances": {"joint_deg": 5.0}, "nodes": nodes, "edges": edges}


def _row_east(r: int, rows: int) -> bool:
    """Direction of grid row ``r`` in the one-way layout: the ring counter-clockwise, inner rows alternate."""
    return r == 0 or (r != rows - 1 and r % 2 == 0)


def _lane(a: str, b: str, side: str, forward: bool | None) -> dict[str, Any]:
    """A lane from junction ``a`` to ``b`` (east or north of it): two-way (``forward`` None) or one way."""
    if forward is None:
        return {"id": f"{a}-{side}", "from": a, "to": b, "speed_m_s": 1.0, "two_way": True}
    src, dst = (a, b) if forward else (b, a)
    return {"id": f"{a}-{side}", "from": src, "to": dst, "speed_m_s": 1.0}
