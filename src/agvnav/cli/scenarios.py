"""``agvnav scenarios``: every shipped scenario with its vehicle, sensors and one-line description."""

from __future__ import annotations

import typer

from agvnav.bench.common import Col, print_table
from agvnav.cli.errors import user_errors

REFERENCE_OPT = typer.Option(False, "--reference", help="Print the scenario reference (docs/scenarios.md) instead.")
WIDE_OPT = typer.Option(False, "--wide", help="Print every column unwrapped, however wide the terminal.")


@user_errors
def scenarios(reference: bool = REFERENCE_OPT, wide: bool = WIDE_OPT) -> None:
    """List the shipped scenarios (run one with ``agvnav simulate NAME``)."""
    if reference:
        from agvnav.report.reference import reference_markdown

        print(reference_markdown(), end="")
        return
    from agvnav.world.fleet import load_fleet
    from agvnav.world.scenario import ScenarioError, builtin_scenario_names, load_scenario

    cols = [Col("name", "left", 0), Col("vehicle", "left", 1), Col("sensors", "left", 2),
            Col("description", "left", 0, wrap=True)]
    rows = []
    for name in builtin_scenario_names():
        try:
            sc = load_scenario(name)
        except ScenarioError:  # a fleet (issue 28): its vehicles' models
            fleet = load_fleet(name)
            models = sorted({s.vehicle.model for s in fleet.vehicle_scenarios()})
            rows.append([name, f"fleet of {len(fleet.ids)}: {', '.join(models)}", "goniometer",
                         " ".join(fleet.description.split())])
            continue
        sensors = [s for s in ("goniometer", "ultrasonic") if getattr(sc, s, None) is not None] or ["odometry only"]
        rows.append([name, sc.vehicle.model, ", ".join(sensors), " ".join(sc.description.split())])
    print_table(("shipped scenarios (agvnav simulate NAME)", cols, rows), wide=wide)
