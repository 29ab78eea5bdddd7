"""YAML loading that refuses duplicate mapping keys (scenario, map and path files).

PyYAML's ``safe_load`` keeps the last of two equal keys silently, so a scenario
that sets ``seed`` twice runs with a value the author may not have meant. The
:class:`UniqueKeyLoader` raises a :class:`yaml.constructor.ConstructorError`
naming the key, with the key's position as ``problem_mark``.

Speed (issue 11): PyYAML's pure-Python scanner and parser take about 4 ms for a
scenario and 4 ms for the lab map, each parsed twice per ``agvnav simulate`` (the
nodes, then the data) and once per campaign batch. When PyYAML has its libyaml
binding, documents are parsed by libyaml (about ten times faster) and constructed by
the same Python constructor and resolver, so the data and the composed nodes (with
their lines) are the same. Any YAML error from libyaml parses the text again in pure
Python, which raises exactly the error (message and line) it always did; the shipped
documents are checked to load the same both ways (``tests/world/test_yaml_strict.py``).
"""

from __future__ import annotations

from typing import Any

import yaml
from yaml.constructor import ConstructorError

__all__ = ["UniqueKeyLoader", "compose", "safe_load_unique", "yaml_error_line"]


class _UniqueKeys:
    """Constructor part shared by both loaders: a mapping with the same key twice is an error."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=True)  # type: ignore[attr-defined]
            try:
                dup = key in seen
            except TypeError:  # unhashable key: SafeConstructor reports it below
                continue
            if dup:
                raise ConstructorError(
                    None, None, f"duplicate key {key!r}", key_node.start_mark
                )
            seen.add(key)
        return super().construct_mapping(node, deep=deep)  # type: ignore[misc]


class UniqueKeyLoader(_UniqueKeys, yaml.SafeLoader):
    """SafeLoader that rejects a mapping with the same key twice (merge keys ``<<`` excepted)."""


#: libyaml's parser with the same constructor, or None when PyYAML was built without libyaml.
_FastLoader: type | None = (
    type("_UniqueKeyCLoader", (_UniqueKeys, yaml.CSafeLoader), {}) if hasattr(yaml, "CSafeLoader") else None
)
_FastSafeLoader: type | None = getattr(yaml, "CSafeLoader", None)


def safe_load_unique(text: str) -> Any:
    """``yaml.safe_load`` of ``text`` that raises ConstructorError on a duplicate mapping key."""
    if _FastLoader is not None:
        try:
            return yaml.load(text, Loader=_FastLoader)
        except yaml.YAMLError:
            pass  # the pure-Python loader below raises the error as it always did
    return yaml.load(text, Loader=UniqueKeyLoader)


def compose(text: str) -> Any:
    """``yaml.compose`` of ``text`` with the safe loader's resolver: the node tree with its marks (lines)."""
    if _FastSafeLoader is not None:
        try:
            return yaml.compose(text, Loader=_FastSafeLoader)
        except yaml.YAMLError:
            pass  # as in safe_load_unique: the error comes from the pure-Python parser
    return yaml.compose(text, Loader=yaml.SafeLoader)


def yaml_error_line(exc: yaml.YAMLError) -> int | None:
    """1-based line of a YAML error's problem mark, or None."""
    mark = getattr(exc, "problem_mark", None)
    return mark.line + 1 if mark is not None else None
