"""docs/scenarios.md is generated from the schema and cannot drift; every key has a unit column and a meaning."""

from pathlib import Path

from agvnav.report.reference import reference_markdown
from agvnav.world.reference import VEHICLE_SPECS, schema_rows, unit_of
from agvnav.world.scenario import Scenario

DOC = Path(__file__).resolve().parents[2] / "docs" / "scenarios.md"


def test_docs_scenarios_md_is_the_generated_reference():
    assert DOC.read_text(encoding="utf-8") == reference_markdown(), (
        "docs/scenarios.md is stale: regenerate with `python -m agvnav.report.reference > docs/scenarios.md`"
    )


def test_every_key_of_every_vehicle_has_a_meaning():
    rows = schema_rows(Scenario) + [r for spec in VEHICLE_SPECS for r in schema_rows(spec, "vehicle.")]
    missing = [r.key for r in rows if not r.meaning.strip()]
    assert not missing, f"keys without a meaning: {missing}"
    keys = {r.key for r in rows}
    assert {"vehicle.track_m", "vehicle.trailer_length_m", "vehicle.half_width_m", "goniometer.mount",
            "path.segments[].yaw_offset_deg", "vehicle.terrain.truth"} <= keys


def test_units_follow_the_key_suffix():
    assert unit_of("speed_m_s") == "m/s"
    assert unit_of("max_accel_m_s2") == "m/s²"
    assert unit_of("poles_per_m") == "1/m" and unit_of("lookahead_m") == "m"
    assert unit_of("max_rate_deg_s") == "deg/s"
    assert unit_of("sweep_deg") == "deg"
    assert unit_of("rate_hz") == "Hz"
    assert unit_of("radius_m") == "m"
    assert unit_of("seed") == "-"
