"""`agvnav bench landmarks`: record keys and the seed-004 ordering (quick mode)."""

import json

from typer.testing import CliRunner

from agvnav.bench import landmarks
from agvnav.cli import app


def test_quick_records_keys_and_ordering():
    records = landmarks.run(quick=True, seed=0)
    assert [(r["terrain"], r["landmarks"]) for r in records] == [
        ("concrete", True), ("concrete", False), ("artificial_grass", True), ("artificial_grass", False)]
    for r in records:
        assert {"terrain", "landmarks", "mean_error_per_lap_m", "max_error_per_lap_m", "laps"} <= set(r)
        assert r["laps"] == 2 and r["max_error_per_lap_m"] >= r["mean_error_per_lap_m"] > 0
    for with_lm, without in (records[0:2], records[2:4]):
        assert with_lm["mean_error_per_lap_m"] <= 0.10 < without["mean_error_per_lap_m"]
        assert without["final_from_start_m"] > without["first_lap_from_start_m"]


def test_cli_json(monkeypatch):
    monkeypatch.setattr(landmarks, "TERRAINS", {"concrete": "tracked_square_3p5_concrete"})
    res = CliRunner().invoke(app, ["bench", "landmarks", "--quick", "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.output)
    assert data["benchmark"] == "landmarks" and len(data["records"]) == 2
