import math

import numpy as np
import pytest

from agvnav.sim.metrics import (
    TransientSpec,
    compute_metrics,
    reorientation_mask,
    transient_end_index,
)
from agvnav.sim.recorder import EventLog, Recorder


def _series(n=1001, v=0.2, dt=0.02):
    t = np.arange(n) * dt
    dist = v * t
    return t, dist


def test_transient_end_is_first_entry_into_band():
    # exponential decay from 110 mm with time constant 2 s: band 11 mm reached at t = 2 ln 10
    t, _ = _series()
    e = 0.110 * np.exp(-t / 2.0)
    k = transient_end_index(e)
    assert k is not None
    assert abs(t[k] - 2.0 * math.log(10.0)) <= 0.02 + 1e-9
    assert abs(e[k]) <= 0.011 < abs(e[k - 1])


def test_band_floor_and_never_settling():
    spec = TransientSpec(band_fraction=0.1, band_floor_m=0.005)
    assert spec.band(0.01) == 0.005
    assert spec.band(-0.2) == pytest.approx(0.02)
    assert transient_end_index(np.full(10, 0.3)) is None
    assert transient_end_index(np.array([0.001, 0.5, 0.5])) == 0
    with pytest.raises(ValueError):
        transient_end_index(np.zeros((2, 2)))


def test_metrics_on_synthetic_series():
    t, dist = _series()
    # decay, then a 10 mm sinusoid with an overshoot of -15 mm after the transient
    e = 0.110 * np.exp(-t / 1.0)
    k0 = transient_end_index(e)
    tail = np.zeros_like(t)
    tail[k0 + 50 :] = 0.010 * np.sin(2 * np.pi * 0.2 * t[k0 + 50 :])
    e = e + tail
    e[k0 + 300] = -0.015
    xr = np.zeros_like(t)
    xr[:k0] = 0.5
    xr[k0 + 10] = -math.radians(3.0)
    true = np.column_stack([t, np.zeros_like(t), np.zeros_like(t)])
    est = true.copy()
    est[:, 1] = 0.003  # 3 mm to the left of a vehicle heading +x
    est[:, 0] += 0.004  # 4 mm longitudinal
    valid = np.ones_like(t, dtype=bool)
    valid[:5] = False
    est[:5] = np.nan
    m = compute_metrics(t, e, 0.5 * xr, dist, true, est, valid, path_completed=True, wall_time_s=0.1, reflections=7,
                        wheel_heading_error=xr)
    k = transient_end_index(e)
    assert k == k0
    assert m.max_abs_lateral_error_m == pytest.approx(0.015)
    assert m.rms_lateral_error_m == pytest.approx(np.sqrt(np.mean(e[k:] ** 2)))
    assert m.max_abs_wheel_heading_error_rad == pytest.approx(math.radians(3.0))
    assert m.max_abs_heading_error_rad == pytest.approx(math.radians(1.5))
    assert m.settling_distance_m == pytest.approx(dist[k])
    assert m.settling_time_s == pytest.approx(t[k])
    assert m.positioning_rms_m == pytest.approx(0.005)
    assert m.positioning_lateral_mean_abs_m == pytest.approx(0.003)
    assert m.positioning_lateral_std_m == pytest.approx(0.0, abs=1e-12)
    assert m.sim_time_s == pytest.approx(t[-1])
    assert m.real_time_factor == pytest.approx(t[-1] / 0.1)
    d = m.to_dict()
    assert d["reflections"] == 7 and d["path_completed"] is True and d["steps"] == t.size - 1


def test_metrics_none_when_undefined():
    t, dist = _series(n=20)
    e = np.full(t.size, 0.2)
    pose = np.zeros((t.size, 3))
    m = compute_metrics(t, e, e, dist, pose, pose, np.zeros(t.size, bool), path_completed=False, wall_time_s=0.0)
    assert m.max_abs_lateral_error_m is None and m.settling_distance_m is None
    assert m.positioning_rms_m is None and m.real_time_factor is None


