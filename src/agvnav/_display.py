"""Tables and display units for people: the one form of every CLI table (re-exported by :mod:`agvnav.bench.common`).

A record key's unit suffix picks the display unit of the whole column (:func:`display_unit`:
``_m`` -> mm or m, ``_s`` -> ns, µs, ms or s, ``_rad`` -> deg), named in the header. A table fits
the terminal (:func:`fit_table`): columns are dropped by priority until it does, and a caption
names what was hidden. A root helper like :mod:`agvnav._validate` (docs/ARCHITECTURE.md, layer 0):
``report`` and ``bench`` both use it. Kept light: it never imports NumPy.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

from rich.console import Console, Group
from rich.table import Table
from rich.text import Text

__all__ = [
    "DASH_NOTE",
    "Col",
    "display_unit",
    "fit_table",
    "format_number",
    "print_table",
    "records_table",
    "terminal_width",
]

#: The footnote of a table that holds a ``-`` cell.
DASH_NOTE = "-: no value (not applicable to this row, or not measured)"


# --------------------------------------------------------------------------- units


@dataclass(frozen=True)
class _Unit:
    suffix: str
    label: str  # the unit in the header
    scale: float  # display value = SI value * scale


#: Fixed display units by key suffix (longest suffixes first; the adaptive ``_m`` and ``_s`` below).
_FIXED: tuple[tuple[str, str, float], ...] = (
    ("_m_s", "m/s", 1.0),
    ("_rad_s", "deg/s", 180.0 / math.pi),
    ("_mrad", "mrad", 1.0),
    ("_rad", "deg", 180.0 / math.pi),
    ("_deg", "deg", 1.0),
    ("_mm", "mm", 1.0),
    ("_cm", "cm", 1.0),
    ("_ms", "ms", 1.0),
    ("_us", "µs", 1.0),
    ("_ns", "ns", 1.0),
    ("_pct", "%", 1.0),
    ("_percent", "%", 1.0),
    ("_hz", "Hz", 1.0),
    ("_mb", "MB", 1.0),
    ("_mib", "MiB", 1.0),
)
_RATES = ("_per_s", "_per_m", "_per_lap", "_per_run")


def display_unit(key: str, values: Sequence[Any] = ()) -> tuple[str, str, float]:
    """``(header, unit, scale)`` to show the SI record column ``key`` holding ``values``.

    Lengths ``*_m`` show in mm when every value is below 1 m, else in m; durations ``*_s``
    in ns, µs, ms or s by the largest value; angles ``*_rad`` in degrees; keys already in a
    display unit (``_mm``, ``_deg``, ``_us``, ...) keep it. A key without a unit suffix
    gets ``unit == ""`` and scale 1. The header is the key without its suffix, words
    spaced, the unit in brackets: ``rms_position_m`` -> ``rms position (mm)``.
    """
    for unit, label in (("_ns_per_", "ns"), ("_us_per_", "µs"), ("_ms_per_", "ms"), ("_s_per_", "s")):
        head, sep, per = key.partition(unit)
        if sep and per and "_" not in per:
            return f"{_words(head)} ({label}/{per})", f"{label}/{per}", 1.0
    for rate in _RATES:
        if key.endswith(rate):
            return f"{_words(key[: -len(rate)])} (1/{rate[5:]})", f"1/{rate[5:]}", 1.0
    numbers = [abs(float(v)) for v in values if _is_number(v) and math.isfinite(float(v))]
    top = max(numbers, default=0.0)
    for suffix, label, scale in _FIXED:
        if key.endswith(suffix):
            return _header(key, suffix, label), label, scale
    if key.endswith("_m"):
        label, scale = ("mm", 1e3) if top < 1.0 else ("m", 1.0)
        return _header(key, "_m", label), label, scale
    if key.endswith("_s"):
        label, scale = _time_unit(top)
        return _header(key, "_s", label), label, scale
    return _words(key), "", 1.0


def _time_unit(top: float) -> tuple[str, float]:
    if top == 0.0 or top >= 1.0:
        return "s", 1.0
    if top >= 1e-3:
        return "ms", 1e3
    if top >= 1e-6:
        return "µs", 1e6
    return "ns", 1e9


def _header(key: str, suffix: str, label: str) -> str:
    return f"{_words(key[: -len(suffix)])} ({label})"


def _words(key: str) -> str:
    return key.replace("_", " ").strip() or key


def _is_number(value: Any) -> bool:
    return (isinstance(value, int | float) and not isinstance(value, bool)) or hasattr(value, "dtype")


def format_number(value: Any, scale: float = 1.0) -> str:
    """A table cell: about 4 significant figures, no exponent between 0.001 and 10^5, ``-`` for none.

    Integers print whole; booleans as yes/no; NaN and None as ``-``; from 10^5 up with
    thousands separators (``2,500,000``).
    """
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, int) and scale == 1.0:
        return f"{value:,}" if abs(value) >= 100_000 else str(value)
    if not isinstance(value, int | float):
        return str(value)
    v = float(value) * scale
    if math.isnan(v):
        return "-"
    if math.isinf(v) or v == 0.0:
        return "0" if v == 0.0 else ("inf" if v > 0 else "-inf")
    a = abs(v)
    if a >= 1e5:
        return f"{v:,.0f}"
    if a < 1e-3:
        return f"{v:.2e}"
    decimals = max(0, 3 - math.floor(math.log10(a)))
    return f"{v:.{decimals}f}"


# --------------------------------------------------------------------------- tables


@dataclass(frozen=True)
class Col:
    """One table column: header, justification and priority (0 is kept longest; higher drops first)."""

    header: str
    justify: Literal["left", "right", "center"] = "right"
    priority: int = 1
    no_wrap: bool = False
    wrap: bool = False
    """the values are prose that may wrap at spaces (else a value is never broken)."""


def records_table(records: Sequence[dict[str, Any]], title: str, priority: Sequence[str] = ()) -> tuple[
    str, list[Col], list[list[str]]
]:
    """``(title, columns, rows)`` of flat records, each numeric column in its display unit.

    Column priority: the keys in ``priority`` first (in that order), then the leading text
    columns (the row labels), then the rest in record order; the last ones drop first.
    """
    keys: list[str] = []
    for rec in records:
        keys += [k for k in rec if k not in keys]
    text = [k for k in keys if any(isinstance(r.get(k), str) for r in records)]
    labels = []  # the leading text columns name the rows
    for k in keys:
        if k not in text:
            break
        labels.append(k)
    order = [k for k in priority if k in keys] + [k for k in labels if k not in priority]
    order += [k for k in keys if k not in order]
    rank = {k: i for i, k in enumerate(order)}
    cols: list[Col] = []
    scales: list[float] = []
    for k in keys:
        if k in text:
            cols.append(Col(_words(k), "left", rank[k]))
            scales.append(1.0)
            continue
        header, _, scale = display_unit(k, [r.get(k) for r in records])
        cols.append(Col(header, "right", rank[k]))
        scales.append(scale)
    rows = [[format_number(r.get(k), s) for k, s in zip(keys, scales, strict=True)] for r in records]
    return title, cols, rows


def terminal_width() -> int | None:
    """The width tables must fit: the terminal's, or ``COLUMNS``; None (no limit) for a pipe or file."""
    env = os.environ.get("COLUMNS", "")
    if env.isdigit() and int(env) > 0:
        return int(env)
    if sys.stdout.isatty():
        return Console().width
    return None


