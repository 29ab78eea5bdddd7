"""Duplicate YAML keys are refused in scenario and map files, naming the key and line; a directory is not a scenario."""

import pytest

from agvnav.world.map import load_map
from agvnav.world.scenario import ScenarioError, builtin_scenario, load_scenario, parse_scenario
from agvnav.world.yaml_strict import safe_load_unique


def test_loader_accepts_unique_keys_and_merges():
    assert safe_load_unique("a: 1\nb: {c: 2}\nbase: &b {x: 1}\nd:\n  <<: *b\n  y: 2\n") == {
        "a": 1, "b": {"c": 2}, "base": {"x": 1}, "d": {"x": 1, "y": 2}
    }


def test_duplicate_key_in_scenario_names_key_and_line():
    text = builtin_scenario("guidance_test").read_text().replace("seed: 0\n", "seed: 0\nseed: 3\n", 1)
    line = text.splitlines().index("seed: 3") + 1
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, "dup.yaml")
    assert info.value.line == line
    assert str(info.value) == f"dup.yaml:{line}: invalid YAML: duplicate key 'seed'"


def test_nested_duplicate_key_in_scenario():
    text = builtin_scenario("guidance_test").read_text().replace(
        "  speed_m_s: 0.2\n", "  speed_m_s: 0.2\n  speed_m_s: 0.5\n", 1
    )
    line = text.splitlines().index("  speed_m_s: 0.5") + 1
    with pytest.raises(ScenarioError, match="duplicate key 'speed_m_s'") as info:
        parse_scenario(text, "dup.yaml")
    assert info.value.line == line


def test_duplicate_key_in_map_file(tmp_path):
    p = tmp_path / "m.yaml"
    p.write_text("reflectors:\n  - {id: A, x: 1, y: 1, x: 2}\nwalls: []\n")
    with pytest.raises(ValueError) as info:
        load_map(p)
    msg = str(info.value)
    assert msg == f"{p}: line 2: not valid YAML: duplicate key 'x'"


def test_directory_as_scenario(tmp_path):
    with pytest.raises(ScenarioError) as info:
        load_scenario(tmp_path)
    assert str(info.value) == f"{tmp_path}: is a directory, not a scenario file"
