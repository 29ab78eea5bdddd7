"""bench layout: the pooled simulated/predicted ratio and its run-jackknife interval (known answers)."""

from __future__ import annotations

import math

from agvnav.bench.layout import TITLE, ratio_with_interval


def _row(route: str, seed: int, meas: float, pred: float | None, n: int = 100) -> dict[str, object]:
    return {"route": route, "seed": seed, "measured_rms_m": meas, "predicted_rms_m": pred, "samples": n}


def test_ratio_pools_mean_squares_over_samples() -> None:
    rows = [_row("a", 0, 2.0, 1.0, 100), _row("a", 0, 1.0, 1.0, 300)]  # one run, two sections
    ratio, ci = ratio_with_interval(rows)
    assert ratio is not None and math.isclose(ratio, math.sqrt((100 * 4 + 300 * 1) / 400))
    assert ci is None  # fewer than 3 runs


def test_identical_runs_have_a_point_interval_and_unpredicted_sections_are_skipped() -> None:
    rows = [_row(r, s, 0.8, 1.0) for r in ("a", "b") for s in (0, 1)] + [_row("a", 0, 5.0, None)]
    ratio, ci = ratio_with_interval(rows)
    assert ratio is not None and math.isclose(ratio, 0.8)
    assert ci is not None and math.isclose(ci[0], 0.8) and math.isclose(ci[1], 0.8)


def test_interval_widens_with_scatter_between_runs() -> None:
    rows = [_row("a", s, m, 1.0) for s, m in enumerate((0.5, 1.0, 1.5, 1.0))]
    ratio, ci = ratio_with_interval(rows)
    assert ratio is not None and ci is not None
    assert math.isclose(ratio, math.sqrt((0.25 + 1 + 2.25 + 1) / 4))
    assert ci[0] < ratio < ci[1] and ci[1] - ci[0] > 0.3
    assert "predicted vs simulated" in TITLE
