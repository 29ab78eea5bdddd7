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

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import yaml
from yaml.constructor import ConstructorError

__all__ = ["UniqueKeyLoader", "compose", "find_long_list", "safe_load_unique", "yaml_error_line"]


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



@dataclass
class _Frame:
    """An open mapping or sequence of the event stream: where it is, and where its next node goes."""

    is_seq: bool
    key: tuple[str | int, ...]
    """its key path (list indices as ints)."""
    pattern: tuple[str, ...]
    """the same with every list index as ``*``."""
    count: int = 0
    """sequence: the items so far."""
    at_key: bool = True
    """mapping: the next node is a key (else the value of ``name``)."""
    name: str = "?"
    """mapping: the current key."""


_NODE_EVENTS = (yaml.ScalarEvent, yaml.SequenceStartEvent, yaml.MappingStartEvent, yaml.AliasEvent)
_START_EVENTS = (yaml.SequenceStartEvent, yaml.MappingStartEvent)
_END_EVENTS = (yaml.SequenceEndEvent, yaml.MappingEndEvent)


def find_long_list(
    text: str, limits: Mapping[tuple[str, ...], int], default: int
) -> tuple[tuple[str | int, ...], int, int] | None:
    """The first list of YAML ``text`` with more items than its limit: ``(key path, 1-based line, limit)``.

    ``limits`` maps key patterns (``("path", "segments")``; ``"*"`` for any list index) to
    their largest item count; any other list may hold ``default`` items. Read from the
    event stream, which stops at the first item past the limit: no node tree or data is
    built, so a list of 200,000 items is found after reading its first ``limit + 1``. The
    line is that of the first item past the limit. None when every list is within its
    limit, and for text that is not valid YAML (the loader then reports the error).
    """
    loader = _FastSafeLoader if _FastSafeLoader is not None else yaml.SafeLoader
    stack: list[_Frame | None] = []  # None: a collection inside a mapping key (its lists are not counted)
    try:
        for ev in yaml.parse(text, Loader=loader):
            if isinstance(ev, _END_EVENTS):
                stack.pop()
                _node_done(stack)
            elif isinstance(ev, _NODE_EVENTS):
                top = stack[-1] if stack else None
                counted = not stack or top is not None
                key: tuple[str | int, ...] = ()
                pattern: tuple[str, ...] = ()
                if top is not None and top.is_seq:
                    limit = limits.get(top.pattern, default)
                    if top.count >= limit:
                        mark = ev.start_mark
                        return top.key, (mark.line + 1 if mark is not None else 0), limit
                    key, pattern = (*top.key, top.count), (*top.pattern, "*")
                    top.count += 1
                elif top is not None and top.at_key:
                    counted = False
                    top.name = str(ev.value) if isinstance(ev, yaml.ScalarEvent) else "?"
                elif top is not None:
                    key, pattern = (*top.key, top.name), (*top.pattern, top.name)
                if isinstance(ev, _START_EVENTS):
                    frame = _Frame(isinstance(ev, yaml.SequenceStartEvent), key, pattern)
                    stack.append(frame if counted else None)
                else:
                    _node_done(stack)
    except yaml.YAMLError:
        return None
    return None


def _node_done(stack: list[_Frame | None]) -> None:
    """A node just ended: in a mapping, a key is followed by its value and a value by the next key."""
    if stack and stack[-1] is not None and not stack[-1].is_seq:
        stack[-1].at_key = not stack[-1].at_key
