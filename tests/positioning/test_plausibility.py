"""Plausibility limits on the estimators' inputs (issue 12 §1): each rule, strict and running modes."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _drive import arc_pose_at

from agvnav.positioning import make_estimator
from agvnav.positioning.estimator import METHODS
from agvnav.positioning.plausibility import PlausibilityLimits, check_covariance, implausible_increment
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import WorldMap, load_builtin_map

MOUNT = np.array([0.3, 0.0, 0.0])
START = np.array([4.0, 3.0, 0.3])
LIMITS = PlausibilityLimits(max_speed_m_s=2.0, max_yaw_rate_rad_s=1.0, max_gap_s=2.0, late_window_s=0.2)


@pytest.fixture(scope="module")
def lab() -> WorldMap:
    return load_builtin_map("lab")


def test_each_rule_names_its_reason() -> None:
    assert implausible_increment(LIMITS, 0.05, 0.1, 0.05) is None  # 2 m/s, 1 rad/s exactly (with the slack)
    assert implausible_increment(LIMITS, 0.05, 5.0, 0.0) == "too_fast"  # a +5 m spike
    assert implausible_increment(LIMITS, 0.05, 6.5e5, 0.0) == "too_fast"  # a 32-bit counter wrap
    assert implausible_increment(LIMITS, 0.05, 0.0, 0.0, 0.2) == "too_fast"  # sideways
    assert implausible_increment(LIMITS, 0.05, 0.0, 0.5) == "turns_too_fast"
    assert implausible_increment(LIMITS, 2.5, 0.0, 0.0) == "time_gap"
    with pytest.raises(ValueError, match="max_speed_m_s"):
        PlausibilityLimits(max_speed_m_s=-1.0)
    with pytest.raises(ValueError, match="late_window_s"):
        PlausibilityLimits(late_window_s=math.nan)


def test_covariance_must_be_symmetric_positive_definite() -> None:
    check_covariance("P", np.eye(3))
    with pytest.raises(ValueError, match="positive definite"):
        check_covariance("P", np.diag([1.0, 0.0, 1.0]))
    with pytest.raises(ValueError, match="symmetric"):
        check_covariance("P", [[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    with pytest.raises(ValueError, match="NaN"):
        check_covariance("P", np.full((3, 3), np.nan))
    with pytest.raises(ValueError, match=r"shape \(3, 3\)"):
        check_covariance("P", np.eye(2))


@pytest.mark.parametrize("method", METHODS)
def test_the_api_refuses_a_non_positive_definite_initial_covariance(lab: WorldMap, method: str) -> None:
    with pytest.raises(ValueError, match="initial_covariance must be positive definite"):
        make_estimator(method, lab, MOUNT, initial_pose=START, initial_covariance=np.diag([1e-4, -1e-4, 1e-4]))


@pytest.mark.parametrize(
    ("increment", "dt", "match"),
    [((5.0, 0.0), 0.05, "too_fast"), ((6.5e5, 0.0), 0.05, "too_fast"), ((0.0, 0.5), 0.05, "turns_too_fast"),
     ((0.0, 0.0), 3.0, "time_gap"), ((math.nan, 0.0), 0.05, "NaN")],
)
def test_strict_estimator_raises_naming_the_problem(lab: WorldMap, increment: tuple, dt: float, match: str) -> None:
    est = make_estimator("ekf", lab, MOUNT, initial_pose=START, plausibility=LIMITS)
    est.predict(0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match=match):
        est.predict(dt, *increment)


@pytest.mark.parametrize("method", METHODS)
def test_running_estimator_drops_and_counts_and_goes_on(lab: WorldMap, method: str) -> None:
    est = make_estimator(method, lab, MOUNT, initial_pose=START, plausibility=LIMITS, strict=False)
    t = 0.0
    est.predict(t, 0.0, 0.0)
    for k in range(1, 11):  # 0.5 m/s straight
        t = 0.05 * k
        est.predict(t, 0.025, 0.0)
    before = est.pose.copy()
    est.predict(t + 0.05, 5.0, 0.0)  # spike: replaced by the last rate
    est.predict(t + 0.10, 6.5e5, 0.0)  # counter wrap
    est.predict(t + 0.15, math.nan, 0.0)
    est.predict(t + 0.20, 0.0, 0.5)
    est.predict(math.inf, 0.0, 0.0)
    est.predict(t - 1.0, 0.0, 0.0)  # out of order
    est.update(math.nan, 0.1)
    assert est.n_dropped == {"too_fast": 2, "non_finite": 3, "turns_too_fast": 1, "out_of_order": 1}
    assert est.drops.total == 7
    moved = est.pose[:2] - before[:2]
    assert np.hypot(*moved) == pytest.approx(4 * 0.025, abs=1e-9)  # four steps at the last rate
    assert math.isfinite(est.pose[0]) and est.t == pytest.approx(t + 0.20)


def test_a_time_gap_in_a_running_vehicle_says_lost(lab: WorldMap) -> None:
    est = make_estimator("ekf", lab, MOUNT, initial_pose=START, plausibility=LIMITS, strict=False)
    est.predict(0.0, 0.0, 0.0)
    est.predict(5.0, 0.3, 0.0)  # 5 s without odometry: not integrated, anything was possible
    assert est.n_dropped == {"time_gap": 1}
    assert np.allclose(est.pose, START) and est.covariance[0, 0] > 10.0 * 10.0
    assert est.status == "lost"


def _scan(lab: WorldMap, t_end: float):
    return Goniometer(mount=tuple(MOUNT)).scan(lab, arc_pose_at(START, 0.5, 0.2), 0.0, t_end)


def test_late_reflections_are_reordered_not_rejected(lab: WorldMap) -> None:
    """Reflections delivered 0.1 s late give (nearly) the estimate of the in-order stream."""
    refl = _scan(lab, 2.0)
    ticks = np.arange(0.0, 2.0 + 1e-9, 0.02)
    estimates = []
    for delay in (0.0, 0.1):
        est = make_estimator("ekf", lab, MOUNT, initial_pose=START, plausibility=LIMITS)
        est.predict(0.0, 0.0, 0.0)
        j = 0
        for t in ticks[1:]:
            est.predict(float(t), 0.5 * 0.02, 0.2 * 0.02)
            while j < refl.t.size and refl.t[j] + delay <= t:
                est.update(float(refl.t[j]), float(refl.bearing[j]))
                j += 1
        estimates.append((est.pose.copy(), est.n_accepted, est.n_dropped))
    (in_order, n0, _), (late, n1, dropped) = estimates
    assert n1 >= 0.9 * n0 and dropped == {}
    assert np.hypot(*(late[:2] - in_order[:2])) < 2e-3


def test_too_late_reflections_raise_or_are_dropped(lab: WorldMap) -> None:
    strict = make_estimator("ekf", lab, MOUNT, initial_pose=START, plausibility=LIMITS)
    strict.predict(1.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="late_window_s"):
        strict.update(0.5, 0.1)
    running = make_estimator("ekf", lab, MOUNT, initial_pose=START, plausibility=LIMITS, strict=False)
    running.predict(1.0, 0.0, 0.0)
    assert not running.update(0.5, 0.1)
    assert running.n_dropped == {"late": 1}


def test_a_burst_of_missed_odometry_is_neither_extrapolated_nor_trusted(lab: WorldMap) -> None:
    """Seconds of missed motion arrive in one step, split at reflection instants (``odometry_lost``).

    The first piece, 4.2 mm in 0.8 ms (5.25 m/s), passes on the slack; the pieces after
    it are refused as too fast and replaced by the motion at the last rate. That rate
    must be one the vehicle can have (at most ``max_speed_m_s``), and the variance must
    grow by what the vehicle could have done in each refused piece's span: before,
    the estimate ran at 5.25 m/s (0.25 m in 50 ms) while its sigma stayed at millimetres.
    """
    est = make_estimator("ekf", lab, MOUNT, initial_pose=START, initial_covariance=np.diag([1e-6, 1e-6, 1e-6]),
                         plausibility=LIMITS, strict=False)
    est.predict(0.0, 0.0, 0.0)
    est.predict(0.0008, 0.0042, 0.0)  # plausible only on the 10 mm slack
    before, var_before = est.pose.copy(), est.covariance[0, 0] + est.covariance[1, 1]
    spans = (0.0049, 0.0095, 0.0224, 0.0124)
    t = 0.0008
    for span in spans:  # 0.26 m in 49 ms: every piece too fast
        t += span
        est.predict(t, 5.25 * span, 0.0)
    assert est.n_dropped == {"too_fast": 4}
    moved = float(np.hypot(*(est.pose[:2] - before[:2])))
    assert moved <= LIMITS.max_speed_m_s * sum(spans) + 1e-12  # at most the limit speed, not 5.25 m/s
    grown = est.covariance[0, 0] + est.covariance[1, 1] - var_before
    assert grown >= 2.0 * sum((LIMITS.max_speed_m_s * s) ** 2 for s in spans)  # sigma ~ the motion possible
