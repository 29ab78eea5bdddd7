"""Campaign plots: one PNG per metric with a histogram and a panel per swept parameter."""

from pathlib import Path

import numpy as np

from agvnav.report.campaign import plot_campaign


def test_one_png_per_metric(tmp_path):
    rng = np.random.default_rng(0)
    n = 30
    columns = {
        "outcome": ["completed"] * (n - 2) + ["failed", "error"],
        "param.traction.speed_m_s": list(np.repeat([0.2, 0.3, 0.4], 10)),
        "param.controller.name": ["seed_simple", "stanley"] * (n // 2),
        "metric.positioning_rms_m": list(rng.normal(0.01, 0.002, n)),
        "metric.settling_distance_m": [None] * n,
    }
    paths = plot_campaign(columns, ["positioning_rms_m", "settling_distance_m", "absent"],
                          ["traction.speed_m_s", "controller.name"], tmp_path / "plots")
    assert [p.name for p in paths] == [
        "campaign_positioning_rms_m.png", "campaign_settling_distance_m.png", "campaign_absent.png"
    ]
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 1000


def test_the_plots_label_and_draw_metrics_in_the_display_units_of_the_table(tmp_path, monkeypatch):
    """mm for a lateral error below 1 m (values scaled), the unit named on every metric axis."""
    import matplotlib.figure

    seen = []

    def record(fig, path, **kwargs):
        axes = fig.get_axes()
        seen.append(([a.get_xlabel() for a in axes], [a.get_ylabel() for a in axes], axes[1].lines[0].get_ydata()))
        Path(path).write_bytes(b"\x89PNG\r\n\x1a\n")

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", record)
    columns = {"outcome": ["completed"] * 4, "param.traction.speed_m_s": [0.2, 0.2, 0.3, 0.3],
               "metric.max_abs_lateral_error_m": [0.010, 0.012, 0.011, 0.013]}
    plot_campaign(columns, ["max_abs_lateral_error_m"], ["traction.speed_m_s"], tmp_path, "c")
    (x0, x1), (_, y1), y = seen[0]
    assert x0 == "max abs lateral error (mm)" and y1 == "max abs lateral error (mm)" and x1 == "traction.speed_m_s"
    np.testing.assert_allclose(y, [10.0, 12.0, 11.0, 13.0])
    summary = {"groups": [{"metrics": {"max_abs_lateral_error_m": {
        "n": 4, "mean": 1.5, "std": 0.1, "median": 1.5, "q05": 1.4, "q95": 1.6, "ci95": [1.4, 1.6]}}}]}
    plot_campaign(columns, ["max_abs_lateral_error_m"], ["traction.speed_m_s"], tmp_path, "c", summary)
    assert seen[1][0][0] == "max abs lateral error (m)"  # the table's unit (m, from its statistics) wins
