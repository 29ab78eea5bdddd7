"""agvnav routes check / plan and bench missions through the CLI runner: output and exit codes."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from agvnav.cli.app import app

runner = CliRunner()


def test_routes_check_reports_every_joint() -> None:
    res = runner.invoke(app, ["routes", "check", "hall_loop", "--json"])
    assert res.exit_code == 0, res.output
    first = json.loads(res.output.splitlines()[0])
    assert first["benchmark"] == "routes check"
    assert all(r["g1"] for r in first["records"]) and len(first["records"]) == 30


def test_routes_plan_and_bad_input_exit_2(tmp_path: Path) -> None:
    png = tmp_path / "route.png"
    res = runner.invoke(app, ["routes", "plan", "hall_loop", "--from", "S1", "--to", "D", "--reverse-into",
                              "--plot", str(png)])
    assert res.exit_code == 0, res.output
    assert "d2  D1 -> D  line     reverse" in res.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    res = runner.invoke(app, ["routes", "plan", "hall_loop", "--from", "S1", "--to", "ZZ"])
    assert res.exit_code == 2 and "unknown station 'ZZ'" in res.output
    bad = tmp_path / "bad.yaml"
    bad.write_text("nodes:\n  - {id: A, x: 0, y: 0}\n  - {id: B, x: 1, y: 0}\nedges:\n  - {id: e, from: A, to: C}\n")
    res = runner.invoke(app, ["routes", "check", str(bad)])
    assert res.exit_code == 2
    assert "bad.yaml:5: edges[0].to: unknown node 'C'" in " ".join(res.output.split())
