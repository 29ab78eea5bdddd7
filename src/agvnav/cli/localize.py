"""``agvnav localize LOG [--map MAP] [--method M] [--out DIR] [--force]``: positioning on recorded data.

LOG is an MCAP file of ROS 2 messages (``agvnav simulate --log``, or a vehicle's
recording with the same topics) or a folder of CSV files (docs/logs.md). The
positioning method runs on the recorded odometry and goniometer reflections as
the simulator feeds it (:func:`agvnav.logs.localize`); DIR receives metrics.json,
timeseries.csv, layout.json, estimate.mcap and the plots (:mod:`agvnav.logs.outputs`),
all at once; ``agvnav report DIR`` reports it like a run. The localization is judged
(:func:`agvnav.logs.judge`): one that failed (too little of the log tracking, too few
reflections used, or off the recorded truth) still writes its files, then prints one
line ``run FAILED: <reason>`` and exits 3, as ``agvnav simulate`` does. A bad log (an
unknown settings key or CSV column, bearings or a mount yaw in degrees, no reflections)
is one line and exit 2; so is an .mcap file without the ``logs`` extra, which a CSV
folder does not need. Argument parsing and printing only; registered lazily
(``cli.app.LAZY_COMMANDS``).
"""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from agvnav.bench.common import Col, display_unit, format_number, json_document, print_table
from agvnav.cli.errors import user_errors
from agvnav.cli.progress import RunProgress
from agvnav.cli.simulate import RUN_FAILED_EXIT
from agvnav.logs import estimator_from_settings, read_log
from agvnav.logs import localize as run_localize
from agvnav.logs.extra import LOGS_EXTRA
from agvnav.logs.outputs import localization_summary, save_localization
from agvnav.logs.writer import logs_extra_installed
from agvnav.report.files import check_out_dir
from agvnav.world import load_map

LOG_ARG = typer.Argument(..., help="Recorded log: an .mcap file or a folder with odometry.csv and reflections.csv.")
MAP_OPT = typer.Option(None, "--map", help="Map YAML file or shipped map name (default: the map the log names).")
METHOD_OPT = typer.Option(None, "--method", help="Positioning method (default: the log's, else ekf).")
OUT_OPT = typer.Option(
    Path("localize_out"), "--out", "-o", help="Output folder for the estimate, its figures and plots."
)
PLOTS_OPT = typer.Option(True, "--plots/--no-plots", help="Write the PNG plots.")
FORCE_OPT = typer.Option(False, "--force", help="Replace an --out folder that holds another result.")
JSON_OPT = typer.Option(False, "--json", help="Print the figures (metrics.json) as JSON with version and machine.")


@user_errors
def localize(
    log: Path = LOG_ARG,
    map: str | None = MAP_OPT,
    method: str | None = METHOD_OPT,
    out: Path = OUT_OPT,
    plots: bool = PLOTS_OPT,
    force: bool = FORCE_OPT,
    json: bool = JSON_OPT,
) -> None:
    """Run a positioning method on a recorded log; write the estimate (CSV and MCAP), its figures and plots."""
    check_out_dir(out, force)
    recorded = read_log(log)
    name = map or recorded.settings.get("map")
    if not name:
        raise ValueError(f"{log}: the log names no map; give one with --map")
    world = load_map(name)  # a file, or a shipped map by name
    estimator = estimator_from_settings(recorded.settings, world, method)
    with RunProgress(f"localize {log.name}", key=f"localize {log.name}"):
        result = run_localize(recorded, estimator, method or recorded.settings.get("method") or "ekf")
    written = save_localization(result, recorded, world, out, force=force, plots=plots, name=log.name)
    console = Console(highlight=False, stderr=json)
    summary = localization_summary(result, recorded, log.name)
    if json:
        print(json_document("log", log.name, {"metrics": summary}, None, None))
    else:
        print_table(_summary_table(summary, log.name))
    console.print(f"wrote {len(written)} files to {out}/: " + ", ".join(p.name for p in written), soft_wrap=True)
    if not logs_extra_installed():
        note = f"estimate.mcap not written: it needs the logs extra ({LOGS_EXTRA})"
        console.print(note, soft_wrap=True, markup=False)
    if summary["outcome"] != "completed":
        console.print(f"run FAILED: {summary['reason']}", soft_wrap=True)
        raise typer.Exit(RUN_FAILED_EXIT)


#: The 0-1 shares of metrics.json, shown in percent.
_SHARES = {"tracking_share": "tracking (% of the duration)", "reflections_used_share": "reflections used (%)"}


def _summary_table(summary: dict[str, object], name: str) -> tuple[str, list[Col], list[list[str]]]:
    """metrics.json as a (figure, value) table, each figure in its display unit (mm, deg, s, %).

    The reason of a failed run is its ``run FAILED`` line; its positioning figures show as ``-``.
    """
    failed = summary.get("outcome") == "failed"
    times = [v for k, v in summary.items() if k.endswith("_s") and isinstance(v, int | float)]
    rows = []
    for key, value in summary.items():
        if key in ("scenario", "reason"):  # the reason is the run FAILED line
            continue
        if key in _SHARES and isinstance(value, float):
            rows.append([_SHARES[key], f"{100 * value:.1f}"])
        elif key.startswith("positioning_") and (failed or value is None):
            # no accuracy figure from a run that failed: it would cover only what little it tracked
            rows.append([display_unit(key, [1e-3])[0], "-"])
        elif isinstance(value, int | float) and not isinstance(value, bool):
            # the times share one unit: tracking 0.65 s beside a 26.1 s duration, not 650.0 ms
            header, _, scale = display_unit(key, times if key.endswith("_s") else [value])
            rows.append([header, format_number(value, scale)])
        else:
            rows.append([key.replace("_", " "), "-" if value is None else str(value)])
    return f"{name}: positioning on the recorded data", [Col("figure", "left", 0), Col("value", "right", 0)], rows
