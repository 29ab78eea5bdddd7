"""The stated bound of the position error (issue 31's deviationRange): the covariance bound's miss
probability by Monte Carlo, the reach bound against brute-force trajectories, and the estimator's
trusted fix and doubt on an encoder dropout (odometry reads zero while the vehicle drives on)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _drive import arc_pose_at

from agvnav.positioning import make_estimator
from agvnav.positioning.deviation import (
    TrustedFix,
    covariance_radius,
    deviation_bound,
    radius_k,
    reach_radius,
)
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import WorldMap, load_builtin_map

MOUNT = np.array([0.3, 0.0, 0.0])


def test_radius_k_is_the_chi_square_2dof_quantile() -> None:
    assert radius_k(math.exp(-4.5**2 / 2.0)) == pytest.approx(4.5)
    assert radius_k(1e-3) == pytest.approx(3.7169, abs=1e-4)
    for bad in (0.0, 1.0, -0.1, math.nan):
        with pytest.raises(ValueError, match="probability"):
            radius_k(bad)


@pytest.mark.parametrize("P", [np.diag([4e-6, 4e-6]), np.array([[9e-6, 4e-6], [4e-6, 3e-6]])])
def test_covariance_radius_misses_at_most_the_stated_probability(P: np.ndarray) -> None:
    """Exactly ``p`` for an isotropic Gaussian (``|e|^2 / sigma^2`` is chi-square 2 dof), below it otherwise."""
    rng = np.random.default_rng(7)
    e = rng.multivariate_normal([0.0, 0.0], P, 400_000)
    p = 0.01
    r = covariance_radius(P, radius_k(p))
    rate = float(np.mean(np.hypot(e[:, 0], e[:, 1]) > r))
    if P[0, 1] == 0.0:
        assert rate == pytest.approx(p, rel=0.05)  # 4,000 expected misses: 1.6 % std
    else:
        assert rate < p
    assert r == pytest.approx(radius_k(p) * math.sqrt(np.linalg.eigvalsh(P)[-1]))
    assert math.isnan(covariance_radius(np.full((2, 2), math.nan), 4.5))
    with pytest.raises(ValueError, match="shape"):
        covariance_radius(np.eye(3), 4.5)


def test_reach_radius_adds_the_anchor_bound_the_estimate_motion_and_the_vehicle_reach() -> None:
    a = TrustedFix(10.0, 1.0, 2.0, 1e-4, 0.0, 1e-4)  # sigma 10 mm
    assert reach_radius(a, 4.5, 4.0, 6.0, 12.0, 0.5) == pytest.approx(0.045 + 5.0 + 1.0)
    assert reach_radius(a, 4.5, 1.0, 2.0, 9.0, 0.5) == pytest.approx(0.045)  # never shrinks below the anchor's
    with pytest.raises(ValueError, match="max_speed"):
        reach_radius(a, 4.5, 1.0, 2.0, 11.0, -1.0)


def test_reach_bound_holds_for_any_truth_within_the_vehicle_speed() -> None:
    """Brute force: random truth paths at speeds up to v_max, estimates anywhere; the bound is never beaten."""
    rng = np.random.default_rng(3)
    v_max, k = 0.5, 4.5
    for _ in range(2000):
        sigma = rng.uniform(1e-3, 2e-2)
        truth0 = rng.uniform(-5, 5, 2)
        x0 = truth0 + rng.normal(0.0, sigma, 2) * min(1.0, k / 3.0)  # within its bound (3 sigma per axis)
        a = TrustedFix(0.0, float(x0[0]), float(x0[1]), sigma**2, 0.0, sigma**2)
        t = rng.uniform(0.0, 5.0)
        steps = rng.normal(size=(50, 2))
        steps *= (v_max * t / 50) * rng.uniform(0, 1, (50, 1)) / np.linalg.norm(steps, axis=1, keepdims=True)
        truth = truth0 + steps.sum(axis=0)
        est = rng.uniform(-5, 5, 2)
        if np.hypot(*(x0 - truth0)) > k * sigma:
            continue
        b = deviation_bound(np.eye(2) * 1e-6, k, float(est[0]), float(est[1]), t, a, True, v_max)
        assert np.hypot(*(est - truth)) <= b + 1e-12


def test_deviation_bound_leaves_the_covariance_only_in_doubt() -> None:
    P = np.diag([1e-4, 1e-4])
    a = TrustedFix(0.0, 0.0, 0.0, 1e-6, 0.0, 1e-6)
    assert deviation_bound(P, 4.5, 3.0, 4.0, 2.0, a, False, 0.5) == pytest.approx(0.045)
    assert deviation_bound(P, 4.5, 3.0, 4.0, 2.0, a, True, 0.5) == pytest.approx(0.0045 + 5.0 + 1.0)
    assert deviation_bound(P * 1e6, 4.5, 0.0, 0.0, 0.0, a, True, 0.5) == pytest.approx(45.0)  # P wider: P's
    assert deviation_bound(P, 4.5, 3.0, 4.0, 2.0, None, True, 0.5) == math.inf


@pytest.fixture(scope="module")
def lab() -> WorldMap:
    return load_builtin_map("lab")


def test_an_encoder_dropout_puts_the_estimate_in_doubt_and_the_bound_holds(lab: WorldMap) -> None:
    """Standing 1 s, then driven at 0.5 m/s with odometry reading zero: the covariance alone misses
    (the estimate stays put with its small P), the stated bound from the last trusted fix never does."""
    start = np.array([4.0, 3.0, 0.3])
    v = 0.5

    def truth(t: np.ndarray) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        moved = arc_pose_at(start, v, 0.0)(np.maximum(t - 1.0, 0.0))
        return np.where((t >= 1.0)[:, None], moved, start)

    est = make_estimator("ekf", lab, MOUNT, initial_pose=start, initial_covariance=np.diag([1e-3, 1e-3, 1e-4]) ** 2)
    refl = Goniometer(mount=tuple(MOUNT)).scan(lab, truth, 0.0, 1.6)
    anchor_before = None
    covariance_missed = False
    for t, z in zip(refl.t, refl.bearing, strict=True):
        est.predict(float(t), 0.0, 0.0)  # the encoders read nothing
        est.update(float(t), float(z))
        if est.status in ("lost", "initialising"):
            break
        err = float(np.hypot(*(est.pose[:2] - truth(t)[0, :2])))
        P = est.covariance[:2, :2]
        covariance_missed |= err > covariance_radius(P, 4.5)
        if t < 1.0:
            anchor_before = est.anchor
            assert not est.in_doubt
        bound = deviation_bound(P, 4.5, float(est.pose[0]), float(est.pose[1]), float(t), est.anchor, est.in_doubt, v)
        assert err <= bound, f"t={t:.3f}: error {err:.3f} m beyond the stated {bound:.3f} m"
    assert anchor_before is not None and anchor_before.t > 0.8
    assert covariance_missed  # the case the reach is for
    assert est.in_doubt or est.status == "lost"
    assert est.anchor is not None and est.anchor.t < 1.2
