"""Review fixes: full-width tables when piped, derived invalid reason, options named in errors."""

from __future__ import annotations

import numpy as np
from typer.testing import CliRunner

from agvnav.cli.app import app
from agvnav.cli.demo import _status, demo_rows


def test_demo_piped_has_no_truncated_cells():
    result = CliRunner().invoke(app, ["demo"])
    assert result.exit_code == 0
    assert "…" not in result.output
    assert "least_squares" in result.output and "heading from estimate" in result.output


def test_bench_table_piped_has_no_truncated_cells(monkeypatch):
    import contextlib
    import io

    from agvnav.bench.common import emit
    monkeypatch.delenv("COLUMNS", raising=False)  # a pipe, not a terminal: every column, whole
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        emit("x", [{"a_very_long_column_name_" + str(i): 1.23456789e-5 * i for i in range(16)}], False, "t")
    assert "…" not in buf.getvalue() and "a very long column name 15" in buf.getvalue()


def test_heading_error_nan_names_the_option():
    result = CliRunner().invoke(app, ["demo", "--heading-error-deg", "nan"])
    assert result.exit_code == 2
    assert "--heading-error-deg" in result.output + (result.stderr if result.stderr_bytes is not None else "")


def test_invalid_status_reason_is_derived():
    rows = demo_rows()
    critical = [r for r in rows if not r["fix"].valid]
    assert critical and all("critical circle" in _status(r) for r in critical)
    row = dict(rows[0])  # an ordinary pose with an invalid fix is not blamed on the critical circle
    row["fix"] = type(rows[0]["fix"])(**{**rows[0]["fix"].__dict__, "valid": np.asarray(False)})
    assert "critical circle" not in _status(row)
