"""``agvnav bench consistency``: the NEES band and its parts on filters whose answer is known."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from agvnav.bench.consistency import band, draw_calibration, nees_parts, scenario_text, summarise


def test_band_for_200_runs_is_the_issue_band() -> None:
    lo, hi = band(200, 3)
    assert (round(lo, 2), round(hi, 2)) == (2.67, 3.35)
    with pytest.raises(ValueError, match="n >= 1"):
        band(0, 3)


def test_band_covers_95_percent_of_means_of_independent_chi_square_samples() -> None:
    rng = np.random.default_rng(1)
    n, dof = 20, 3
    means = rng.chisquare(dof, size=(4000, n)).mean(axis=1)
    lo, hi = band(n, dof)
    assert 0.94 < np.mean((means > lo) & (means < hi)) < 0.96


def test_nees_parts_of_known_errors() -> None:
    P = np.array([[4.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.25]])
    e = np.array([[2.0, 1.0, 0.5], [np.nan, 0.0, 0.0]])
    parts = nees_parts(e, np.stack([P, P]))
    np.testing.assert_allclose(parts, [[3.0, 2.0, 1.0]])  # the NaN sample is dropped


def _kalman_runs(n_runs: int, r_filter_factor: float, seed: int) -> list[dict]:
    """A 3-state random walk measured directly, filtered with the true Q and ``R * r_filter_factor``."""
    rng = np.random.default_rng(seed)
    q, r, steps = np.array([1e-4, 1e-4, 1e-6]), np.array([1e-2, 1e-2, 1e-4]), 300
    runs = []
    for _ in range(n_runs):
        x = np.zeros(3)
        xh, p = rng.normal(0.0, np.sqrt(r)), r.copy()
        x_err, covs = [], []
        for _ in range(steps):
            x = x + rng.normal(0.0, np.sqrt(q))
            z = x + rng.normal(0.0, np.sqrt(r))
            p = p + q
            k = p / (p + r * r_filter_factor)
            xh = xh + k * (z - xh)
            p = (1.0 - k) * p
            x_err.append(xh - x)
            covs.append(np.diag(p))
        parts = nees_parts(np.array(x_err), np.array(covs))
        m = parts.mean(axis=0)
        runs.append({"nees": m[0], "position": m[1], "heading": m[2], "above": int(np.sum(parts[:, 0] > 7.815)),
                     "samples": parts.shape[0], "cpu_s": 0.0, "outcome": "completed"})
    return runs


def test_a_consistent_filter_falls_inside_and_an_overconfident_one_outside() -> None:
    good = summarise("kalman", _kalman_runs(40, 1.0, seed=2))
    lo, hi = (float(v) for v in good["nees_band"].split("-"))
    assert good["inside"] and lo < good["nees_mean"] < hi
    assert abs(good["position_mean"] - 2.0) < 0.4 and abs(good["heading_mean"] - 1.0) < 0.25
    assert 0.03 < good["above_chi2_95"] < 0.07
    ci_lo, ci_hi = (float(v) for v in good["nees_ci95"].split("-"))
    assert ci_lo < 3.0 < ci_hi
    bad = summarise("kalman", _kalman_runs(40, 0.25, seed=2))  # R understated 4x: overconfident
    assert not bad["inside"] and bad["nees_mean"] > hi
    assert bad["above_chi2_95"] > 0.1


def test_calibration_draw_is_seeded_and_follows_the_stated_tolerance() -> None:
    assert draw_calibration(7, 0.003, 0.2) == draw_calibration(7, 0.003, 0.2)
    assert draw_calibration(7, 0.003, 0.2) != draw_calibration(8, 0.003, 0.2)
    assert draw_calibration(7, 0.0, 0.0) == (0.0, 0.0)
    draws = np.array([draw_calibration(k, 0.003, 0.2) for k in range(4000)])
    np.testing.assert_allclose(draws.std(axis=0), [0.003, 0.2], rtol=0.05)
    assert abs(draws[:, 0].mean()) < 0.0003 and abs(draws[:, 1].mean()) < 0.02
    assert abs(np.corrcoef(draws.T)[0, 1]) < 0.05
    with pytest.raises(ValueError, match="wheel_radius_std"):
        draw_calibration(0, -0.1, 0.2)


def test_scenario_text_draws_the_truth_of_a_wheel_odometry_scenario() -> None:
    drawn = yaml.safe_load(scenario_text("tricycle_rear_loop", 5))
    eps, beta = draw_calibration(5, 0.003, 0.2)
    assert drawn["vehicle"]["truth"]["wheel_radius_error"] == eps
    assert drawn["vehicle"]["truth"]["steering_offset_deg"] == beta
    shipped = yaml.safe_load(scenario_text("tricycle_rear_loop", 5, shipped_truth=True))
    assert shipped["vehicle"]["truth"]["wheel_radius_error"] == 0.003
    assert shipped["vehicle"]["truth"]["steering_offset_deg"] == 0.2
    plain = yaml.safe_load(scenario_text("differential_loop", 5))  # no wheel_odometry: truth as shipped
    assert plain == yaml.safe_load(scenario_text("differential_loop", 5, shipped_truth=True))
