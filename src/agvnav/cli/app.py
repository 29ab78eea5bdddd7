"""The ``agvnav`` command: a thin layer that parses arguments and calls the library.

Start-up (issue 11): ``agvnav --help`` must not import the library (NumPy, numba,
SciPy, matplotlib). The commands whose modules import the library at the top are
registered lazily: :data:`LAZY_COMMANDS` names the module, the function and the
one-line help that ``--help`` lists; the module is imported only when that command
runs (or shows its own ``--help``). ``tests/cli/test_startup.py`` checks that each
listed help line is the first line of the command's docstring, so they cannot drift.
"""

from __future__ import annotations

import atexit
import gc
import importlib
import sys
from typing import Any, Protocol, TypeGuard

import typer
from typer.core import TyperCommand, TyperGroup
from typer.main import get_command

from agvnav import __version__
from agvnav.cli.bench import bench_app
from agvnav.cli.campaign import campaign
from agvnav.cli.errors import USER_ERROR_EXIT, err_console
from agvnav.cli.routes import routes_app
from agvnav.cli.scenarios import scenarios
from agvnav.cli.simulate import simulate

#: name -> (module, function, one-line help): commands loaded only when they run.
LAZY_COMMANDS: dict[str, tuple[str, str, str]] = {
    "demo": ("agvnav.cli.demo", "demo", "Triangulate a vehicle on a built-in reflector layout and print a table."),
    "layout": (
        "agvnav.cli.layout", "layout",
        "Plan a reflector layout for the routes of a hall: map YAML, heat map PNG and a table against a baseline.",
    ),
    "localize": (
        "agvnav.cli.localize", "localize",
        "Run a positioning method on a recorded log; write the estimate (CSV and MCAP), its figures and plots.",
    ),
    "map": (
        "agvnav.cli.mapping", "map_command",
        "Map the reflectors from a recorded drive (SLAM); write a map YAML with per-reflector covariance.",
    ),
    "vehicle": (
        "agvnav.cli.vehicle", "vehicle",
        "Run a scenario's vehicle as a VDA 5050 vehicle on an MQTT broker until SIGINT/SIGTERM.",
    ),
    "fleet": (
        "agvnav.cli.fleet", "fleet",
        "Dispatch pick-and-drop jobs over VDA 5050 to SPEC's vehicles (any vendor's), traffic-controlled on request.",
    ),
    "report": (
        "agvnav.cli.report", "report",
        "Write one self-contained HTML report (plots, metrics, a time slider) of a run folder.",
    ),
}


class _LazyCommand(TyperCommand):
    """A command listed by name and help; its module is imported when it runs."""

    def __init__(self, name: str, module: str, function: str, short_help: str) -> None:
        super().__init__(name, short_help=short_help, help=short_help)
        self.target = (module, function)

    def load(self) -> Any:
        """The real click command (imports its module)."""
        module, function = self.target
        single = typer.Typer(add_completion=False, pretty_exceptions_enable=False)
        single.command(self.name)(getattr(importlib.import_module(module), function))
        return get_command(single)

    def make_context(self, info_name: str | None, args: list[str], parent: Any = None, **extra: Any) -> Any:
        return self.load().make_context(info_name, args, parent=parent, **extra)


class _Group(TyperGroup):
    """The root group: the eagerly registered commands plus :data:`LAZY_COMMANDS`."""

    def __init__(self, **attrs: Any) -> None:
        super().__init__(**attrs)
        for name, (module, function, short_help) in LAZY_COMMANDS.items():
            self.commands.setdefault(name, _LazyCommand(name, module, function, short_help))


app = typer.Typer(
    cls=_Group,
    help="agvnav: positioning and guidance of automated guided vehicles.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
app.add_typer(bench_app, name="bench")
app.add_typer(routes_app, name="routes")
app.command("simulate")(simulate)
app.command("scenarios")(scenarios)
app.command("campaign")(campaign)


def _version(value: bool) -> None:
    if value:
        print(f"agvnav {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False, "--version", callback=_version, is_eager=True, help="Print the version and exit."
    ),
) -> None:
    """agvnav: positioning and guidance of automated guided vehicles."""


def main(argv: list[str] | None = None) -> None:
    """Console entry point: usage mistakes become one line on stderr and exit code 2.

    At the exit of the process the objects still alive are frozen (:func:`_skip_final_collection`).
    """
    if not _EXIT_HOOK:
        atexit.register(_skip_final_collection)
        _EXIT_HOOK.append(True)
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


_EXIT_HOOK: list[bool] = []  # whether _skip_final_collection is registered (once per process)


def _skip_final_collection() -> None:
    """At exit, move every object still alive out of the collector's reach (``gc.freeze``).

    Shutting the interpreter down runs full cyclic collections over everything a command
    loaded (NumPy, the simulator, the schema; about 200,000 objects after ``agvnav simulate``),
    which cost about 0.1-0.2 s of the command's wall time (issue 11) and free nothing that
    matters: the process ends and the system takes its memory back. The collections then
    skip the frozen objects. Every output file is closed by then (the commands write with
    ``with`` blocks and rename complete folders into place); standard streams are flushed as
    usual. Registered with :mod:`atexit` by :func:`main`, once per process.
    """
    gc.freeze()


class _UsageError(Protocol):
    """The shape of click's usage errors: a message and an exit code."""

    exit_code: int

    def format_message(self) -> str: ...


def _is_usage_error(exc: Exception) -> TypeGuard[_UsageError]:
    """True for click-style usage errors (typer vendors click from 0.2x on, so match by shape)."""
    return hasattr(exc, "format_message") and hasattr(exc, "exit_code")
