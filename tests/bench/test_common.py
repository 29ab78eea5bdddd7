"""The shared table and JSON form: display units, number format, column fitting, metadata."""

from __future__ import annotations

import contextlib
import io
import json
import math

from rich.console import Console

from agvnav.bench.common import (
    DASH_NOTE,
    Col,
    display_unit,
    emit,
    fit_table,
    format_number,
    records_table,
    run_metadata,
)

RECORDS = [
    {"method": "absolute_angles", "rms_position_m": 0.00322, "single_fix_s": 3.22e-6, "rms_heading_rad": 0.0011,
     "valid_fraction": 0.999, "samples": 10000, "note": None, "an_extra_long_figure_m": 12.5},
    {"method": "least_squares", "rms_position_m": 0.0021, "single_fix_s": 2.2e-5, "rms_heading_rad": 0.0009,
     "valid_fraction": 1.0, "samples": 10000, "note": "five reflectors", "an_extra_long_figure_m": 3.0},
]


def _render(table, width=300):
    console = Console(width=width, record=True, highlight=False)
    console.print(table)
    return console.export_text()


def test_display_units_pick_what_people_read():
    assert display_unit("rms_position_m", [0.00322, 0.0021]) == ("rms position (mm)", "mm", 1e3)
    assert display_unit("route_length_m", [0.5, 47.0]) == ("route length (m)", "m", 1.0)
    assert display_unit("single_fix_s", [3.22e-6, 2.2e-5]) == ("single fix (µs)", "µs", 1e6)
    assert display_unit("wall_time_s", [0.02, 0.5])[1:] == ("ms", 1e3)
    assert display_unit("wall_time_s", [2.0])[1:] == ("s", 1.0)
    header, unit, scale = display_unit("rms_heading_rad", [0.001])
    assert (header, unit) == ("rms heading (deg)", "deg") and math.isclose(scale, 180 / math.pi)
    assert display_unit("batch_ns_per_fix", [1500.0])[0] == "batch (ns/fix)"
    assert display_unit("curvature_jump_per_m", [0.5])[:2] == ("curvature jump (1/m)", "1/m")
    assert display_unit("valid_fraction", [1.0]) == ("valid fraction", "", 1.0)


def test_numbers_never_print_raw_si_or_long_exponents():
    assert format_number(0.00322, 1e3) == "3.220"
    assert format_number(2.5e6) == "2,500,000"
    assert format_number(10000) == "10000" and format_number(250_000) == "250,000"
    assert format_number(None) == "-" and format_number(float("nan")) == "-"
    assert format_number(True) == "yes" and format_number(0.0) == "0"
    assert format_number(1.23456e-5) == "1.23e-05"


def test_records_table_converts_columns_and_keeps_json_in_si():
    _title, cols, rows = records_table(RECORDS, "t")
    headers = [c.header for c in cols]
    assert "rms position (mm)" in headers and "single fix (µs)" in headers and "rms heading (deg)" in headers
    assert rows[0][headers.index("rms position (mm)")] == "3.220"
    assert rows[1][headers.index("single fix (µs)")] == "22.00"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        emit("t", RECORDS, as_json=True, seed=7, quick=True)
    doc = json.loads(buf.getvalue())
    assert doc["records"][0]["rms_position_m"] == 0.00322  # machines keep SI
    assert doc["metadata"]["seed"] == 7 and doc["metadata"]["quick"] is True


def test_metadata_names_version_seed_quick_python_numpy_and_cpu():
    import numpy as np

    import agvnav

    meta = run_metadata(seed=3, quick=False)
    assert meta["agvnav"] == agvnav.__version__ and meta["seed"] == 3 and meta["quick"] is False
    assert meta["numpy"] == np.__version__ and meta["python"].count(".") == 2
    assert isinstance(meta["cpu"], str) and meta["cpu"] and meta["cpu_count"] >= 1


def test_fitting_80_columns_drops_the_lowest_priority_columns_and_wide_keeps_all():
    title, cols, rows = records_table(RECORDS, "t", priority=("method", "rms_position_m"))
    narrow = _render(fit_table(title, cols, rows, width=80), width=80)
    assert max(len(line) for line in narrow.splitlines()) <= 80
    assert "method" in narrow and "3.220" in narrow  # the first priorities stay
    assert "an extra long figure" not in narrow.split("hidden")[0]  # the last column went first
    assert "hidden to fit 80 characters" in " ".join(narrow.split()) and "--wide" in narrow
    wide = _render(fit_table(title, cols, rows, width=80, wide=True))
    for c in cols:
        assert c.header in wide
    assert "hidden" not in wide


def test_a_dash_is_explained_where_it_appears():
    table = fit_table("t", [Col("a", "left", 0), Col("b")], [["x", "-"], ["y", "1"]], width=None)
    assert DASH_NOTE in " ".join(_render(table).split())
    table = fit_table("t", [Col("a", "left", 0), Col("b")], [["x", "2"], ["y", "1"]], width=None)
    assert DASH_NOTE not in " ".join(_render(table).split())


def test_values_are_never_folded_only_headers_wrap():
    cols = [Col("method", "left", 0), Col("a very long header (mm)", "right", 0)]
    table = fit_table("t", cols, [["absolute_angles", "123.456"]], width=30)
    text = _render(table, width=30)
    assert "absolute_angles" in text and "123.456" in text