def test_recorder_and_event_log():
    rec = Recorder(("a", "b"), 4)
    rec.append((1.0, 2.0))
    rec.append((3.0, 4.0))
    assert rec.data.shape == (2, 2)
    np.testing.assert_array_equal(rec["b"], [2.0, 4.0])
    with pytest.raises(ValueError):
        Recorder(("a", "a"), 3)
    log = EventLog(("t", "x"), block=3)
    for i in range(4):
        log.extend(np.array([[i, 10 * i], [i + 0.5, 10 * i + 5]], dtype=float))
    assert len(log) == 8
    d = log.as_dict()
    np.testing.assert_array_equal(d["t"], [0, 0.5, 1, 1.5, 2, 2.5, 3, 3.5])


def test_no_wheel_heading_error_without_a_steered_wheel():
    # issue 29: a mecanum or differential vehicle has no wheel heading error; the body heading figure is given
    t, dist = _series(n=50)
    h = np.full(t.size, math.radians(2.0))
    pose = np.zeros((t.size, 3))
    m = compute_metrics(t, np.zeros(t.size), h, dist, pose, pose, np.ones(t.size, bool), path_completed=True,
                        wall_time_s=0.1)
    assert m.max_abs_wheel_heading_error_rad is None
    assert m.max_abs_heading_error_rad == pytest.approx(math.radians(2.0))


def _reorienting_run(decay_per_m):
    """A body turning onto a 90 deg step of its reference at s = 5 m, its error decaying per metre."""
    s = np.linspace(0.0, 10.0, 1001)
    h = np.where(s >= 5.0, math.radians(90.0) * np.exp(-decay_per_m * np.clip(s - 5.0, 0.0, None)), 0.0)
    return s, h


def test_reorientation_is_skipped_for_a_stated_distance_and_a_slow_turn_shows():
    s, fast = _reorienting_run(math.log(50.0))  # 2 % left after 1 m: the shipped follower's design
    turning = reorientation_mask(s, s, [5.0])
    assert turning[(s >= 5.0) & (s <= 6.0)].all() and not turning[(s < 5.0) | (s > 6.0 + 1e-9)].any()
    pose = np.zeros((s.size, 3))
    t = s / 0.4

    def figure(h):
        return compute_metrics(t, np.zeros(s.size), h, s, pose, pose, np.ones(s.size, bool), path_completed=True,
                               wall_time_s=1.0, reorienting=turning, heading_reorientations=1)

    m = figure(fast)
    assert m.heading_reorientations == 1
    assert m.max_abs_heading_error_rad == pytest.approx(math.radians(90.0) / 50.0, rel=0.05)
    slow = figure(_reorienting_run(math.log(50.0) / 4.0)[1])  # a follower four times slower: 37 deg left at 1 m
    assert math.degrees(slow.max_abs_heading_error_rad) == pytest.approx(90.0 / 50.0**0.25, rel=0.05)
    unskipped = compute_metrics(t, np.zeros(s.size), fast, s, pose, pose, np.ones(s.size, bool),
                                path_completed=True, wall_time_s=1.0)
    assert math.degrees(unskipped.max_abs_heading_error_rad) == pytest.approx(90.0)


def test_counted_samples_decide_the_headline():
    # a mission counts the samples where the vehicle moves; a larger error at rest is not its headline
    t, dist = _series(n=100)
    e = np.full(t.size, 0.002)
    e[60:70] = 0.050
    counted = np.ones(t.size, bool)
    counted[60:70] = False
    pose = np.zeros((t.size, 3))
    args = (t, e, np.zeros(t.size), dist, pose, pose, np.ones(t.size, bool))
    assert compute_metrics(*args, path_completed=True, wall_time_s=1.0).max_abs_lateral_error_m == pytest.approx(0.05)
    m = compute_metrics(*args, path_completed=True, wall_time_s=1.0, counted=counted)
    assert m.max_abs_lateral_error_m == pytest.approx(0.002)
