"""agvnav routes conflicts through the CLI runner: output, the files, refusal of foreign folders, exit codes."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from agvnav.cli.app import app

runner = CliRunner()


def test_conflicts_json_is_the_checked_document() -> None:
    res = runner.invoke(app, ["routes", "conflicts", "hall_loop", "--model", "tricycle", "--model", "differential",
                              "--json", "--check-step-mm", "100"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    assert doc["models"] == ["tricycle", "differential"] and doc["missed_conflicts"] == 0
    b2 = doc["conflicts"]["tricycle|differential"]["edge b2"]
    assert {"edge b2", "edge b2~r", "node S1", "node P"} <= set(b2)
    assert ["edge d1", "edge d1~r", "node D", "node D1"] in doc["zones"]


def test_conflicts_writes_a_folder_and_refuses_others(tmp_path: Path) -> None:
    out = tmp_path / "zones"
    args = ["routes", "conflicts", "hall_loop_arcs", "--model", "tricycle", "--out", str(out), "--check-step-mm", "100"]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert "zone 1:" in res.output and json.loads((out / "conflicts.json").read_text())["network"] == "hall_loop_arcs"
    assert (out / "conflicts.png").read_bytes()[:4] == b"\x89PNG"
    again = runner.invoke(app, args)
    assert again.exit_code == 2 and "use --force" in again.output
    assert runner.invoke(app, [*args, "--force"]).exit_code == 0
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep")
    res = runner.invoke(app, ["routes", "conflicts", "hall_loop", "--model", "tracked", "--out", str(foreign),
                              "--force"])
    assert res.exit_code == 2 and "not an agvnav conflict zones output" in res.output
    assert (foreign / "notes.txt").read_text() == "keep"


def test_conflicts_bad_input_is_one_line_exit_2() -> None:
    res = runner.invoke(app, ["routes", "conflicts", "hall_loop", "--model", "bus"])
    assert res.exit_code == 2 and "unknown vehicle model 'bus'" in res.output
    assert len(res.output.strip().splitlines()) == 1
    res = runner.invoke(app, ["routes", "conflicts", "no_such_network", "--model", "tricycle"])
    assert res.exit_code == 2 and len(res.output.strip().splitlines()) == 1
