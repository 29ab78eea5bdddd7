"""The ``agvnav`` command: a thin layer that parses arguments and calls the library."""

from __future__ import annotations

import sys

import typer

from agvnav import __version__
from agvnav.cli.bench import bench_app
from agvnav.cli.campaign import campaign
from agvnav.cli.demo import demo
from agvnav.cli.errors import USER_ERROR_EXIT, err_console
from agvnav.cli.scenarios import scenarios
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
app.command("scenarios")(scenarios)
app.command("campaign")(campaign)


def _version(value: bool) -> None:
    if value:
        print(f"agvnav {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="Print the version and exit."),
) -> None:
    """agvnav: positioning and guidance of automated guided vehicles."""


def main(argv: list[str] | None = None) -> None:
    """Console entry point: usage mistakes become one line on stderr and exit code 2."""
    try:
        code = app(args=argv, prog_name="agvnav", standalone_mode=False)
    except (typer.Abort, KeyboardInterrupt):
        err_console.print("aborted", markup=False)
        sys.exit(1)
    except Exception as exc:  # click's (or typer's vendored click's) usage errors
        if not _is_usage_error(exc):
            raise
        if type(exc).__name__ == "NoArgsIsHelpError":
            print(exc.format_message())
        else:
            err_console.print(f"error: {exc.format_message()}", markup=False)
        sys.exit(USER_ERROR_EXIT)
    sys.exit(code if isinstance(code, int) else 0)


def _is_usage_error(exc: Exception) -> bool:
    """True for click-style usage errors (typer vendors click from 0.2x on, so match by shape)."""
    return hasattr(exc, "format_message") and hasattr(exc, "exit_code")
