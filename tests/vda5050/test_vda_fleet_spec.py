"""``agvnav fleet``'s spec: strict keys with file and line; bad starts refused; the master built from it."""

from __future__ import annotations

from pathlib import Path

import pytest

from agvnav.vda5050.master import job_master, load_fleet_spec
from agvnav.world.strict import ScenarioError

GOOD = ("scenario: mission_hall_differential\nversion: 3.0.0\nmanufacturer: acme\n"
        "vehicles:\n  - {serial: a, start: S1}\n")


def test_spec_builds_a_master(tmp_path: Path) -> None:
    p = tmp_path / "f.yaml"
    p.write_text(GOOD + "  - {serial: b, start: S3}\njobs: 3\n", encoding="utf-8")
    m = job_master(load_fleet_spec(p))
    assert {s: d.node for s, d in m.vehicles.items()} == {"a": "S1", "b": "S3"}
    assert "S1" not in m.stations and "S3" not in m.stations


@pytest.mark.parametrize(("extra", "words"), [
    ("colour: red\n", "colour"),
    ("  - {serial: a, start: S2}\n", "distinct"),
    ("jobs: 0\n", "jobs"),
])
def test_bad_spec_names_line_and_key(tmp_path: Path, extra: str, words: str) -> None:
    p = tmp_path / "f.yaml"
    p.write_text(GOOD + extra, encoding="utf-8")
    with pytest.raises(ScenarioError, match=words):
        load_fleet_spec(p)


def test_start_off_the_network_is_refused(tmp_path: Path) -> None:
    p = tmp_path / "f.yaml"
    p.write_text(GOOD.replace("S1", "NOPE"), encoding="utf-8")
    with pytest.raises(ValueError, match="NOPE"):
        job_master(load_fleet_spec(p))
