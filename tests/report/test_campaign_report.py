"""The campaign summary table: display units per metric, and std and the 95 % CI kept on a narrow terminal."""

from rich.console import Console

from agvnav.bench.common import fit_table
from agvnav.report.campaign import metric_units, summary_sections, summary_table


def _stats(mean, spread):
    return {"n": 50, "mean": mean, "std": spread, "median": mean, "q05": mean - 2 * spread,
            "q95": mean + 2 * spread, "ci95": [mean - spread / 3, mean + spread / 3]}


def _summary():
    """default_seeds' shape: a 2 x 2 grid (long dotted keys) and eight metrics, as the shipped campaign."""
    metrics = {
        "max_abs_lateral_error_m": _stats(0.0109, 0.0004), "rms_lateral_error_m": _stats(0.0074, 0.0017),
        "max_abs_wheel_heading_error_rad": _stats(0.0179, 0.001), "settling_distance_m": _stats(1.585, 0.24),
        "positioning_rms_m": _stats(0.0055, 0.0054), "positioning_lateral_max_abs_m": _stats(0.0064, 0.0058),
        "path_completed": _stats(1.0, 0.0), "real_time_factor": _stats(15.3, 3.7),
    }
    groups = [{"params": {}, "outcomes": {"completed": 200, "failed": 0}, "metrics": metrics}]
    for speed in (0.2, 0.3):
        for p_miss in (0.05, 0.2):
            groups.append({"params": {"traction.speed_m_s": speed, "goniometer.p_miss": p_miss},
                           "outcomes": {"completed": 50, "failed": 0}, "metrics": metrics})
    return {"runs": 200, "metrics": list(metrics), "group_by": [], "groups": groups}


def _render(width):
    title, cols, rows = summary_table("default_seeds", _summary())
    console = Console(width=width, record=True, highlight=False)
    console.print(fit_table(title, cols, rows, width, sections=summary_sections(_summary())))
    return console.export_text()


def test_at_100_columns_the_table_keeps_std_and_the_95_percent_interval():
    text = _render(100)
    assert max(len(line) for line in text.splitlines()) <= 100
    header = next(line for line in text.splitlines() if "mean" in line)
    assert "std" in header and "95 % CI" in text, text
    assert "[10.77, 11.03]" in text  # the CI of the max lateral error, in mm
    hidden = next(line for line in text.splitlines() if "hidden" in line)
    assert "std" not in hidden and "CI" not in hidden


def test_every_metric_has_one_display_unit_the_plots_share():
    units = metric_units(_summary())
    assert units["max_abs_lateral_error_m"] == ("max abs lateral error (mm)", 1000.0)
    assert units["settling_distance_m"] == ("settling distance (m)", 1.0)
    assert units["max_abs_wheel_heading_error_rad"][0] == "max abs wheel heading error (deg)"
    _, _, rows = summary_table("x", _summary())
    assert rows[0][1] == "max abs lateral error (mm)" and rows[0][3] == "10.90"
