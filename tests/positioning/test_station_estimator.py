"""Issue 32: the station-relative estimator against ground truth (exactness, NEES), and its pattern recognition."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.odometry import OdometryNoise
from agvnav.positioning.edge_bearing import bearing_model
from agvnav.positioning.station import StationEstimator, prior_in_station, station_offset, to_station
from agvnav.world.docking import DockingTarget, parse_docking_targets

MAP = """
docking_targets:
  - id: CH
    station: [2.0, 1.0, 30.0]
    reflectors:
      - {id: a, x: 0.0, y: -0.40}
      - {id: b, x: 0.0, y: 0.10}
      - {id: c, x: 0.0, y: 0.40}
    radius_m: 0.025
    docking_pose: [0.6, 0.0, 180.0]
    approach_m: 2.5
"""


def _target() -> DockingTarget:
    return DockingTarget.from_spec(parse_docking_targets(MAP).docking_targets[0])


def _drive(est: StationEstimator, target: DockingTarget, x0, steps: int, dd: float, rng=None, std: float = 0.0,
           odo_std: float = 0.0, xy=None, extra=()):
    """Drive straight ``steps`` times by ``dd`` (truth), one revolution of bearings after each step."""
    truth = np.array(x0, dtype=float)
    xy = target.reflector_xy if xy is None else xy
    t = est.t
    for _ in range(steps):
        t += 0.125
        d_true = dd
        d_meas = dd + (rng.normal(0.0, odo_std * math.sqrt(abs(dd))) if odo_std else 0.0)
        truth = truth + [d_true * math.cos(truth[2]), d_true * math.sin(truth[2]), 0.0]
        est.predict(t, d_meas, 0.0)
        h, _, _ = bearing_model(truth, (0.0, 0.0, 0.0), np.vstack([xy, *extra]) if extra else xy, target.radius)
        for k, z in enumerate(np.atleast_1d(h)):
            noise = rng.normal(0.0, std) if std else 0.0
            est.update(t + 1e-3 * (k + 1), float(z) + noise)
        t += 1e-2
        est.check(t)
    return truth


def test_frames_round_trip():
    s = np.array([2.0, 1.0, 0.5])
    g = np.array([3.0, -1.0, 2.0])
    rel = to_station(s, g)
    c, si = math.cos(s[2]), math.sin(s[2])
    back = [s[0] + c * rel[0] - si * rel[1], s[1] + si * rel[0] + c * rel[1], s[2] + rel[2]]
    assert back == pytest.approx(g, abs=1e-12)
    # the offset of a station seen where the map puts it is zero; moved, it is the move
    assert station_offset(s, g, rel) == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)
    moved = np.array([s[0] + 0.02 * c, s[1] + 0.02 * si, s[2] + 0.01])
    assert station_offset(s, g, to_station(moved, g)) == pytest.approx([0.02, 0.0, 0.01], abs=1e-12)


def test_noise_free_bearings_converge_to_the_truth():
    target = _target()
    est = StationEstimator(target, (0.0, 0.0, 0.0), 2**40, 0.125, OdometryNoise(1e-6, 1e-6, 1e-6), target_std=1e-7)
    truth0 = np.array([3.0, 0.05, math.pi])
    est.start(0.0, truth0 + [0.02, -0.015, 0.01], np.diag([0.02**2, 0.02**2, 0.02**2]))
    _drive(est, target, truth0, 2, 0.0)  # recognition at standstill
    truth = _drive(est, target, truth0, 40, 0.05)
    assert est.status == "tracking"
    assert est.pose[:2] == pytest.approx(truth[:2], abs=1e-6)
    assert est.pose[2] == pytest.approx(truth[2], abs=1e-6)


def test_nees_is_consistent_small_monte_carlo():
    """Mean NEES of the final estimate over runs lies in the chi2(3 n)/n 99.9 % band (n = 40)."""
    target = _target()
    rng = np.random.default_rng(7)
    noise = OdometryNoise(1e-4, 1e-4, 1e-4)
    std = 2.0 * math.pi / 65535 / math.sqrt(12.0)
    nees = []
    for _ in range(40):
        est = StationEstimator(target, (0.0, 0.0, 0.0), 65535, 0.125, noise, target_std=1e-9)
        truth0 = np.array([3.0, 0.0, math.pi])
        P0 = np.diag([0.01**2, 0.01**2, 0.01**2])
        est.start(0.0, truth0 + rng.multivariate_normal(np.zeros(3), P0), P0)
        _drive(est, target, truth0, 2, 0.0, rng, std=std)  # recognition at standstill
        truth = _drive(est, target, truth0, 12, 0.1, rng, std=std, odo_std=math.sqrt(noise.k_d))
        e = est.pose - truth
        e[2] = math.remainder(e[2], 2 * math.pi)
        nees.append(float(e @ np.linalg.solve(est.covariance, e)))
    mean = float(np.mean(nees))
    assert 3.0 * 0.62 < mean < 3.0 * 1.55, mean  # chi2(120)/40 99.9 % band: [2.0, 4.5] around 3


def test_pattern_recognised_then_tracked():
    target = _target()
    est = StationEstimator(target, (0.0, 0.0, 0.0), 65535, 0.125)
    x, P = prior_in_station((0.0, 0.0, 0.0), (3.0, 0.01, math.pi), np.diag([1e-4, 1e-4, 1e-5]), (0.05, 0.035))
    est.start(0.0, x, P)
    _drive(est, target, (3.0, 0.0, math.pi), 6, 0.02, np.random.default_rng(1))
    assert est.status == "tracking" and est.reason is None


@pytest.mark.parametrize("case, words", [
    ("missing", "not seen"),
    ("mismatch", "pattern mismatch"),
    ("clutter", "clutter"),
])
def test_a_target_that_does_not_fit_is_not_recognised(case, words):
    target = _target()
    est = StationEstimator(target, (0.0, 0.0, 0.0), 65535, 0.125, recognition_revolutions=4)
    P = np.diag([1e-4, 1e-4, 1e-5])
    est.start(0.0, (3.0, 0.0, math.pi), P)
    xy = target.reflector_xy.copy()
    extra = ()
    if case == "missing":
        xy = xy[:2]
    elif case == "mismatch":  # the pattern's shape: one reflector 30 mm off its place
        xy[1, 1] += 0.03
    else:
        extra = (np.array([[0.0, 0.112]]),)  # a shiny object 12 mm beside reflector b
    _drive(est, target, (3.0, 0.0, math.pi), 8, 0.0, xy=xy, extra=extra)
    assert est.status == "failed"
    assert words in str(est.reason), est.reason


def test_a_reflector_lost_while_tracking_fails_the_estimate():
    target = _target()
    est = StationEstimator(target, (0.0, 0.0, 0.0), 65535, 0.125)
    est.start(0.0, (3.0, 0.0, math.pi), np.diag([1e-4, 1e-4, 1e-5]))
    truth = _drive(est, target, (3.0, 0.0, math.pi), 3, 0.01)
    assert est.status == "tracking"
    _drive(est, target, truth, 12, 0.01, xy=target.reflector_xy[1:])  # a person hides reflector a
    assert est.status == "failed" and "'a' unseen" in str(est.reason)
