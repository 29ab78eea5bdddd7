"""``agvnav routes ...``: check a network's continuity, plan a route (issue 14), its conflict zones (issue 30).

Thin layer: parses arguments, calls :mod:`agvnav.routes`, prints. The library is
imported inside the commands, so ``agvnav --help`` stays light.
"""

from __future__ import annotations

import math

import typer

from agvnav.cli.errors import user_errors

routes_app = typer.Typer(help="Route networks: continuity report and route planning.", no_args_is_help=True)

BLOCK_OPT = typer.Option(None, "--block", help="Blocked edge id (repeat for more).")
MODELS_OPT = typer.Option(..., "--model", help="Vehicle model (repeat for more: conflicts between them).")
NETWORK_ARG = typer.Argument(..., help="Route network YAML file, or a shipped network name (e.g. hall_loop).")


@routes_app.command("check")
@user_errors
def check(
    network: str = NETWORK_ARG,
    json: bool = typer.Option(False, "--json", help="Machine-readable output."),
    wide: bool = typer.Option(False, "--wide", help="Print every table column, however wide the terminal."),
) -> None:
    """Load a route network and report the continuity (G1, and G2 next to clothoids) of every joint.

    With ``--json`` the output is one JSON document: ``records`` (the joints), ``approximation``
    (the arc-chain error of each curved edge) and ``not_g2`` (joints next to a clothoid that are not G2).
    """
    from agvnav.bench.common import emit, json_document
    from agvnav.routes.network import load_network

    net = load_network(network)
    records = [
        {"node": j.node, "incoming": j.incoming, "outgoing": j.outgoing,
         "heading_jump_deg": math.degrees(j.heading_jump), "curvature_jump_per_m": j.curvature_jump,
         "g1": j.g1, "g2": j.g2 if j.g2_required else None}
        for j in net.joints()
    ]
    approx = [{"edge": e.id, "kind": e.curve.kind, "approx_error_m": e.curve.approx_error_m}
              for e in net.edges.values() if e.curve.kind in ("clothoid", "nurbs")]
    bad = [r for r in records if r["g2"] is False]
    if json:  # one document (the tables below are two)
        body = {"network": net.name, "nodes": len(net.nodes), "edges": len(net.edges), "records": records,
                "approximation": approx, "not_g2": len(bad)}
        print(json_document("benchmark", "routes check", body, None, None))
        return
    emit("routes check", records, as_json=False, wide=wide,
         title=f"{net.name}: {len(net.nodes)} nodes, {len(net.edges)} edges, {len(records)} joints")
    if approx:
        emit("routes approximation", approx, as_json=False, wide=wide,
             title="arc-chain approximation of curved edges")
    if bad:
        print(f"{len(bad)} joint(s) next to a clothoid are not G2 (curvature jump beyond tolerance)")


@routes_app.command("plan")
@user_errors
def plan(
    network: str = NETWORK_ARG,
    start: str = typer.Option(..., "--from", help="Start node."),
    goal: str = typer.Option(..., "--to", help="Goal station."),
    model: str = typer.Option("tricycle", "--model", help="Vehicle model (which edges and turns it may use)."),
    speed: float = typer.Option(1.0, "--speed", min=0.01, help="Vehicle cruise speed (m/s)."),
    heading_deg: float | None = typer.Option(None, "--heading-deg", help="Start heading (default the node's)."),
    block: list[str] | None = BLOCK_OPT,
    reverse_into: bool = typer.Option(False, "--reverse-into", help="Arrive backing up the last edge."),
    plot: str | None = typer.Option(None, "--plot", help="Write a PNG of the network with the route."),
) -> None:
    """Plan the fastest route between two nodes for a vehicle model (heading-aware, blocked edges)."""
    from agvnav.routes.network import load_network
    from agvnav.routes.planning import Planner, VehicleLimits

    net = load_network(network)
    planner = Planner(net, VehicleLimits(model, max_speed=speed), tuple(block or ()))
    h = None if heading_deg is None else math.radians(heading_deg)
    route = planner.plan(start, goal, h, -1 if reverse_into else None)
    print(f"route {start} -> {goal} for a {model}: {len(route.traversals)} edges, {route.time_s:.1f} s")
    for t in route.traversals:
        how = "forward" if t.mode > 0 else "reverse"
        print(f"  {t.edge.id:>10}  {t.edge.source} -> {t.edge.target}  {t.edge.curve.kind:<8} {how:<7} "
              f"{t.edge.curve.length:7.2f} m")
    if plot is not None:
        from agvnav.report.routes import plot_network

        print(f"wrote {plot_network(net, plot, route)}")


