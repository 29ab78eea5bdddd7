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


def test_a_docking_summary_leads_with_the_docking_and_labels_the_path_figures_as_the_maps() -> None:
    from agvnav.cli.simulate import ON_MAP_STATION, _summary

    extra = {"dock_error_m": 0.00107, "dock_heading_error_rad": math.radians(0.041), "dock_time_s": 30.85,
             "docking_reported_finished": 1.0, "station_offset_measured_x_m": 0.0209,
             "station_offset_measured_y_m": -0.0002, "station_offset_true_m": 0.02}
    m = SimpleNamespace(initial_lateral_error_m=0.0, max_abs_lateral_error_m=0.0205, rms_lateral_error_m=0.0106,
                        max_abs_heading_error_rad=math.radians(5.8), heading_reorientations=0,
                        max_abs_wheel_heading_error_rad=None, settling_distance_m=None, positioning_rms_m=0.0018,
                        positioning_lateral_mean_abs_m=0.0009, positioning_lateral_std_m=0.0003,
                        positioning_lateral_max_abs_m=0.0029, sim_time_s=31.35, wall_time_s=1.0,
                        real_time_factor=31.0)
    sc = SimpleNamespace(name="docking_charger_differential", seed=0, vehicle=SimpleNamespace(model="differential"))
    result = SimpleNamespace(metrics=m, scenario=sc, outcome="completed", reason=None, extra=extra, timeline={})
    names = [row[0] for row in _summary(result)[2]]
    assert names[:5] == [name for name, _, _ in _docking_rows(result)]  # the docking's figures lead
    lateral = [n for n in names if "lateral error" in n and not n.startswith("positioning")]
    assert len(lateral) == 3 and all(ON_MAP_STATION in n for n in lateral)
    assert f"max |heading error|{ON_MAP_STATION} (deg)" in names
    rows = {row[0]: row[1] for row in _summary(result)[2]}
    assert rows["docking error, true station (mm)"] == "1.07"  # the headline is the recorded figure
    assert rows[f"max |lateral error|{ON_MAP_STATION} (mm)"] == "20.5"
