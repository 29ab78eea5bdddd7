"""Leave-one-out (RAIM) fault detection and exclusion of the integrity monitor (issue 12)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agvnav.positioning import bearing_model
from agvnav.positioning.integrity import IntegrityLimits, IntegrityMonitor, chi2_threshold, leave_one_out_fde

MOUNT = np.array([0.0, 0.0, 0.0])
POSE = np.array([4.0, 3.0, 0.3])
XY = np.array([[9.0, 3.0], [4.0, 9.0], [-1.0, 4.0], [5.0, -2.0], [8.0, 8.0], [0.0, -1.0], [9.0, -1.0]])
STD = 1e-3  # rad


def _jacobian(pose: np.ndarray) -> np.ndarray:
    d = XY - pose[:2]
    d2 = np.sum(d * d, axis=1)
    return np.column_stack([d[:, 1] / d2, -d[:, 0] / d2, -np.ones(len(XY))])


def test_chi2_threshold_known_values() -> None:
    assert chi2_threshold(2, 1e-3) == pytest.approx(-2.0 * math.log(1e-3))
    assert chi2_threshold(1, 0.05) == pytest.approx(3.841458820694124)
    with pytest.raises(ValueError, match="dof"):
        chi2_threshold(0, 0.01)


def test_the_biased_reflector_is_the_one_excluded() -> None:
    rng = np.random.default_rng(3)
    H = _jacobian(POSE)
    r = H @ np.array([0.02, -0.01, 0.002]) + rng.normal(0.0, STD, len(XY))  # an estimate pulled off
    r[4] += 12 * STD  # the moved reflector's bias
    res = leave_one_out_fde(r, H, np.full(len(XY), STD**2), 1e-5)
    assert res.detected and res.dof == len(XY) - 3
    assert res.faulty == 4
    assert res.without[4] <= res.exclusion_threshold


def test_a_sound_window_flags_nothing() -> None:
    rng = np.random.default_rng(4)
    H = _jacobian(POSE)
    r = H @ np.array([0.05, 0.03, -0.01]) + rng.normal(0.0, STD, len(XY))
    res = leave_one_out_fde(r, H, np.full(len(XY), STD**2), 1e-5)
    assert not res.detected and res.faulty == -1


def test_statistics_match_a_least_squares_reference() -> None:
    """Every statistic (all rows, each row left out) is the residual of numpy's lstsq fit, in either kernel mode."""
    from agvnav import _jit

    rng = np.random.default_rng(9)
    H = _jacobian(POSE)
    var = rng.uniform(0.5, 2.0, len(XY)) * STD**2
    r = H @ np.array([0.03, 0.01, -0.004]) + rng.normal(0.0, STD, len(XY))
    r[2] += 15 * STD

    def reference(keep: np.ndarray) -> float:
        sw = 1.0 / np.sqrt(var[keep])
        dx = np.linalg.lstsq(H[keep] * sw[:, None], r[keep] * sw, rcond=None)[0]
        return float(np.sum((r[keep] - H[keep] @ dx) ** 2 / var[keep]))

    before = _jit.compiled()
    try:
        for on in (False, True):
            _jit.set_compiled(on)
            res = leave_one_out_fde(r, H, var, 1e-5)
            assert res.statistic == pytest.approx(reference(np.ones(len(XY), bool)), rel=1e-9)
            for k in range(len(XY)):
                assert res.without[k] == pytest.approx(reference(np.arange(len(XY)) != k), rel=1e-9)
            assert res.detected and res.faulty == 2
    finally:
        _jit.set_compiled(before)


def test_chi2_threshold_is_scipy_s_quantile_bit_for_bit() -> None:
    from scipy.stats import chi2

    from agvnav.positioning._chi2_table import QUANTILES_1E5

    assert len(QUANTILES_1E5) == 512
    for dof in range(1, 520):  # the table (1e-5, dof <= 512), then scipy
        assert chi2_threshold(dof, 1e-5) == float(chi2.isf(1e-5, dof))
    for dof in (1, 3, 7):
        assert chi2_threshold(dof, 1e-3) == float(chi2.isf(1e-3, dof))
        assert chi2_threshold(dof, 1e-3) is chi2_threshold(dof, 1e-3)  # the cached float


def test_bad_input_is_named() -> None:
    H = _jacobian(POSE)
    with pytest.raises(ValueError, match="more rows"):
        leave_one_out_fde(np.zeros(3), H[:3], np.ones(3), 0.01)
    with pytest.raises(ValueError, match="variances"):
        leave_one_out_fde(np.zeros(7), H, np.zeros(7), 0.01)


@settings(max_examples=3, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_false_alarm_rate_of_sound_windows_is_the_stated_probability(seed: int) -> None:
    """Over 1000 sound windows at a 5 % false-alarm probability, 5 % +- 4.5 sigma of a binomial fail."""
    rng = np.random.default_rng(seed)
    H = _jacobian(POSE)
    var = rng.uniform(0.5, 2.0, len(XY)) * STD**2
    n, p = 1000, 0.05
    alarms = sum(
        leave_one_out_fde(rng.normal(0.0, np.sqrt(var)), H, var, p).detected for _ in range(n)
    )
    assert abs(alarms / n - p) < 4.5 * math.sqrt(p * (1 - p) / n)


def _feed(mon: IntegrityMonitor, bias_row: int, bias: float, t0: float, n_rev: int) -> float:
    """Exact bearings of every reflector each revolution, as EKF innovations about a pose held at POSE."""
    h, _, _ = bearing_model(POSE, MOUNT, XY, np.zeros(len(XY)))
    H = _jacobian(POSE)
    rng = np.random.default_rng(7)
    t = t0
    for k in range(n_rev * len(XY)):
        i = k % len(XY)
        if i in mon.excluded:  # the estimator never associates an excluded reflector again
            continue
        t = t0 + (k + 1) * 0.125 / len(XY)
        y = rng.normal(0.0, STD) + (bias if i == bias_row else 0.0)
        S = STD**2
        mon.accepted(t, y * y / S, i, float(h[i]), (0.0, 0.0, 0.0), None, (y, S, *H[i]))
        if mon.due(t):
            mon.check(t, POSE, np.diag([1e-4, 1e-4, 1e-5]), (0.0, 0.0, 0.0), False)
    return t


def test_the_monitor_excludes_a_biased_reflector_and_reports_degraded() -> None:
    mon = IntegrityMonitor(XY, np.zeros(len(XY)), MOUNT, STD, 0.125, IntegrityLimits(max_latency_s=1.0))
    _feed(mon, 2, 8 * STD, 0.0, 40)
    assert mon.excluded == (2,)


def test_the_monitor_leaves_a_sound_stream_alone() -> None:
    mon = IntegrityMonitor(XY, np.zeros(len(XY)), MOUNT, STD, 0.125, IntegrityLimits(max_latency_s=1.0))
    _feed(mon, -1, 0.0, 0.0, 40)
    assert mon.excluded == () and mon.verdict == "ok"
    assert math.isfinite(mon.raim_statistic) and mon.raim_statistic < 1.0


def test_the_default_false_alarm_needs_no_scipy_stats() -> None:
    """The RAIM's quantiles come from the table: agvnav simulate does not pay scipy.stats' import (issue 11)."""
    import subprocess
    import sys

    code = ("import sys; from agvnav.positioning.integrity import chi2_threshold; "
            "[chi2_threshold(k, 1e-5) for k in range(1, 300)]; print('scipy.stats' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout
    assert out.strip() == "False"
