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
    doc = json.loads(res.output)  # the whole output is one document
    assert doc["benchmark"] == "routes check"
    assert all(r["g1"] for r in doc["records"]) and len(doc["records"]) == 30
    assert doc["not_g2"] == 0 and all(a["kind"] in ("clothoid", "nurbs") for a in doc["approximation"])


def test_routes_check_json_is_one_document_with_curved_edges() -> None:
    """A network with clothoid/NURBS edges printed two documents (joints, then approximation) with --json."""
    res = runner.invoke(app, ["routes", "check", "warehouse", "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    assert doc["network"] == "warehouse" and doc["edges"] >= len(doc["approximation"]) > 0
    assert all(a["approx_error_m"] >= 0.0 for a in doc["approximation"])
    assert doc["not_g2"] == sum(r["g2"] is False for r in doc["records"])


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
