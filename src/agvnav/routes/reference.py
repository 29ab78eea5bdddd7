"""The route network file format as Markdown (a section of docs/scenarios.md), from its schema."""

from __future__ import annotations

from agvnav.routes.schema import NetworkSpec
from agvnav.world.reference import schema_rows

__all__ = ["network_reference"]


def network_reference() -> list[str]:
    """Markdown lines: the route network keys (type, unit, default, meaning) and how missions use them."""
    lines = [
        "## Route network files (`mission.network`)",
        "",
        "A route network (issue 14; shipped in `agvnav/data/routes`: `hall_loop`, `hall_loop_arcs`, and the",
        "60 x 40 m `warehouse`, `warehouse_arcs` in the `warehouse` map; scenario `warehouse_mission`) lists",
        "nodes and directed edges. Each edge's geometry starts at its `from` node and must end within",
        "`tolerances.gap_m` of its `to` node; arcs and clothoids start with `heading_deg` (default the",
        "`from` node's). Edges continuing each other at a node (tangents within `tolerances.joint_deg`)",
        "must join within `tolerances.heading_deg` (G1); curvature jumps next to a clothoid are reported",
        "(G2, `agvnav routes check`). `direction`: how the vehicle may drive along the edge (facing",
        "forward, backing up, or either); `two_way` adds the edge driven from `to` to `from` (id `ID~r`).",
        "Clothoids and NURBS are followed as G1 arc chains sampled every 0.05 m (the measured deviation,",
        "about 0.1 mm, is printed by `agvnav routes check`).",
        "",
        "| key | type | unit | default | meaning |",
        "| --- | --- | --- | --- | --- |",
    ]
    for r in schema_rows(NetworkSpec):
        key = r.key.replace("edges[].source", "edges[].from")  # the YAML key (a Python keyword in the model)
        unit = "1/m" if key.endswith("_per_m") else r.unit
        cells = (f"`{key}`", r.type, unit, r.default, r.meaning)
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return lines
