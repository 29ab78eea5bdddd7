"""The one machine-readable and human-readable form every benchmark shares."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from typing import Any

from rich.console import Console
from rich.table import Table


def emit(benchmark: str, records: Sequence[dict[str, Any]], as_json: bool, title: str = "") -> None:
    """Print ``records`` as ``{"benchmark": NAME, "records": [...]}`` or as a rich table."""
    if as_json:
        print(json.dumps({"benchmark": benchmark, "records": list(records)}, default=_jsonable))
        return
    table = Table(title=title or benchmark)
    columns: list[str] = []
    for rec in records:
        columns += [k for k in rec if k not in columns]
    for col in columns:
        table.add_column(col, justify="left" if _is_text_column(records, col) else "right")
    for rec in records:
        table.add_row(*(_format(rec.get(col)) for col in columns))
    print_table(table)


def print_table(table: Table) -> None:
    """Print ``table`` at its natural width, never truncated ("…") or folded.

    The console is as wide as the terminal or as the table needs, whichever is larger, so
    ``agvnav ... | cat`` (no terminal: rich would assume 80 columns) shows every value whole.
    """
    console = Console(highlight=False)
    needed = Console(highlight=False, width=100_000).measure(table).maximum
    if needed > console.width:
        console = Console(highlight=False, width=needed)
    console.print(table)


def best_time(func: Callable[[], Any], repeat: int = 5, number: int = 1) -> float:
    """Best wall time (s) of ``number`` calls of ``func``, over ``repeat`` trials."""
    best = math.inf
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(number):
            func()
        best = min(best, (time.perf_counter() - start) / number)
    return best


def _is_text_column(records: Sequence[dict[str, Any]], col: str) -> bool:
    return any(isinstance(r.get(col), str) for r in records)


def _format(value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if value == 0.0 or not math.isfinite(value):
            return str(value)
        return f"{value:.4g}"
    return str(value)


def _jsonable(value: Any) -> Any:
    if hasattr(value, "item"):
        return value.item()
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
