"""The ``agvnav`` command: a thin layer that parses arguments and calls the library."""

from __future__ import annotations

import typer

from agvnav import __version__
from agvnav.cli.bench import bench_app
from agvnav.cli.demo import demo
from agvnav.cli.simulate import simulate

app = typer.Typer(
    help="agvnav: positioning and guidance of automated guided vehicles.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
app.add_typer(bench_app, name="bench")
app.command("demo")(demo)
app.command("simulate")(simulate)


def _version(value: bool) -> None:
    if value:
        print(f"agvnav {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="Print the version and exit."),
) -> None:
    """agvnav: positioning and guidance of automated guided vehicles."""


def main() -> None:
    """Console entry point."""
    app()
