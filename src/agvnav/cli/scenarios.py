"""``agvnav scenarios``: every shipped scenario with its vehicle, sensors and one-line description."""

from __future__ import annotations

import typer
from rich.console import Console
from rich.table import Table

from agvnav.cli.errors import user_errors

REFERENCE_OPT = typer.Option(False, "--reference", help="Print the scenario reference (docs/scenarios.md) instead.")


@user_errors
def scenarios(reference: bool = REFERENCE_OPT) -> None:
    """List the shipped scenarios (run one with ``agvnav simulate NAME``)."""
    if reference:
        from agvnav.report.reference import reference_markdown

        print(reference_markdown(), end="")
        return
    from agvnav.world.scenario import builtin_scenario_names, load_scenario

    table = Table(title="shipped scenarios (agvnav simulate NAME)")
    for column in ("name", "vehicle", "sensors", "description"):
        table.add_column(column, overflow="fold")
    for name in builtin_scenario_names():
        sc = load_scenario(name)
        sensors = [s for s in ("goniometer", "ultrasonic") if getattr(sc, s, None) is not None] or ["odometry only"]
        table.add_row(name, sc.vehicle.model, ", ".join(sensors), sc.description)
    Console(highlight=False).print(table)
