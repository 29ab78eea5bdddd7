"""``agvnav layout``: plan where the reflectors go, write the map, heat map and table; ``--verify`` drives the routes.

Output: ``DIR/map.yaml``, ``heatmap.png`` and ``plan.json``, all at once at the end (a temporary
folder renamed into place). A DIR holding another layout (a plan.json) is refused unless
``--force``, which replaces it whole; a non-empty DIR without a plan.json is never written into
(exit 2, checked before planning).

A thin layer: parse, call :func:`agvnav.layout.plan_layout`, write with
:func:`agvnav.report.layout.write_layout`, print. Bad input (a polygon that does
not close, a route outside the hall, a reflector inside a rack, a target no
candidate set can meet) is one line on stderr and exit 2.
"""

from __future__ import annotations

from pathlib import Path

import typer

from agvnav.bench.common import emit, json_document
from agvnav.cli.errors import user_errors
from agvnav.cli.progress import RunProgress
from agvnav.layout import load_layout, plan_layout, summary_rows
from agvnav.layout.verify import verify_plan
from agvnav.report.files import check_out_dir
from agvnav.report.layout import LAYOUT_MARKER, plan_record, write_layout

__all__ = ["layout"]

SPEC_ARG = typer.Argument(..., help="Layout file (YAML), or a shipped one by name: warehouse, generated_100x60.")
OUT_OPT = typer.Option(None, "--out", "-o", help="Output folder (default: ./<name>_layout).")
VERIFY_OPT = typer.Option(False, "--verify", help="Drive the routes in the closed loop; measured vs predicted RMS.")
JSON_OPT = typer.Option(False, "--json", help="Print the plan (and verification) as JSON, with version and machine.")
FORCE_OPT = typer.Option(False, "--force", help="Replace an --out folder that holds another layout (a plan.json).")
WIDE_OPT = typer.Option(False, "--wide", help="Print every table column, however wide the terminal.")


@user_errors
def layout(
    spec: str = SPEC_ARG, out: Path | None = OUT_OPT, verify: bool = VERIFY_OPT, json: bool = JSON_OPT,
    wide: bool = WIDE_OPT, force: bool = FORCE_OPT,
) -> None:
    """Plan a reflector layout for the routes of a hall: map YAML, heat map PNG and a table against a baseline."""
    doc = load_layout(spec)
    target = out if out is not None else Path(f"{doc.name}_layout")
    check_out_dir(target, force, marker=LAYOUT_MARKER, what="layout")  # before the planning's seconds
    with RunProgress(f"layout {doc.name}", key=f"layout plan {doc.name}"):
        plan = plan_layout(doc)
    paths = write_layout(plan, target, force)
    checks = []
    if verify:
        with RunProgress(f"verify {doc.name}", key=f"layout verify {doc.name}"):
            checks = verify_plan(plan)
    if json:
        record = plan_record(plan) | {"files": {k: str(v) for k, v in paths.items()}, "verify": checks}
        print(json_document("layout", doc.name, record, doc.seed, None))
        return
    emit("layout", summary_rows(plan), as_json=False, wide=wide,
         title=f"{doc.name}: planned layout against regular spacing ({plan.baseline_spacing_m:.1f} m)")
    print(plan.result.guarantee)
    print(f"planned in {plan.runtime_s:.1f} s; wrote {', '.join(str(p) for p in paths.values())}")
    if checks:
        emit("layout-verify", checks, as_json=False, wide=wide,
             title="closed loop: measured against predicted RMS per section")
