"""Pictures of a route network and of a mission driven on it.

* :func:`plot_network`: edges by geometry kind, stations, and a planned route on top;
* :func:`plot_mission_route`: the network with its stations, the mission's planned path,
  and the driven path of the guided point coloured by its lateral error;
* :func:`plot_station_stops`: the stop position and heading error at each station,
  against the issue-14 targets (10 mm, 0.5 deg);
* :func:`write_mission_plots`: both, for the result of a mission scenario
  (``agvnav simulate``: ``mission_route.png``, ``mission_stops.png``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.report.plots import pyplot
from agvnav.routes.mission import MissionPlan
from agvnav.routes.network import EDGE_KINDS, RouteNetwork
from agvnav.routes.planning import Route

__all__ = ["plot_mission_route", "plot_network", "plot_station_stops", "write_mission_plots"]

#: Station stop targets of issue 14: position (m) and heading (rad).
STOP_TARGET_M = 0.010
STOP_TARGET_RAD = math.radians(0.5)

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


def _draw_walls(ax: Any, walls: NDArray[np.float64] | None) -> None:
    if walls is None or len(walls) == 0:
        return
    from matplotlib.collections import LineCollection  # noqa: PLC0415  (lazy: matplotlib only when plotting)

    ax.add_collection(LineCollection(list(np.asarray(walls)), colors="0.35", linewidths=1.0))


def plot_mission_route(
    network: RouteNetwork,
    plan: MissionPlan,
    driven_xy: NDArray[np.float64],
    lateral: NDArray[np.float64],
    out: str | Path,
    walls: NDArray[np.float64] | None = None,
    reflector_xy: NDArray[np.float64] | None = None,
    title: str = "",
) -> Path:
    """The network (thin, by kind), its stations, the mission's planned path (dashed) and the driven
    path of the guided point coloured by ``|lateral|`` (mm); write a PNG to ``out``.

    ``driven_xy`` ``(n, 2)`` m and ``lateral`` ``(n,)`` m (:func:`agvnav.sim.mission.route_tracking`);
    ``walls`` ``(M, 2, 2)`` and ``reflector_xy`` ``(N, 2)`` (m) drawn when given.
    """
    from matplotlib.collections import LineCollection  # noqa: PLC0415  (lazy: matplotlib only when plotting)

    driven = np.asarray(driven_xy, dtype=np.float64)
    lat_mm = 1e3 * np.abs(np.asarray(lateral, dtype=np.float64))
    if driven.ndim != 2 or driven.shape[1] != 2 or lat_mm.shape != (driven.shape[0],):
        raise ValueError(f"driven_xy must be (n, 2) and lateral (n,), got {driven.shape} and {lat_mm.shape}")
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(12, 8.5))
    _draw_walls(ax, walls)
    if reflector_xy is not None and len(reflector_xy):
        r = np.asarray(reflector_xy)
        ax.plot(r[:, 0], r[:, 1], "o", color="tab:green", ms=3, label="reflectors")
    for e in network.edges.values():
        p = e.curve.points
        ax.plot(p[:, 0], p[:, 1], color=_COLOURS[e.curve.kind], lw=0.8, alpha=0.6)
    n = max(2, math.ceil(plan.path.length / 0.05) + 1)
    planned = np.asarray(plan.path.point_at(np.linspace(0.0, plan.path.length, n)))
    ax.plot(planned[:, 0], planned[:, 1], "k--", lw=0.8, label="planned route")
    if len(driven) >= 2:
        segs = np.stack([driven[:-1], driven[1:]], axis=1)
        vmax = max(float(np.nanpercentile(lat_mm, 99.5)), 1.0)
        lc = LineCollection(list(segs), cmap="viridis", linewidths=2.2)
        lc.set_array(0.5 * (lat_mm[:-1] + lat_mm[1:]))
        lc.set_clim(0.0, vmax)
        ax.add_collection(lc)
        fig.colorbar(lc, ax=ax, shrink=0.8, label="|lateral error| of the guided point [mm]")
    for node in network.nodes.values():
        if node.kind != "decision":
            ax.plot(node.x, node.y, "s" if node.kind == "station" else "^", color="tab:red", ms=6)
            ax.annotate(node.id, (node.x, node.y), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.grid(alpha=0.3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title or f"{network.name}: mission route, driven path coloured by lateral error")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return Path(out)


def plot_station_stops(
    stations: list[str],
    stop_error_m: NDArray[np.float64] | list[float],
    stop_heading_error_rad: NDArray[np.float64] | list[float],
    out: str | Path,
    title: str = "",
) -> Path:
    """Bars of the stop position error (mm) and heading error (deg) per station, with the issue-14
    targets (10 mm, 0.5 deg) as lines; write a PNG to ``out``. Inputs in m and rad, one per stop."""
    e = 1e3 * np.asarray(stop_error_m, dtype=np.float64)
    h = np.degrees(np.asarray(stop_heading_error_rad, dtype=np.float64))
    if not (len(stations) == e.shape[0] == h.shape[0]):
        raise ValueError(f"one station name per stop: {len(stations)} names, {e.shape[0]} and {h.shape[0]} errors")
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    x = np.arange(len(stations))
    labels = [f"{i + 1}: {s}" for i, s in enumerate(stations)]
    for ax, v, target, unit, colour in ((a1, e, 1e3 * STOP_TARGET_M, "mm", "tab:blue"),
                                        (a2, h, math.degrees(STOP_TARGET_RAD), "deg", "tab:orange")):
        ax.bar(x, v, color=colour)
        ax.axhline(target, color="tab:red", ls="--", lw=1.0, label=f"target {target:g} {unit}")
        ax.set_xticks(x, labels, rotation=30, ha="right", fontsize=8)
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=8)
    a1.set_ylabel("stop position error [mm]")
    a2.set_ylabel("stop heading error [deg]")
    fig.suptitle(title or "stop error at each station (true pose)")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return Path(out)


def write_mission_plots(result: Any, out_dir: str | Path) -> list[Path]:
    """``mission_route.png`` and ``mission_stops.png`` of a mission scenario's :class:`agvnav.sim.SimResult`.

    The plan is re-planned from the scenario (deterministic); the lateral error is the guided
    point's against the run it drove (:func:`agvnav.sim.mission.route_tracking`). A result
    without a mission writes nothing.
    """
    from agvnav.sim.mission import load_mission_network, plan_mission, route_tracking, tracked_point  # noqa: PLC0415

    sc = result.scenario
    if sc.mission is None:
        return []
    out = Path(out_dir)
    plan = plan_mission(sc)
    network = load_mission_network(sc)
    series = result.series
    _, lateral = route_tracking(series, plan)
    moving = np.abs(series["v_cmd"]) > 1e-6
    lateral = np.where(moving, lateral, 0.0)
    written = [plot_mission_route(network, plan, tracked_point(series), lateral, out / "mission_route.png",
                                  result.world.wall_segments, result.world.reflector_xy,
                                  f"{sc.name}: driven path coloured by the lateral error of the guided point")]
    names = [str(leg.station) for leg in plan.legs if leg.route is not None and leg.route.traversals]
    k = int(result.extra.get("stations", 0))
    errs = [result.extra.get(f"stop_error_m[{i}]", math.nan) for i in range(k)]
    herrs = [result.extra.get(f"stop_heading_error_rad[{i}]", math.nan) for i in range(k)]
    if k:
        written.append(plot_station_stops(names[:k], errs, herrs, out / "mission_stops.png",
                                          f"{sc.name}: stop error at each station (true pose)"))
    return written
