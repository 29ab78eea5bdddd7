"""Campaign plots: one PNG per metric with a histogram and a panel per swept parameter."""

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
