"""Pictures of a route network: edges by geometry kind, stations, and a planned route on top."""

from __future__ import annotations

from pathlib import Path

from agvnav.report.plots import pyplot
from agvnav.routes.network import EDGE_KINDS, RouteNetwork
from agvnav.routes.planning import Route

__all__ = ["plot_network"]

_COLOURS = dict(zip(EDGE_KINDS, ("0.45", "tab:blue", "tab:orange", "tab:purple"), strict=True))


def plot_network(network: RouteNetwork, out: str | Path, route: Route | None = None) -> Path:
    """Draw ``network`` (edges coloured by kind, stations labelled) and ``route`` in red; write a PNG to ``out``."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(10, 6))
    seen: set[str] = set()
    for e in network.edges.values():
        p = e.curve.points
        label = e.curve.kind if e.curve.kind not in seen else None
        seen.add(e.curve.kind)
        ax.plot(p[:, 0], p[:, 1], color=_COLOURS[e.curve.kind], lw=1.5, label=label)
    if route is not None:
        for i, t in enumerate(route.traversals):
            p = t.edge.curve.points
            ax.plot(p[:, 0], p[:, 1], color="tab:red", lw=3.5, alpha=0.6,
                    ls="-" if t.mode > 0 else "--", label="planned route" if i == 0 else None)
    for n in network.nodes.values():
        if n.kind != "decision":
            ax.plot(n.x, n.y, "s" if n.kind == "station" else "^", color="k", ms=6)
            ax.annotate(n.id, (n.x, n.y), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{network.name}: route network" + ("" if route is None else f", route {route.time_s:.1f} s"))
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return Path(out)
