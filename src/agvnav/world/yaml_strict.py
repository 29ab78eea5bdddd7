"""YAML loading that refuses duplicate mapping keys (scenario, map and path files).

PyYAML's ``safe_load`` keeps the last of two equal keys silently, so a scenario
that sets ``seed`` twice runs with a value the author may not have meant. The
:class:`UniqueKeyLoader` raises a :class:`yaml.constructor.ConstructorError`
naming the key, with the key's position as ``problem_mark``.
"""

from __future__ import annotations

from typing import Any

import yaml
from yaml.constructor import ConstructorError

__all__ = ["UniqueKeyLoader", "safe_load_unique", "yaml_error_line"]


class UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that rejects a mapping with the same key twice (merge keys ``<<`` excepted)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=True)
            try:
                dup = key in seen
            except TypeError:  # unhashable key: SafeConstructor reports it below
                continue
            if dup:
                raise ConstructorError(
                    None, None, f"duplicate key {key!r}", key_node.start_mark
                )
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


def safe_load_unique(text: str) -> Any:
    """``yaml.safe_load`` of ``text`` that raises ConstructorError on a duplicate mapping key."""
    return yaml.load(text, Loader=UniqueKeyLoader)


def yaml_error_line(exc: yaml.YAMLError) -> int | None:
    """1-based line of a YAML error's problem mark, or None."""
    mark = getattr(exc, "problem_mark", None)
    return mark.line + 1 if mark is not None else None
