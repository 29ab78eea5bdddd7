"""``agvnav demo``: a readable table of true poses vs every method, degrees labelled."""

from __future__ import annotations

import math

import pytest
from typer.testing import CliRunner

from agvnav.cli import app
from agvnav.cli.demo import demo_poses, demo_rows
from agvnav.positioning import METHODS

runner = CliRunner()


def test_demo_prints_every_method_with_units():
    result = runner.invoke(app, ["demo"], env={"COLUMNS": "220"})
    assert result.exit_code == 0, result.output
    for text in (*METHODS, "(deg)", "(m)", "(mm)", "critical circle", "65535 pulses/rev"):
        assert text in result.output


def test_demo_errors_are_at_the_quantisation_level_off_the_critical_circle():
    rows = demo_rows()
    assert len(rows) == len(demo_poses()) * len(METHODS)
    for row in rows:
        fix = row["fix"]
        if row["pose"] < 4:
            assert fix.valid and row["position_error_m"] < 5e-3 and abs(row["heading_error_rad"]) < 1e-3
            assert row["position_error_m"] < 4.0 * row["std_position_m"]


def test_demo_critical_pose_shows_each_method_behaviour():
    rows = {r["method"]: r for r in demo_rows(heading_error_deg=1.0) if r["pose"] == 4}
    assert not rows["relative_angles"]["fix"].valid and not rows["total"]["fix"].valid
    absolute = rows["absolute_angles"]
    assert absolute["fix"].heading_from_estimate
    assert math.degrees(absolute["heading_error_rad"]) == pytest.approx(1.0, abs=1e-9)
    assert rows["least_squares"]["fix"].valid and rows["least_squares"]["position_error_m"] < 5e-3


def test_demo_bad_option_is_a_one_line_error():
    result = runner.invoke(app, ["demo", "--pulses-per-rev", "0"])
    assert result.exit_code == 2
    assert "--pulses-per-rev" in result.output


def test_demo_help():
    result = runner.invoke(app, ["demo", "--help"])
    assert result.exit_code == 0 and "--pulses-per-rev" in result.output