def fit_table(
    title: str,
    cols: Sequence[Col],
    rows: Sequence[Sequence[str]],
    width: int | None = None,
    wide: bool = False,
    caption: str = "",
    sections: Sequence[bool] = (),
) -> Table | Group:
    """A rich Table of ``rows`` that fits ``width`` columns: the highest-priority numbers drop first.

    ``wide`` (or ``width=None``) keeps every column. Hidden columns are named in the
    notes below the table with a hint to use ``--wide``; a ``-`` cell anywhere adds
    :data:`DASH_NOTE` (the table and its notes come as a rich ``Group``).
    ``sections[i]`` ends a section after row ``i``. Cells may hold rich markup.
    """
    keep = list(range(len(cols)))
    if width is not None and not wide:
        by_drop = sorted(keep, key=lambda i: (cols[i].priority, i), reverse=True)
        while len(keep) > 1 and _min_width(title, cols, rows, keep) > width:
            victim = next(i for i in by_drop if i in keep and cols[i].priority > 0)
            keep.remove(victim)
            if all(cols[i].priority == 0 for i in keep):
                break
    hidden = [cols[i].header for i in range(len(cols)) if i not in keep]
    notes = [caption] if caption else []
    if any(cell.strip() == "-" for row in rows for i, cell in enumerate(row) if i in keep):
        notes.append(DASH_NOTE)
    if hidden:
        notes.append(f"{len(hidden)} column(s) hidden to fit {width} characters: {', '.join(hidden)}; --wide shows all")
    table = _table(title, cols, rows, keep, "", sections, None if wide else width)
    if not notes:
        return table
    # the notes below the table, as wide as the terminal (a caption would wrap at the table's width)
    return Group(table, Text("\n".join(notes), no_wrap=False))


