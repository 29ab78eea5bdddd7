"""``agvnav report RUN_DIR [--out FILE]``: one self-contained HTML report of a run folder.

Reads the folder ``agvnav simulate`` wrote and writes ``RUN_DIR/report.html`` (or
FILE): plots inlined, no network needed (:mod:`agvnav.report.html`).
"""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from agvnav.cli.errors import user_errors
from agvnav.cli.progress import RunProgress
from agvnav.report.html import write_html_report

RUN_ARG = typer.Argument(..., help="A run folder written by agvnav simulate --out.")
OUT_OPT = typer.Option(None, "--out", "-o", help="HTML file to write (default RUN_DIR/report.html).")


@user_errors
def report(run_dir: Path = RUN_ARG, out: Path | None = OUT_OPT) -> None:
    """Write one self-contained HTML report (plots, metrics, a time slider) of a run folder."""
    if not (run_dir / "metrics.json").is_file():
        raise ValueError(f"{run_dir}: not a run folder (no metrics.json)")
    with RunProgress(f"report {run_dir.name}", key="report"):
        path = write_html_report(run_dir, out)
    Console(highlight=False).print(f"wrote {path}")
