"""The official VDA 5050 JSON schemas (2.0.0, 2.1.0, 3.0.0) and the two checks every message passes.

The schemas are vendored unmodified in ``agvnav/data/vda5050/<version>/`` (MIT licence, its
``LICENSE.txt`` beside them; 3.0.0 is the repository's ``main`` at ``0b2ae43``, whose order,
visualization and factsheet schemas are valid JSON where the ``3.0.0`` tag's are not).

:func:`problems` applies both checks to one message:

* **schema**: JSON Schema draft 2020-12 validation (``jsonschema``);
* **no unknown key**: none of the schemas sets ``additionalProperties: false``, so a v3
  ``state`` that carries the v2 names (``agvPosition``, ``batteryState``) or a misspelt key
  validates. :func:`unknown_keys` walks the message beside its schema (following ``$ref``,
  ``items`` and ``allOf``/``anyOf``/``oneOf``/``if``/``then``/``else``) and names every key the
  schema does not define. A value whose schema defines no properties (an action parameter's
  ``value``) is free.

Two errata of the 2.0.0 release are handled here, said where they apply: its ``factsheet.json``
lists the fields at the top level instead of under ``properties`` (read as if they were), and its
``instantActions`` schema names the action's type ``actionName`` where the specification's text
and every later release say ``actionType``: a 2.0.0 instant action is checked with ``actionType``.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Iterator
from functools import cache
from importlib import resources
from typing import cast

from jsonschema import Draft202012Validator

__all__ = ["TOPICS", "VERSIONS", "JsonObject", "major", "problems", "schema", "unknown_keys"]

#: A parsed JSON object (the messages are plain JSON; values are checked by the schemas).
JsonObject = dict[str, object]

#: Protocol versions agvnav speaks.
VERSIONS = ("2.0.0", "2.1.0", "3.0.0")

#: Message topics with a schema in every version (3.0 adds ``responses`` and ``zoneSet``).
TOPICS = ("order", "instantActions", "state", "visualization", "connection", "factsheet")

#: Keys of a schema document that are not field definitions (the 2.0.0 factsheet's top level).
_SCHEMA_WORDS = frozenset({
    "$schema", "$id", "title", "description", "required", "subtopic", "type", "definitions", "$defs",
    "properties", "examples", "additionalProperties",
})


def major(version: str) -> str:
    """The topic level of ``version``: ``"v2"`` or ``"v3"``."""
    if version not in VERSIONS:
        raise ValueError(f"unknown VDA 5050 version {version!r}; valid: {', '.join(VERSIONS)}")
    return "v" + version.split(".")[0]


@cache
def schema(version: str, topic: str) -> JsonObject:
    """The official schema of ``topic`` in ``version`` (with the 2.0.0 errata applied, module doc)."""
    major(version)
    if topic not in TOPICS:
        raise ValueError(f"unknown VDA 5050 topic {topic!r}; valid: {', '.join(TOPICS)}")
    name = "factsheet.json" if (version, topic) == ("2.0.0", "factsheet") else f"{topic}.schema"
    text = resources.files("agvnav").joinpath("data", "vda5050", version, name).read_text(encoding="utf-8")
    doc = cast(JsonObject, json.loads(text))
    if (version, topic) == ("2.0.0", "factsheet") and "properties" not in doc:
        doc = {k: v for k, v in doc.items() if k in _SCHEMA_WORDS} | {
            "properties": {k: v for k, v in doc.items() if k not in _SCHEMA_WORDS}}
    if (version, topic) == ("2.0.0", "instantActions"):
        doc = _action_type_erratum(doc)
    return doc


def _action_type_erratum(doc: JsonObject) -> JsonObject:
    """The 2.0.0 instantActions schema with its ``actionName`` read as the text's ``actionType``."""
    out = copy.deepcopy(doc)
    item = cast(JsonObject, cast(JsonObject, cast(JsonObject, out["properties"])["actions"])["items"])
    props = cast(JsonObject, item["properties"])
    if "actionName" in props:
        props["actionType"] = props.pop("actionName")
        item["required"] = ["actionType" if r == "actionName" else r for r in cast(list[str], item["required"])]
    return out


@cache
def _validator(version: str, topic: str) -> Draft202012Validator:
    return Draft202012Validator(schema(version, topic))


def _resolve(node: JsonObject, root: JsonObject) -> JsonObject:
    while isinstance(node.get("$ref"), str):
        ref = cast(str, node["$ref"])
        if not ref.startswith("#/"):
            raise ValueError(f"external $ref {ref!r} is not supported")
        target: object = root
        for part in ref[2:].split("/"):
            target = cast(JsonObject, target)[part]
        node = cast(JsonObject, target)
    return node


def _branches(node: JsonObject, root: JsonObject) -> Iterator[JsonObject]:
    """``node`` and every sub-schema that may add properties to the same instance."""
    node = _resolve(node, root)
    yield node
    for word in ("allOf", "anyOf", "oneOf"):
        for sub in cast(list[JsonObject], node.get(word, [])):
            yield from _branches(sub, root)
    for word in ("if", "then", "else"):
        if isinstance(node.get(word), dict):
            yield from _branches(cast(JsonObject, node[word]), root)


def unknown_keys(message: object, version: str, topic: str) -> list[str]:
    """Dotted paths of the keys in ``message`` that the schema of ``topic`` in ``version`` does not define."""
    root = schema(version, topic)
    out: list[str] = []
    _walk(message, root, root, "", out)
    return out


def _walk(value: object, node: JsonObject, root: JsonObject, path: str, out: list[str]) -> None:
    branches = list(_branches(node, root))
    if isinstance(value, dict):
        props: dict[str, JsonObject] = {}
        for b in branches:
            props.update(cast(dict[str, JsonObject], b.get("properties", {})))
        if not props:
            return  # a free object (no properties defined)
        for key, sub in value.items():
            where = f"{path}.{key}" if path else str(key)
            if key not in props:
                out.append(where)
            else:
                _walk(sub, props[key], root, where, out)
    elif isinstance(value, list):
        for b in branches:
            if isinstance(b.get("items"), dict):
                for i, item in enumerate(value):
                    _walk(item, cast(JsonObject, b["items"]), root, f"{path}[{i}]", out)
                return


def problems(message: object, version: str, topic: str, strict: bool = True) -> list[str]:
    """Everything wrong with ``message`` as a ``topic`` message of ``version``: schema errors, then unknown keys.

    ``strict=False`` skips the unknown-key check (a vehicle reading a master's message tolerates
    extra keys; what it publishes is always checked strictly). Empty when the message conforms.
    """
    out = [
        f"{'/'.join(str(p) for p in e.absolute_path) or '<root>'}: {e.message}"
        for e in sorted(_validator(version, topic).iter_errors(message), key=lambda e: list(map(str, e.absolute_path)))
    ]
    if strict:
        out.extend(f"{k}: key not defined by the {version} {topic} schema"
                   for k in unknown_keys(message, version, topic))
    return out
