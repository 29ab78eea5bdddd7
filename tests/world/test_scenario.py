import pytest

from agvnav.world.scenario import (
    ScenarioError,
    builtin_scenario,
    builtin_scenario_names,
    default_scenario,
    load_scenario,
    parse_scenario,
)


def _text(name="guidance_test"):
    return builtin_scenario(name).read_text()


def _line_of(text, needle):
    return next(i + 1 for i, line in enumerate(text.splitlines()) if needle in line)


def test_shipped_scenarios_parse():
    assert {"guidance_test", "positioning_validation"} <= set(builtin_scenario_names())
    sc = default_scenario()
    assert sc.name == "guidance_test"
    assert sc.traction.speed_m_s == pytest.approx(0.2)
    assert sc.start.lateral_offset_m == pytest.approx(0.110)
    arc, line = sc.path.segments
    assert arc.type == "arc" and arc.radius_m == pytest.approx(1.24)
    assert line.type == "line" and line.length_m == pytest.approx(3.0)
    assert load_scenario("positioning_validation").positioning.method == "angle_propagation"


@pytest.mark.parametrize(
    ("old", "new", "key", "needle", "words"),
    [
        ("slip_std: 0.01", "slip_sdt: 0.01", "vehicle.truth.slip_sdt", "slip_sdt", "unknown key"),
        ("radius_m: 1.24", "radius_m: -1.24", "path.segments[0].radius_m", "radius_m: -1.24", "greater than 0"),
        ("type: line", "type: spline", "path.segments[1]", "type: spline", "type must be one of line, arc"),
        ("  rate_hz: 8.0", "  rate_hz: fast", "goniometer.rate_hz", "rate_hz: fast", "number"),
        ("map: lab", "map: 3", "map", "map: 3", "shipped map name"),
        ("model: tricycle", "model: hovercraft", "vehicle.model", "model: hovercraft", "differential, tractor_trailer"),
    ],
)
def test_errors_name_key_and_line(old, new, key, needle, words):
    text = _text().replace(old, new, 1)
    assert new in text
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, "g.yaml")
    msg = str(info.value)
    assert msg.startswith(f"g.yaml:{_line_of(text, needle)}: {key}: "), msg
    assert words in msg


def test_missing_required_key_points_at_parent():
    text = _text().replace("  start: [5.5, 2.0, 0.0]", "  # no start", 1)
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, "g.yaml")
    assert "path.start: required key is missing" in str(info.value)
    assert info.value.line == _line_of(text, "path:")


def test_invalid_yaml_and_non_mapping():
    with pytest.raises(ScenarioError, match=r"x.yaml:\d+: invalid YAML"):
        parse_scenario("name: a\nseed: 1\n  bad: [\nx: 2\n", "x.yaml")
    with pytest.raises(ScenarioError, match="mapping"):
        parse_scenario("- 1\n- 2\n", "x.yaml")
    with pytest.raises(ValueError, match="no such scenario"):
        load_scenario("/nonexistent/file.yaml")


def test_with_seed_keeps_line_map():
    sc = default_scenario().with_seed(42)
    assert sc.seed == 42
    assert sc.locate(("controller", "poles_per_m")) == _line_of(_text(), "poles_per_m")
    with pytest.raises(ValueError):
        sc.with_seed(-1)
