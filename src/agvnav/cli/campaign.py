"""``agvnav campaign SPEC.yaml [--out DIR] [--scheduler ADDRESS] [--workers N] [--json]``: Monte Carlo campaigns.

Runs every run of the campaign on a Dask cluster (a local one of ``--workers``
processes, default 2, or the existing ``--scheduler``), streaming results to
``DIR/runs/*.parquet``; started again on the same ``--out`` it runs only what
is missing. DIR must be absent, empty or this campaign's own folder (its
``campaign.json``); a folder of another campaign is refused unless ``--force``,
which replaces it whole, and a folder of other files is never written into
(exit 2, before anything runs). Prints the summary table (or ``--json``) and writes
``DIR/summary.json`` and ``DIR/plots/campaign_<metric>.png``. ``--replay N``
writes run N's whole scenario to ``DIR/replay/`` for ``agvnav simulate``
instead of running the campaign. Argument parsing and printing only: the work
is :func:`agvnav.campaign.run_campaign`, imported when the command runs so
``agvnav --help`` stays fast.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import typer
from rich.console import Console

from agvnav.bench.common import json_document, print_table
from agvnav.cli.errors import err_console, fail, user_errors
from agvnav.cli.progress import RunProgress

#: Exit code after Ctrl-C (128 + SIGINT), as shells report it.
INTERRUPTED_EXIT = 130

SPEC_ARG = typer.Argument(..., help="Campaign YAML file, or a shipped campaign name (default_seeds).")
OUT_OPT = typer.Option(Path("campaign_out"), "--out", "-o", help="Output folder (Parquet runs, summary.json, plots).")
SCHED_OPT = typer.Option(None, "--scheduler", help="Address of an existing Dask scheduler (default: a local cluster).")
WORKERS_OPT = typer.Option(None, "--workers", min=1, help="Worker processes of the local cluster (default 2).")
JSON_OPT = typer.Option(False, "--json", help="Print the run counts, speed and summary as JSON.")
PLOTS_OPT = typer.Option(True, "--plots/--no-plots", help="Write the PNG plots.")
WIDE_OPT = typer.Option(False, "--wide", help="Print every table column, however wide the terminal.")
FORCE_OPT = typer.Option(
    False, "--force", help="Replace an --out folder that holds another campaign's results (a different spec or base)."
)
REPLAY_OPT = typer.Option(
    None, "--replay", min=0, help="Write run N's scenario to DIR/replay/ for `agvnav simulate`, and run nothing."
)


def _library() -> Any:
    try:
        import importlib

        import agvnav.campaign as lib

        importlib.import_module("agvnav.campaign.runner")  # Dask, pyarrow (the package imports without them)
    except ImportError as exc:
        raise fail(f"agvnav campaign needs the campaign extra: pip install 'agvnav[campaign]' ({exc})") from None
    return lib


@user_errors
def campaign(
    spec: str = SPEC_ARG,
    out: Path = OUT_OPT,
    scheduler: str | None = SCHED_OPT,
    workers: int | None = WORKERS_OPT,
    json_out: bool = JSON_OPT,
    plots: bool = PLOTS_OPT,
    replay: int | None = REPLAY_OPT,
    wide: bool = WIDE_OPT,
    force: bool = FORCE_OPT,
) -> None:
    """Run a Monte Carlo campaign on Dask; write Parquet results, summary.json and plots."""
    lib = _library()
    camp = lib.load_campaign(spec)
    console = Console(highlight=False)  # long paths stay on one line (soft_wrap) so they can be copied
    if replay is not None:
        path = lib.write_replay(camp, replay, out, force)
        hint = f"wrote {path}; replay run {replay} alone with: agvnav simulate {path}"
        console.print(hint, markup=False, soft_wrap=True)
        return
    try:
        with RunProgress(f"campaign {camp.name}", None, "runs") as bar:
            result = lib.run_campaign(camp, out, scheduler=scheduler, workers=workers, progress=bar.runs, force=force)
    except KeyboardInterrupt:
        saved = len(lib.finished_runs(out))
        err_console.print(f"interrupted: {saved} runs are saved in {out}/runs; the same command resumes", markup=False)
        raise typer.Exit(code=INTERRUPTED_EXIT) from None
    written = []
    if plots:
        import tempfile

        from agvnav.report.campaign import plot_campaign
        from agvnav.report.files import replace_dir

        columns = lib.read_results(out).to_pydict()
        plots_dir = Path(out) / "plots"
        tmp = Path(tempfile.mkdtemp(prefix=".plots.partial-", dir=out))
        try:  # the plots appear together (a temporary folder beside them, renamed)
            names = [p.name for p in plot_campaign(
                columns, result.summary["metrics"], camp.swept, tmp, camp.name, result.summary
            )]
            replace_dir(tmp, plots_dir)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        written = [plots_dir / n for n in names]
    if json_out:
        print(json_document("campaign", camp.name, _json(result), camp.seed, None))
        return
    from agvnav.report.campaign import summary_sections, summary_table

    print_table(summary_table(camp.name, result.summary), wide=wide, sections=summary_sections(result.summary))
    speed = f", {result.runs_per_s:.2f} runs/s" if result.runs_per_s else ""
    console.print(
        f"{result.ran} runs done, {result.skipped} already there, on {result.workers} workers in "
        f"{result.wall_s:.1f} s{speed}; wrote {out}/runs, {out}/summary.json and {len(written)} plots",
        markup=False,
        soft_wrap=True,
    )


def _json(result: Any) -> dict[str, Any]:
    return {
        "out": str(result.out_dir),
        "runs": result.total,
        "ran": result.ran,
        "skipped": result.skipped,
        "workers": result.workers,
        "wall_s": result.wall_s,
        "runs_per_s": result.runs_per_s,
        "summary": result.summary,
    }
