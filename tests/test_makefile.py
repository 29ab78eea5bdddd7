"""``make run`` works when run twice (the README's promise; issue 29): its recipe replaces its own sim_out."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from typer.testing import CliRunner

from agvnav.cli import app

MAKEFILE = Path(__file__).resolve().parents[1] / "Makefile"
runner = CliRunner()


def _run_recipe() -> list[str]:
    """The arguments the Makefile's ``run`` target gives ``agvnav``."""
    m = re.search(r"^run:.*\n\t\$\(BIN\)/agvnav (.+)$", MAKEFILE.read_text(encoding="utf-8"), re.MULTILINE)
    assert m, "the Makefile's run target runs $(BIN)/agvnav"
    return shlex.split(m.group(1))


def test_make_run_twice_replaces_its_previous_run_and_never_a_users_folder(tmp_path: Path,
                                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """Before: the second `make run` found sim_out holding a run and exited 2. Now the recipe passes --force: the
    previous run is replaced whole; a sim_out that is not an agvnav run is still refused (exit 2, untouched)."""
    args = _run_recipe()
    assert args[0] == "simulate"
    monkeypatch.chdir(tmp_path)
    fast = [*args, "--no-plots"]  # the folder rule does not depend on the plots
    for _ in range(2):
        res = runner.invoke(app, fast)
        assert res.exit_code == 0, res.output
        assert (tmp_path / "sim_out" / "metrics.json").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sim_out"]  # nothing left aside
    other = tmp_path / "elsewhere"
    other.mkdir()
    (other / "notes.txt").write_text("mine", encoding="utf-8")
    monkeypatch.chdir(other)
    (other / "sim_out").mkdir()
    (other / "sim_out" / "notes.txt").write_text("mine", encoding="utf-8")
    res = runner.invoke(app, fast)
    assert res.exit_code == 2 and "not an agvnav run" in res.output
    assert [p.name for p in (other / "sim_out").iterdir()] == ["notes.txt"]
