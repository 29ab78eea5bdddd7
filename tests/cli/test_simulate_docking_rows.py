"""The summary table of a docking run shows the docking's own figures, equal to metrics.json's (issue 32)."""

from __future__ import annotations

import math
from types import SimpleNamespace

from agvnav.cli.simulate import _docking_rows


def test_docking_rows_state_the_recorded_figures_in_display_units() -> None:
    extra = {"dock_error_m": 0.00107, "dock_heading_error_rad": math.radians(0.041), "dock_time_s": 30.85,
             "docking_reported_finished": 1.0, "station_offset_measured_x_m": 0.0209,
             "station_offset_measured_y_m": -0.0002, "station_offset_true_m": 0.02}
    rows = {name: value for name, value, _ in _docking_rows(SimpleNamespace(extra=extra))}
    assert rows["docking error, true station (mm)"] == "1.07"
    assert rows["docking heading error (deg)"] == "0.041"
    assert rows["docking reported finished"] == "yes"
    assert rows["time to dock (s)"] == "30.9"
    assert rows["station offset measured / true (mm)"] == "20.9 / 20.0"


def test_no_docking_rows_without_a_docking() -> None:
    assert _docking_rows(SimpleNamespace(extra={"stops": 2.0})) == []
    assert _docking_rows(SimpleNamespace(extra=None)) == []
