"""``agvnav map LOG [--anchor ...] [--map EXISTING] [--out MAP.yaml]``: survey the reflectors by driving.

LOG is a recorded drive as ``agvnav localize`` reads it (an MCAP file or a CSV folder,
docs/logs.md). Anchors (repeatable): ``surveyed:FILE.yaml``, ``baseline:X1,Y1,X2,Y2,D[,STD_MM]``,
``start_pose[:X,Y,HEADING_DEG]`` (:mod:`agvnav.mapping.anchors`). Without one the command
refuses (exit 2): the scale is unobservable. ``--map`` adds to an existing map without
moving its frame. Argument parsing and printing only; registered lazily (``cli.app.LAZY_COMMANDS``).
"""

from __future__ import annotations

from pathlib import Path

import typer

from agvnav.bench.common import json_document
from agvnav.cli.errors import user_errors
from agvnav.cli.progress import RunProgress

LOG_ARG = typer.Argument(..., help="Recorded drive: an .mcap file or a folder with odometry.csv and reflections.csv.")
ANCHOR_OPT = typer.Option(
    None, "--anchor", "-a",
    help="surveyed:FILE.yaml | baseline:X1,Y1,X2,Y2,D[,STD_MM] | start_pose[:X,Y,HEADING_DEG] (repeatable).",
)
MAP_OPT = typer.Option(None, "--map", help="Existing map (file or shipped name) to add to; its frame is kept.")
OUT_OPT = typer.Option(Path("map.yaml"), "--out", "-o", help="Map YAML to write (with per-reflector covariance).")
PLOT_OPT = typer.Option(None, "--plot", help="PNG of the map with 3-sigma ellipses and the trajectory.")
RADIUS_OPT = typer.Option(40.0, "--radius-mm", help="Reflector radius (mm).")
JSON_OPT = typer.Option(False, "--json", help="Print the summary as JSON.")


@user_errors
def map_command(
    log: Path = LOG_ARG,
    anchor: list[str] | None = ANCHOR_OPT,
    map: str | None = MAP_OPT,
    out: Path = OUT_OPT,
    plot: Path | None = PLOT_OPT,
    radius_mm: float = RADIUS_OPT,
    json: bool = JSON_OPT,
) -> None:
    """Map the reflectors from a recorded drive (SLAM); write a map YAML with per-reflector covariance."""
    from agvnav.logs import read_log  # lazy: start-up time
    from agvnav.mapping import MappingOptions, build_map, map_summary, parse_anchor, write_map
    from agvnav.world import load_map

    anchors = [parse_anchor(a) for a in anchor or []]
    existing = load_map(map) if map else None
    recorded = read_log(log)
    options = MappingOptions(radius=radius_mm / 1000.0)
    with RunProgress(f"map {log.name}", key=f"map {log.name}"):
        result = build_map(recorded, anchors, options, existing)
    world = write_map(result, out, options.radius, existing)
    summary = {"log": str(log), "out": str(out), **map_summary(result)}
    if plot is not None:
        from agvnav.report.mapping import plot_mapping

        plot_mapping(result, plot, existing)
        summary["plot"] = str(plot)
    if json:
        print(json_document("log", str(log), summary, None, None))
        return
    print(f"{len(world.reflectors)} reflectors ({summary['new_reflectors']} new), anchored by {result.anchor}; "
          f"odometry scale {result.scale:.5f} ± {result.scale_std:.5f}, heading drift "
          f"{result.heading_rate * 1000:.2f} mrad/m, turns {result.turn_scale * 100:+.2f} %")
    print(f"{'id':>8} {'x (m)':>10} {'y (m)':>10} {'std (mm)':>9} {'sightings':>9}")
    for r, n in zip(world.reflectors, result.sightings.tolist(), strict=True):
        print(f"{r.id:>8} {r.x:10.4f} {r.y:10.4f} {r.survey_std_m * 1000:9.2f} {n:9d}")
    print(f"wrote {out}" + (f" and {plot}" if plot is not None else ""))