def _table(
    title: str, cols: Sequence[Col], rows: Sequence[Sequence[str]], keep: Sequence[int], caption: str,
    sections: Sequence[bool] = (), width: int | None = None,
) -> Table:
    """The table of the ``keep`` columns; with ``width``, explicit column widths that fit it."""
    t = Table(title=title, caption=caption or None, caption_justify="left")
    widths = _column_widths(cols, rows, keep, width)
    for k, i in enumerate(keep):
        t.add_column(
            cols[i].header, justify=cols[i].justify, no_wrap=cols[i].no_wrap, overflow="fold",
            width=widths[k] if widths else None,
        )
    for j, row in enumerate(rows):
        t.add_row(*(row[i] for i in keep), end_section=bool(sections[j]) if j < len(sections) else False)
    return t


def _bounds(cols: Sequence[Col], rows: Sequence[Sequence[str]], i: int) -> tuple[int, int]:
    """(narrowest, natural) content width of column ``i``: values never fold, headers wrap at spaces."""
    longest = max((_cell_width(r[i]) for r in rows), default=0)
    header_word = max((len(w) for w in cols[i].header.split()), default=0)
    narrowest = longest
    if cols[i].wrap:
        narrowest = min(longest, max(24, max((len(w) for r in rows for w in r[i].split()), default=0)))
    return max(narrowest, header_word, 1), max(longest, len(cols[i].header), 1)


def _column_widths(
    cols: Sequence[Col], rows: Sequence[Sequence[str]], keep: Sequence[int], width: int | None
) -> list[int]:
    """Content widths of the kept columns within ``width`` (borders and padding: 3 per column + 1)."""
    if width is None:
        return []
    bounds = [_bounds(cols, rows, i) for i in keep]
    room = width - (3 * len(keep) + 1)
    widths = [lo for lo, _ in bounds]
    spare = room - sum(widths)
    if spare <= 0:
        return widths
    wants = sorted(range(len(keep)), key=lambda k: bounds[k][1] - bounds[k][0])
    for n, k in enumerate(wants):
        give = min(bounds[k][1] - widths[k], spare // (len(wants) - n))
        widths[k] += give
        spare -= give
    return widths


def _min_width(title: str, cols: Sequence[Col], rows: Sequence[Sequence[str]], keep: Sequence[int]) -> int:
    """Narrowest width at which the kept columns show every value whole (headers may wrap)."""
    return sum(_bounds(cols, rows, i)[0] for i in keep) + 3 * len(keep) + 1


def _cell_width(cell: str) -> int:
    return max((Text.from_markup(line).cell_len for line in cell.split("\n")), default=0)


def print_table(
    table: Table | tuple[str, Sequence[Col], Sequence[Sequence[str]]], wide: bool = False, width: int | None = None,
    caption: str = "", sections: Sequence[bool] = (),
) -> None:
    """Print a table to stdout, fitting the terminal (:func:`terminal_width`) unless ``wide``.

    ``table`` is a ready rich Table (printed whole, never truncated "…") or
    ``(title, columns, rows)`` (:func:`records_table`), fitted with :func:`fit_table`.
    """
    limit = terminal_width() if width is None else width
    if isinstance(table, Table):  # a ready table: natural width, nothing truncated ("…") or folded
        need = Console(highlight=False, width=100_000).measure(table)
        Console(highlight=False, width=max(Console().width, need.maximum)).print(table)
        return
    title, cols, rows = table
    fitted = fit_table(title, cols, rows, limit, wide, caption, sections)
    main = fitted.renderables[0] if isinstance(fitted, Group) else fitted
    need = Console(highlight=False, width=100_000).measure(main)
    if limit is not None and not wide:
        width_used = max(limit, need.minimum)  # the kept columns wrap their headers, never their values
    else:  # wide, or a pipe: natural width
        width_used = max(Console().width if limit is None else limit, need.maximum)
    Console(highlight=False, width=width_used).print(fitted)
