"""``agvnav map LOG [--anchor ...] [--map EXISTING] [--out MAP.yaml]``: survey the reflectors by driving.

LOG is a recorded drive as ``agvnav localize`` reads it (an MCAP file or a CSV folder,
docs/logs.md). Anchors (repeatable): ``surveyed:FILE.yaml``, ``baseline:X1,Y1,X2,Y2,D[,STD_MM]``,
``start_pose[:X,Y,HEADING_DEG]`` (:mod:`agvnav.mapping.anchors`). Without one the command
refuses (exit 2): the scale is unobservable. ``--map`` adds to an existing map without
moving its frame.

Writing follows ``agvnav simulate``'s rules, for a file: the map is written to a temporary
file beside ``--out`` and renamed over it. An existing ``--out`` is refused (exit 2, before
the work) unless ``--force``; the message says whether it is a map agvnav wrote (its first
line is ``# agvnav map:``, :data:`agvnav.mapping.output.MAP_HEADER`) or someone else's file
(a surveyed map, say). ``--plot`` likewise. Anchors that imply an odometry scale error
beyond ``--max-scale-error`` (2 % by default) or that the drive contradicts (a surveyed
reflector beyond :data:`agvnav.mapping.anchors.MAX_ANCHOR_SIGMA` of where the drive puts it)
are refused (exit 2, nothing written), naming the anchor: :func:`agvnav.mapping.check_anchor_fit`.
Argument parsing and printing only; registered lazily (``cli.app.LAZY_COMMANDS``).
"""

from __future__ import annotations

from collections.abc import Callable
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
FORCE_OPT = typer.Option(
    False, "--force", help="Overwrite an existing --out map (or --plot file); without it an existing file is refused."
)
SCALE_OPT = typer.Option(
    2.0, "--max-scale-error", min=0.0,
    help="Largest odometry scale error (%) the anchors may imply before the map is refused as implausible.",
)


@user_errors
def map_command(
    log: Path = LOG_ARG,
    anchor: list[str] | None = ANCHOR_OPT,
    map: str | None = MAP_OPT,
    out: Path = OUT_OPT,
    plot: Path | None = PLOT_OPT,
    radius_mm: float = RADIUS_OPT,
    json: bool = JSON_OPT,
    force: bool = FORCE_OPT,
    max_scale_error: float = SCALE_OPT,
) -> None:
    """Map the reflectors from a recorded drive (SLAM); write a map YAML with per-reflector covariance."""
    from agvnav.logs import read_log  # lazy: start-up time
    from agvnav.mapping import MappingOptions, build_map, check_anchor_fit, map_summary, parse_anchor, write_map
    from agvnav.mapping.output import check_map_file
    from agvnav.world import load_map

    check_map_file(out, force)  # before the work: an existing map (or any other file) is not silently replaced
    if plot is not None:
        _check_plot(plot, force)
    texts = list(anchor or [])
    anchors = [parse_anchor(a) for a in texts]
    existing = load_map(map) if map else None
    recorded = read_log(log)
    options = MappingOptions(radius=radius_mm / 1000.0)
    with RunProgress(f"map {log.name}", key=f"map {log.name}"):
        result = build_map(recorded, anchors, options, existing)
    # anchors from another site (or a mistyped survey) give a confident map in the wrong frame and scale:
    # refused, naming the anchor, before anything is written
    check_anchor_fit(result, anchors, [f"--anchor {t}" for t in texts], max_scale_error / 100.0,
                     existing_label=f"--map {map}" if map else None)
    world = write_map(result, out, options.radius, existing, force=force)
    summary = {"log": str(log), "out": str(out), **map_summary(result)}
    if plot is not None:
        from agvnav.report.mapping import plot_mapping

        _atomic_plot(lambda p: plot_mapping(result, p, existing), plot)
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


def _check_plot(plot: Path, force: bool) -> None:
    """Refuse an existing ``--plot`` file unless ``force`` (a folder always)."""
    if plot.is_dir():
        raise ValueError(f"--plot {plot}: it is a folder, not a file")
    if not plot.parent.is_dir():
        raise ValueError(f"--plot {plot}: the folder {plot.parent} does not exist")
    if plot.exists() and not force:
        raise ValueError(f"--plot {plot}: the file exists; choose another file, or use --force to overwrite it")


def _atomic_plot(draw: Callable[[Path], object], plot: Path) -> None:
    """Draw into a temporary file beside ``plot`` (same suffix: the format) and rename it over ``plot``."""
    import os
    import tempfile

    fd, name = tempfile.mkstemp(prefix=f".{plot.name}.partial-", suffix=plot.suffix, dir=plot.parent)
    os.close(fd)
    try:
        draw(Path(name))
        os.replace(name, plot)
    finally:
        Path(name).unlink(missing_ok=True)
