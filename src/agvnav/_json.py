"""Strict JSON, the one form of every JSON document agvnav writes (files and ``--json`` on stdout).

A root helper like :mod:`agvnav._validate`: every package may use it (docs/ARCHITECTURE.md, layer 0).
"""

from __future__ import annotations

import json
import math
from typing import Any

__all__ = ["json_text", "plain_json"]


def plain_json(value: Any) -> Any:
    """``value`` as strict JSON values: NumPy scalars and arrays as Python numbers and lists, NaN and
    infinities as None, tuples as lists, mapping keys as text; containers walked.

    Strict parsers (JavaScript's ``JSON.parse``, ``jq``, Python's ``json.loads`` with
    ``parse_constant`` raising) refuse the ``NaN``/``Infinity`` literals :func:`json.dumps` writes
    by default; a figure that was not measured is ``null`` instead.
    """
    if isinstance(value, dict):
        return {str(k): plain_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [plain_json(v) for v in value]
    if hasattr(value, "tolist"):  # NumPy scalars and arrays (without importing NumPy)
        value = value.tolist()
        if isinstance(value, list):
            return plain_json(value)
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_text(document: Any, indent: int | None = None) -> str:
    """``document`` as strict JSON text (:func:`plain_json`: no NaN or Infinity literals, ever).

    Every JSON agvnav writes goes through here: files (metrics.json, summary.json, ...) and
    ``--json`` on stdout. ``indent`` as for :func:`json.dumps`.
    """
    return json.dumps(plain_json(document), indent=indent, allow_nan=False, default=_jsonable)


def _jsonable(value: Any) -> Any:
    if hasattr(value, "item"):
        return value.item()
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