@routes_app.command("conflicts")
@user_errors
def conflicts(
    network: str = NETWORK_ARG,
    model: list[str] = MODELS_OPT,
    margin_mm: float = typer.Option(100.0, "--margin-mm", min=0.0, help="Safety margin between swept shapes (mm)."),
    check_step_mm: float = typer.Option(50.0, "--check-step-mm", min=1.0,
                                        help="Pose step of the brute-force check (mm)."),
    out: str | None = typer.Option(None, "--out", help="Folder for conflicts.json and conflicts.png."),
    force: bool = typer.Option(False, "--force", help="Replace a previous conflicts output in --out."),
    json: bool = typer.Option(False, "--json", help="Machine-readable output (the conflicts.json document)."),
    wide: bool = typer.Option(False, "--wide", help="Print every table column, however wide the terminal."),
) -> None:
    """Compute the conflict zones of a network for vehicle models (footprints swept along the edges, turned at
    the nodes), check them against brute-force footprint intersection, print them (and write them with --out).

    A check that finds a missed conflict is an untrustworthy result: one line, exit 3.
    """
    from agvnav.bench.common import emit, json_document
    from agvnav.cli.simulate import RUN_FAILED_EXIT
    from agvnav.report.conflicts import conflict_records, conflicts_document, write_conflicts
    from agvnav.report.files import check_out_dir
    from agvnav.routes.network import load_network
    from agvnav.traffic.zones import conflict_zones, find_missed_conflicts

    net = load_network(network)
    if out is not None:
        check_out_dir(out, force, marker="conflicts.json", what="conflict zones output")
    zones = conflict_zones(net, model, margin_m=margin_mm / 1000.0)
    step = check_step_mm / 1000.0
    missed = find_missed_conflicts(net, zones.models, zones, step_m=step)
    if missed:
        a, ra, b, rb = missed[0]
        print(f"untrustworthy conflict zones: the brute-force check found {len(missed)} missed conflict(s), "
              f"first {a} {ra[0]} {ra[1]} with {b} {rb[0]} {rb[1]}")
        raise typer.Exit(RUN_FAILED_EXIT)
    doc = conflicts_document(zones, len(missed), step)
    written = write_conflicts(net, zones, doc, out, force) if out is not None else []
    if json:
        print(json_document("benchmark", "routes conflicts", doc, None, None))
        return
    groups = zones.zones()
    title = (f"{net.name}: conflicts for {', '.join(zones.models)} (margin {margin_mm:g} mm); "
             f"{len(groups)} zone(s); brute-force check every {check_step_mm:g} mm: 0 missed")
    emit("routes conflicts", conflict_records(zones), as_json=False, wide=wide, title=title)
    for i, z in enumerate(groups):
        print(f"zone {i + 1}: {' '.join(f'{k} {r}' for k, r in sorted(z))}")
    for p in written:
        print(f"wrote {p}")


@routes_app.command("import-lif")
@user_errors
def import_lif(
    file: str = typer.Argument(..., help="LIF 1.0 JSON file."),
    out: str = typer.Option(..., "--out", help="Route network YAML file to write."),
    layout: str | None = typer.Option(None, "--layout", help="Layout id to import (default the first)."),
    force: bool = typer.Option(False, "--force", help="Replace an existing --out file."),
) -> None:
    """Import a route network from LIF 1.0 leniently: print what was fixed, name the first problem of a non-LIF file."""
    from pathlib import Path

    from agvnav.report.lif import check_out_file, write_network_yaml
    from agvnav.traffic.lif import import_lif as read_lif
    from agvnav.traffic.lif import parse_lif_text

    check_out_file(out, force)
    src = Path(file)
    doc = parse_lif_text(src.read_text(encoding="utf-8"), str(src))
    try:
        result = read_lif(doc, layout)
    except ValueError as exc:
        raise ValueError(f"{src}: {exc}") from None
    for fix in result.fixes:
        print(f"fixed: {fix}")
    net = result.network
    path = write_network_yaml(result.data, f"route network imported from LIF {src.name} by agvnav routes import-lif",
                              out, force)
    print(f"{net.name}: {len(net.nodes)} nodes, {len(net.edges)} edges, {len(net.stations)} stations; "
          f"{len(result.fixes)} fix(es); wrote {path}")


@routes_app.command("export-lif")
@user_errors
def export_lif(
    network: str = NETWORK_ARG,
    out: str = typer.Option(..., "--out", help="LIF JSON file to write."),
    force: bool = typer.Option(False, "--force", help="Replace an existing --out file."),
) -> None:
    """Export a route network as LIF 1.0 JSON, validated against the LIF schema before it is written."""
    from agvnav.report.lif import check_out_file, write_lif
    from agvnav.routes.network import load_network
    from agvnav.traffic.lif import export_lif as to_lif

    check_out_file(out, force)
    net = load_network(network)
    doc = to_lif(net)
    path = write_lif(doc, out, force)
    lay = doc["layouts"][0]
    print(f"{net.name}: {len(lay['nodes'])} nodes, {len(lay['edges'])} edges, {len(lay['stations'])} stations; "
          f"valid LIF {doc['metaInformation']['lifVersion']}; wrote {path}")
