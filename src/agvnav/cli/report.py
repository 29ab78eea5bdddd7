"""``agvnav report RUN_DIR [--out FILE]``: one self-contained HTML report of a run folder.

Reads the folder ``agvnav simulate`` wrote and writes ``RUN_DIR/report.html`` (or
FILE): plots inlined, no network needed (:mod:`agvnav.report.html`). An existing FILE that
is not a report agvnav wrote is refused (exit 2) unless ``--force``; the write is atomic.
"""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from agvnav.cli.errors import user_errors
from agvnav.cli.progress import RunProgress
from agvnav.report.html import check_report_file, write_html_report

RUN_ARG = typer.Argument(..., help="A run folder written by agvnav simulate --out.")
OUT_OPT = typer.Option(None, "--out", "-o", help="HTML file to write (default RUN_DIR/report.html).")
FORCE_OPT = typer.Option(False, "--force", help="Overwrite an --out file that is not a report agvnav wrote.")


@user_errors
def report(run_dir: Path = RUN_ARG, out: Path | None = OUT_OPT, force: bool = FORCE_OPT) -> None:
    """Write one self-contained HTML report (plots, metrics, a time slider) of a run folder."""
    if not (run_dir / "metrics.json").is_file():
        raise ValueError(f"{run_dir}: not a run folder (no metrics.json)")
    check_report_file(out if out is not None else run_dir / "report.html", force)  # before the work
    with RunProgress(f"report {run_dir.name}", key="report"):
        path = write_html_report(run_dir, out, force)
    Console(highlight=False).print(f"wrote {path}")
