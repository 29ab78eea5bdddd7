"""libyaml parses, the pure-Python loader reports errors: the same data, nodes and messages either way (issue 11)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Any

import pytest
import yaml

from agvnav.world import yaml_strict
from agvnav.world.scenario import ScenarioError, parse_scenario
from agvnav.world.yaml_strict import UniqueKeyLoader, compose, safe_load_unique

SHIPPED = sorted(Path(str(resources.files("agvnav") / "data")).rglob("*.yaml"))

pytestmark = pytest.mark.skipif(not hasattr(yaml, "CSafeLoader"), reason="PyYAML without libyaml")


def _tree(node: Any) -> Any:
    """A node tree as plain tuples: tag, line and column of its start, value (scalars) or children."""
    if node is None:
        return None
    mark = (node.start_mark.line, node.start_mark.column)
    if isinstance(node, yaml.MappingNode):
        return node.tag, mark, [(_tree(k), _tree(v)) for k, v in node.value]
    if isinstance(node, yaml.SequenceNode):
        return node.tag, mark, [_tree(v) for v in node.value]
    return node.tag, mark, node.value  # not the style: libyaml says "" where PyYAML says None (plain)


def test_there_are_shipped_documents() -> None:
    assert len(SHIPPED) >= 20


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_shipped_documents_load_the_same_with_libyaml(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    python_data = yaml.load(text, Loader=UniqueKeyLoader)
    fast = safe_load_unique(text)
    assert fast == python_data
    assert repr(fast) == repr(python_data)  # same types too (1 against 1.0, dates, None)
    assert _tree(compose(text)) == _tree(yaml.compose(text, Loader=yaml.SafeLoader))


@pytest.mark.parametrize(
    "text",
    [
        "a: 1\na: 2\n",  # duplicate key
        "a: [1, 2\nb: 3\n",  # unclosed flow sequence
        "a: b: c\n",  # mapping value where none may be
        "a:\n  - 1\n - 2\n",  # bad indentation
        "x: \x07\n",  # a control character
    ],
)
def test_errors_are_those_of_the_pure_python_loader(text: str) -> None:
    with pytest.raises(yaml.YAMLError) as python:
        yaml.compose(text, Loader=yaml.SafeLoader)
        yaml.load(text, Loader=UniqueKeyLoader)
    with pytest.raises(yaml.YAMLError) as fast:
        compose(text)
        safe_load_unique(text)
    assert type(fast.value) is type(python.value)
    assert str(fast.value) == str(python.value)


def test_scenario_error_lines_unchanged_without_libyaml(monkeypatch: pytest.MonkeyPatch) -> None:
    text = "name: x\nseed: 1\nseed: 2\n"
    with pytest.raises(ScenarioError) as fast:
        parse_scenario(text, "s.yaml")
    monkeypatch.setattr(yaml_strict, "_FastLoader", None)
    monkeypatch.setattr(yaml_strict, "_FastSafeLoader", None)
    with pytest.raises(ScenarioError) as python:
        parse_scenario(text, "s.yaml")
    assert str(fast.value) == str(python.value) == "s.yaml:3: invalid YAML: duplicate key 'seed'"
