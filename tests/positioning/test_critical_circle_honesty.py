"""Triangulation near the critical circle (issue 12): a valid fix's covariance bounds its error.

Near the circle through the three reflectors the fix is no longer linear in the bearing
noise; before the ``NONLINEAR_RATIO`` flag 25-54 % of the valid fixes there fell outside
their own 95 % ellipse. Monte Carlo at known poses: the valid ones now fall outside about
5 % of the time, and far from the circle nothing is flagged.
"""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.positioning import triangulate
from agvnav.positioning.fix_covariance import NONLINEAR_RATIO

R = 5.0
REFLECTORS = np.c_[R * np.cos(np.radians([90, 210, 330])), R * np.sin(np.radians([90, 210, 330]))]
CHI2_2_95 = 5.991464547107979


def _monte_carlo(method: str, sigma: float, rel_offsets: list[float], n: int, seed: int) -> tuple[float, float, int]:
    """(share valid, share of the valid outside their own 95 % ellipse, valid count) over the poses."""
    rng = np.random.default_rng(seed)
    n_valid = n_out = n_all = 0
    for eps in rel_offsets:
        for a in (0.3, 1.2, 2.5):
            p = R * (1.0 - eps) * np.array([np.cos(a), np.sin(a)])
            theta = np.arctan2(REFLECTORS[:, 1] - p[1], REFLECTORS[:, 0] - p[0]) - 0.2
            fix = triangulate(REFLECTORS, theta + rng.normal(0.0, sigma, (n, 3)), method=method, bearing_std=sigma)
            assert fix.covariance is not None
            ok = fix.valid
            e = np.c_[fix.x[ok] - p[0], fix.y[ok] - p[1]]
            d2 = np.einsum("ij,ij->i", e, np.linalg.solve(fix.covariance[ok][:, :2, :2], e[..., None])[..., 0])
            n_all += n
            n_valid += int(ok.sum())
            n_out += int(np.count_nonzero(d2 > CHI2_2_95))
    return n_valid / n_all, n_out / max(n_valid, 1), n_valid


NEAR = [-0.1, -0.07, -0.05, 0.05, 0.07, 0.1]


@pytest.mark.parametrize("method", ["total", "relative_angles"])
def test_valid_fixes_near_the_circle_stay_inside_their_bound(method: str) -> None:
    share_valid, outside, n_valid = _monte_carlo(method, 1e-3, NEAR, 400, seed=5)
    assert n_valid > 1000  # the flag keeps a good part of the fixes
    assert share_valid < 0.8  # and drops the ones the linearisation cannot bound
    assert outside < 0.08  # about 5 %, as a 95 % bound should (binomial sd ~0.6 %)


def test_far_from_the_circle_nothing_is_flagged() -> None:
    share_valid, outside, _ = _monte_carlo("total", 1e-3, [0.3, -0.3], 500, seed=6)
    assert share_valid == 1.0 and 0.03 < outside < 0.07


def test_single_fix_follows_the_batch() -> None:
    rng = np.random.default_rng(7)
    b = np.concatenate([
        np.arctan2(REFLECTORS[:, 1] - p[1], REFLECTORS[:, 0] - p[0]) - 0.2 + rng.normal(0.0, 1e-3, (50, 3))
        for p in (R * f * np.array([np.cos(0.3), np.sin(0.3)]) for f in (0.93, 0.94, 0.945, 0.95))
    ])
    batch = triangulate(REFLECTORS, b, method="total", bearing_std=1e-3)
    for k in range(0, 200, 7):
        one = triangulate(REFLECTORS, b[k], method="total", bearing_std=1e-3)
        assert bool(one.valid) == bool(batch.valid[k])
        if one.valid:
            assert float(one.x) == pytest.approx(float(batch.x[k]), abs=1e-9)
        else:
            assert np.isnan(float(one.x)) and float(one.quality) == 0.0
    assert 0.0 < batch.valid.mean() < 1.0  # this pose sits in the band the flag judges


def test_without_bearing_std_no_covariance_no_flag() -> None:
    """The flag needs the covariance: a fix without ``bearing_std`` keeps today's validity."""
    p = R * 0.93 * np.array([np.cos(0.3), np.sin(0.3)])
    theta = np.arctan2(REFLECTORS[:, 1] - p[1], REFLECTORS[:, 0] - p[0]) - 0.2
    b = theta + np.random.default_rng(8).normal(0.0, 1e-3, (300, 3))
    assert triangulate(REFLECTORS, b, method="total").valid.mean() > triangulate(
        REFLECTORS, b, method="total", bearing_std=1e-3).valid.mean()
    assert 0.0 < NONLINEAR_RATIO < 1.0
