"""Positioning guard (issue 12 §2): decisions on synthetic status and covariance sequences."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.navigation.guard import EstimatorWatch, GuardLimits, PositioningGuard, demanded_level, lateral_sigma

LIM = GuardLimits(lateral_3sigma_slow_m=0.1, lateral_3sigma_stop_m=0.3, slow_speed_fraction=0.25, resume_after_s=1.0)


def _cov(sx, sy, rho=0.0, spsi=0.01):
    P = np.array([[sx * sx, rho * sx * sy, 0.0], [rho * sx * sy, sy * sy, 0.0], [0.0, 0.0, spsi * spsi]])
    return P.ravel().tolist()


@given(
    st.floats(1e-4, 1.0), st.floats(1e-4, 1.0), st.floats(-0.99, 0.99), st.floats(-math.pi, math.pi)
)
def test_lateral_sigma_is_the_projection_on_the_body_y_axis(sx, sy, rho, psi):
    P = np.array(_cov(sx, sy, rho)).reshape(3, 3)[:2, :2]
    n = np.array([-math.sin(psi), math.cos(psi)])
    assert lateral_sigma(_cov(sx, sy, rho), psi) == pytest.approx(math.sqrt(n @ P @ n), rel=1e-9, abs=1e-15)


def test_lateral_sigma_axis_cases():
    cov = _cov(0.3, 0.01)  # long along x, thin along y
    assert lateral_sigma(cov, 0.0) == pytest.approx(0.01)  # heading east: lateral is y
    assert lateral_sigma(cov, math.pi / 2) == pytest.approx(0.3)  # heading north: lateral is x
    assert math.isnan(lateral_sigma([math.nan] * 9, 0.0))


@pytest.mark.parametrize(
    ("status", "lat3", "level"),
    [
        ("tracking", 0.05, 0),
        ("tracking", 0.15, 1),
        ("tracking", 0.31, 2),
        ("degraded", 0.05, 1),
        ("dead_reckoning", 0.05, 1),
        ("dead_reckoning", 0.5, 2),
        ("lost", 0.01, 2),
        ("initialising", 0.01, 2),
        ("some_new_status", 0.01, 2),  # unknown: conservative
        ("tracking", math.nan, 2),  # non-finite covariance
        ("tracking", None, 0),  # an estimator without covariance: status only
        ("degraded", None, 1),
    ],
)
def test_demanded_level(status, lat3, level):
    assert demanded_level(status, lat3, LIM) == level


def _run(guard, seq, dt=0.1):
    """Feed (status, sigma_lateral) per step; return the scales."""
    return [guard.update(k * dt, status, _cov(0.01, s), 0.0) for k, (status, s) in enumerate(seq)]


def test_slow_then_stop_then_resume_after_the_hold_time():
    g = PositioningGuard(LIM)
    seq = [("tracking", 0.01)] * 3 + [("dead_reckoning", 0.01)] * 3 + [("lost", 0.01)] * 3 + [("tracking", 0.01)] * 15
    scales = _run(g, seq)
    assert scales[:3] == [1.0] * 3
    assert scales[3:6] == [0.25] * 3
    assert scales[6:9] == [0.0] * 3
    # good again from step 9 (t = 0.9 s): still stopped until 1 s of good positioning (t = 1.9 s)
    assert scales[9:19] == [0.0] * 10
    assert scales[19:] == [1.0] * 5


def test_worse_applies_at_once_and_a_relapse_restarts_the_hold():
    g = PositioningGuard(LIM)
    seq = [("lost", 0.01)] + [("tracking", 0.01)] * 5 + [("tracking", 0.05)] + [("tracking", 0.01)] * 12
    scales = _run(g, seq)
    assert scales[0] == 0.0 and scales[1:6] == [0.0] * 5
    assert scales[6] == 0.0  # demand slow < stop: still holding
    assert scales[7:16] == [0.0] * 9  # the worse demand at step 6 restarted the 1 s hold
    assert scales[16] == 1.0


def test_covariance_limits_slow_and_stop():
    g = PositioningGuard(LIM)
    assert g.update(0.0, "tracking", _cov(0.01, 0.02), 0.0) == 1.0  # 3 sigma 6 cm
    assert g.update(0.1, "tracking", _cov(0.01, 0.05), 0.0) == 0.25  # 15 cm
    assert g.update(0.2, "tracking", _cov(0.01, 0.11), 0.0) == 0.0  # 33 cm
    assert g.state == "stop" and g.lateral_3sigma == pytest.approx(0.33)


def test_disabled_guard_never_slows():
    g = PositioningGuard(LIM, enabled=False)
    assert _run(g, [("lost", 1.0)] * 3) == [1.0] * 3


@pytest.mark.parametrize(
    "kwargs",
    [
        {"lateral_3sigma_slow_m": 0.2, "lateral_3sigma_stop_m": 0.1},
        {"slow_speed_fraction": 0.0},
        {"slow_speed_fraction": 1.5},
        {"resume_after_s": -1.0},
        {"lateral_3sigma_slow_m": math.nan},
    ],
)
def test_bad_limits_raise(kwargs):
    with pytest.raises(ValueError):
        GuardLimits(**kwargs)


class _Est:
    def __init__(self, status, cov, quality=None):
        self.status, self.covariance, self.pose = status, np.asarray(cov).reshape(3, 3), np.zeros(3)
        if quality is not None:
            self.quality = quality


def test_watch_records_covariance_and_quality():
    w = EstimatorWatch(PositioningGuard(LIM))
    assert w.scale(0.0, _Est("tracking", _cov(0.01, 0.02), quality=0.8)) == 1.0
    sig = dict(zip(w.signal_names, w.signals(), strict=True))
    assert sig["est_cov_yy"] == pytest.approx(4e-4) and sig["est_quality"] == 0.8
    assert sig["lateral_3sigma_est"] == pytest.approx(0.06) and sig["guard_level"] == 0.0
    w.scale(0.1, _Est("lost", _cov(0.01, 0.02)))
    sig = dict(zip(w.signal_names, w.signals(), strict=True))
    assert math.isnan(sig["est_quality"]) and sig["speed_scale"] == 0.0
