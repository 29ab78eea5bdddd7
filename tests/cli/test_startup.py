"""Start-up (issue 11): ``agvnav --help`` imports no numerical library; lazy commands keep their help."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from agvnav.cli import app
from agvnav.cli.app import LAZY_COMMANDS

HEAVY = ("numpy", "numba", "scipy", "matplotlib", "distributed")  # typer's rich help may load pydantic

_PROBE = """
import sys
from agvnav.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
print(" ".join(sorted({m.split(".")[0] for m in sys.modules})))
"""


@pytest.mark.parametrize("argv", [["--help"], ["bench", "--help"], ["--version"]])
def test_help_imports_no_numerical_library(argv: list[str]) -> None:
    res = subprocess.run([sys.executable, "-c", _PROBE, *argv], capture_output=True, text=True, check=True)
    loaded = set(res.stdout.split("\n")[-2].split())
    assert not loaded & set(HEAVY), sorted(loaded & set(HEAVY))


def test_import_agvnav_imports_no_numerical_library() -> None:
    code = "import sys, agvnav; print(' '.join(sorted({m.split('.')[0] for m in sys.modules})))"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert not set(res.stdout.split()) & set(HEAVY)


@pytest.mark.parametrize("name", sorted(LAZY_COMMANDS))
def test_lazy_command_help_is_its_docstring_first_line(name: str) -> None:
    module, function, short_help = LAZY_COMMANDS[name]
    doc = getattr(importlib.import_module(module), function).__doc__
    assert doc.strip().splitlines()[0] == short_help
    listed = CliRunner().invoke(app, ["--help"]).output
    assert name in listed


def test_lazy_command_runs_and_parses_its_own_options() -> None:
    runner = CliRunner()
    res = runner.invoke(app, ["demo", "--help"])
    assert res.exit_code == 0 and "--pulses-per-rev" in res.output
    res = runner.invoke(app, ["demo", "--pulses-per-rev", "4096"])
    assert res.exit_code == 0 and "least_squares" in res.output


_EXIT_PROBE = """
import atexit, gc, sys
atexit.register(lambda: print("frozen at exit:", gc.get_freeze_count() > 0))  # registered first: runs last
from agvnav.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    print("frozen before exit:", gc.get_freeze_count() > 0)
"""


def test_process_exit_skips_the_final_collection() -> None:
    """At the exit of the process the live objects are frozen: shutdown's full collections skip them (issue 11)."""
    res = subprocess.run([sys.executable, "-c", _EXIT_PROBE, "--version"], capture_output=True, text=True, check=True)
    assert "frozen before exit: False" in res.stdout
    assert "frozen at exit: True" in res.stdout
