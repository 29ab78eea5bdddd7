"""A generated benchmark hall: 100 m x 60 m, 24 rack blocks, about 2 km of routes, about 2,000 candidate sites.

The goniometer sits 0.3 m ahead of base_link, so the two directions of an aisle
see the reflectors from different head positions (the heading matters).
"""

from __future__ import annotations

from typing import Any

from agvnav.layout.schema import LayoutSpec
from agvnav.world.strict import attach_source

__all__ = ["generated_hall", "generated_hall_dict"]


def _box(x0: float, y0: float, x1: float, y1: float) -> list[list[float]]:
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]]


def _line(name: str, x: float, y: float, heading_deg: float, length: float) -> dict[str, Any]:
    return {"name": name, "path": {"start": [x, y, heading_deg], "segments": [{"type": "line", "length_m": length}]}}


def _loop(name: str, sweep: float) -> dict[str, Any]:
    """The perimeter loop at 4 m from the walls, counter-clockwise (``sweep`` 90) or clockwise (-90)."""
    r = 3.0
    segs = []
    sides = (84.0, 46.0) if sweep > 0 else (46.0, 84.0)
    for length in sides * 2:
        segs += [{"type": "line", "length_m": length}, {"type": "arc", "radius_m": r, "sweep_deg": sweep}]
    start = [8.0, 4.0, 0.0] if sweep > 0 else [5.0, 7.0, 90.0]
    return {"name": name, "path": {"start": start, "segments": segs}}


def generated_hall_dict(width: float = 100.0, depth: float = 60.0, quick: bool = False) -> dict[str, Any]:
    """The layout document (plain dict) of the generated hall; ``quick``: the two perimeter loops only."""
    racks, sites = [], [{"face": "outer", "spacing_m": 0.5}]
    for j in range(8):
        y0 = 8.0 + 6.0 * j
        for i, (x0, x1) in enumerate(((10.0, 35.0), (38.0, 63.0), (66.0, 91.0))):
            rid = f"rack_{j + 1}{'abc'[i]}"
            racks.append({"id": rid, "kind": "rack", "points": _box(x0, y0, x1, y0 + 2.0)})
            sites.append({"face": rid, "spacing_m": 1.0})
    routes = [_loop("loop_ccw", 90.0), _loop("loop_cw", -90.0)]
    for j in range(7):
        y = 12.0 + 6.0 * j
        routes += [_line(f"aisle_{j + 1}_east", 5.5, y, 0.0, 89.0), _line(f"aisle_{j + 1}_west", 94.5, y, 180.0, 89.0)]
    for x in (36.5, 64.5):
        routes += [_line(f"cross_{x:g}_north", x, 4.0, 90.0, 52.0), _line(f"cross_{x:g}_south", x, 56.0, 270.0, 52.0)]
    if quick:
        routes = routes[:2]
    return {
        "name": "generated_100x60",
        "hall": {"outer": _box(0.0, 0.0, width, depth), "occluders": racks},
        "routes": routes,
        "goniometer": {"mount": [0.3, 0.0, 0.0], "max_range_m": 30.0, "reflector_radius_m": 0.04},
        "candidates": {"sites": sites},
        "target": {"position_3sigma_m": 0.01, "heading_3sigma_deg": 0.1, "fraction": 0.99, "min_visible": 3},
        "verify": {"vehicle": "differential", "speed_m_s": 1.0, "max_length_m": 100.0, "section_m": 50.0},
    }


def generated_hall(quick: bool = False) -> LayoutSpec:
    """The generated hall as a validated :class:`LayoutSpec` (``quick``: the perimeter loops only)."""
    spec = LayoutSpec.model_validate(generated_hall_dict(quick=quick))
    attach_source(spec, "<generated 100x60 hall>", None, None)
    return spec
