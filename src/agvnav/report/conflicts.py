"""The conflict zones of a route network as files: ``conflicts.json`` and ``conflicts.png``.

* :func:`conflicts_document`: per pair of models, each resource and what conflicts with it
  (the resources sharing no node with it listed apart, ``near``), the display zones, the
  brute-force check's figure;
* :func:`plot_conflicts`: the network, every zone's swept shapes in a colour of its own;
* :func:`write_conflicts`: both into a folder, atomically (:func:`agvnav.report.files.atomic_dir`,
  marker ``conflicts.json``: a folder of other files is refused, one of ours only with ``force``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import shapely

from agvnav._json import json_text
from agvnav.report.files import atomic_dir
from agvnav.report.plots import pyplot
from agvnav.routes.network import RouteNetwork
from agvnav.traffic.zones import ConflictZones, Resource

__all__ = ["CONFLICTS_MARKER", "conflict_records", "conflicts_document", "plot_conflicts", "write_conflicts"]

#: The file that makes a folder a ``routes conflicts`` output.
CONFLICTS_MARKER = "conflicts.json"


def _label(res: Resource) -> str:
    return f"{res[0]} {res[1]}"


def conflict_records(zones: ConflictZones) -> list[dict[str, Any]]:
    """One record per (model_a, resource, model_b): how many resources conflict and the ``near`` ones
    (sharing no node with it: the conflicts a drawing would not show)."""
    out = []
    for a in zones.models:
        for b in zones.models:
            for res in sorted(zones.shapes[a]):
                c = zones.conflicts(a, res, b)
                near = sorted(r for r in c if not (zones.ends(r) & zones.ends(res)))
                out.append({"model_a": a, "resource": _label(res), "model_b": b, "conflicts": len(c),
                            "near": " ".join(_label(r) for r in near)})
    return out


def conflicts_document(zones: ConflictZones, missed: int, step_m: float) -> dict[str, Any]:
    """The content of conflicts.json: models, margin, the zones, every resource's conflicts, the check."""
    tables = {
        f"{a}|{b}": {_label(r): sorted(_label(x) for x in zones.conflicts(a, r, b)) for r in sorted(zones.shapes[a])}
        for a in zones.models for b in zones.models
    }
    return {"network": zones.network, "models": list(zones.models), "margin_m": zones.margin_m,
            "zones": [sorted(_label(r) for r in z) for z in zones.zones()],
            "conflicts": tables, "missed_conflicts": missed, "check_step_m": step_m}


def plot_conflicts(network: RouteNetwork, zones: ConflictZones, out: str | Path) -> Path:
    """Draw the network and each zone's swept shapes (union over the models) in its own colour; PNG to ``out``."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(10, 6))
    for e in network.edges.values():
        p = e.curve.points
        ax.plot(p[:, 0], p[:, 1], color="0.4", lw=1.0)
    cmap = plt.get_cmap("tab10")
    for i, zone in enumerate(zones.zones()):
        parts = [zones.shapes[m][r] for m in zones.models for r in zone if r in zones.shapes[m]]
        _fill(ax, shapely.union_all(parts), cmap(i % 10), f"zone {i + 1} ({len(zone)} resources)")
    for n in network.nodes.values():
        if n.kind != "decision":
            ax.plot(n.x, n.y, "s", color="k", ms=4)
            ax.annotate(n.id, (n.x, n.y), textcoords="offset points", xytext=(3, 3), fontsize=7)
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{network.name}: conflict zones for {', '.join(zones.models)} (margin {zones.margin_m * 1000:g} mm)")
    if zones.zones():
        ax.legend(loc="best", fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return Path(out)


def _fill(ax: Any, geometry: Any, colour: Any, label: str) -> None:
    polys = getattr(geometry, "geoms", [geometry])
    for k, poly in enumerate(polys):
        if poly.is_empty or poly.geom_type != "Polygon":
            continue
        x, y = poly.exterior.xy
        ax.fill(x, y, color=colour, alpha=0.35, lw=0.8, label=label if k == 0 else None)


def write_conflicts(network: RouteNetwork, zones: ConflictZones, document: dict[str, Any], out: str | Path,
                    force: bool = False) -> list[Path]:
    """Write ``conflicts.json`` and ``conflicts.png`` into folder ``out`` atomically (module doc)."""
    with atomic_dir(out, force, marker=CONFLICTS_MARKER, what="conflict zones output") as tmp:
        (tmp / CONFLICTS_MARKER).write_text(json_text(document) + "\n", encoding="utf-8")
        plot_conflicts(network, zones, tmp / "conflicts.png")
    return [Path(out) / CONFLICTS_MARKER, Path(out) / "conflicts.png"]
