"""The one machine-readable and human-readable form every benchmark (and every CLI table) shares.

Machines get ``{"benchmark": NAME, "metadata": {...}, "records": [...]}`` (``--json``):
records keep their SI keys and values (``rms_position_m``), and :func:`run_metadata`
says which agvnav, seed, ``--quick``, Python, NumPy and CPU produced them.

People get a table in the units they read: a record key's unit suffix picks the
display unit of the whole column (:func:`display_unit`: ``_m`` -> mm or m, ``_s`` ->
ns, µs, ms or s, ``_rad`` -> deg), named in the header ("rms position (mm)").
A table fits the terminal (:func:`fit_table`): columns are dropped by priority
(least important first) until it does, a caption names what was hidden and that
``--wide`` shows everything, and another explains ``-`` wherever a cell holds one.
Output that is not a terminal (a pipe, a file) keeps every column, unless ``COLUMNS``
is set.

Kept light: ``agvnav --help`` imports this module, so it never imports NumPy
(:func:`run_metadata` reads NumPy's version from the package metadata).
"""

from __future__ import annotations

import math
import os
import platform
import time
from collections.abc import Callable, Sequence
from importlib import metadata
from typing import Any

from agvnav import __version__
from agvnav._display import (
    DASH_NOTE,
    Col,
    display_unit,
    fit_table,
    format_number,
    print_table,
    records_table,
    terminal_width,
)
from agvnav._json import json_text, plain_json
from agvnav.jit import mode as kernel_mode

__all__ = [
    "DASH_NOTE",
    "Col",
    "best_time",
    "display_unit",
    "emit",
    "fit_table",
    "format_number",
    "json_document",
    "json_text",
    "plain_json",
    "print_table",
    "records_table",
    "run_metadata",
    "terminal_width",
]


#: Progress callback a benchmark's ``run`` may accept as ``progress=``: (done, total) in its own units.
BenchProgress = Callable[[float, float], None]


def run_metadata(seed: int | None = None, quick: bool | None = None) -> dict[str, Any]:
    """What produced a record: agvnav version, seed, quick flag, the kernels' mode, Python, NumPy and the CPU.

    ``kernels`` is ``"compiled"`` or ``"interpreted"`` (:func:`agvnav.jit.mode`): seeded runs repeat
    themselves bit for bit within one mode, and agree to rounding across modes.

    ``cpu`` is the processor's model name where the OS tells it (Linux ``/proc/cpuinfo``,
    else :func:`platform.processor`), with the logical CPU count.
    """
    return {
        "agvnav": __version__,
        "seed": seed,
        "quick": quick,
        "kernels": kernel_mode(),
        "python": platform.python_version(),
        "numpy": _version_of("numpy"),
        "cpu": _cpu_name(),
        "cpu_count": os.cpu_count(),
        "machine": platform.machine(),
        "platform": platform.platform(),
    }


def _version_of(package: str) -> str | None:
    """Installed version of ``package`` (read from its metadata, without importing it)."""
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return None


def _cpu_name() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def json_document(kind: str, name: str, body: dict[str, Any], seed: int | None, quick: bool | None) -> str:
    """``{kind: name, "metadata": run_metadata(seed, quick), **body}`` as one JSON text."""
    doc = {kind: name, "metadata": run_metadata(seed, quick), **body}
    return json_text(doc)


def emit(
    benchmark: str,
    records: Sequence[dict[str, Any]],
    as_json: bool,
    title: str = "",
    *,
    seed: int | None = None,
    quick: bool | None = None,
    wide: bool = False,
    priority: Sequence[str] = (),
) -> None:
    """Print ``records`` as JSON (``{"benchmark", "metadata", "records"}``) or as a table fitting the terminal.

    ``priority`` names the columns to keep longest (most important first); see :func:`records_table`.
    """
    if as_json:
        print(json_document("benchmark", benchmark, {"records": list(records)}, seed, quick))
        return
    print_table(records_table(records, title or benchmark, priority), wide=wide)


def best_time(func: Callable[[], Any], repeat: int = 5, number: int = 1) -> float:
    """Best wall time (s) of ``number`` calls of ``func``, over ``repeat`` trials."""
    best = math.inf
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(number):
            func()
        best = min(best, (time.perf_counter() - start) / number)
    return best


