"""A localization is judged before it is reported: tracking time, reflections used, the truth (issue 29)."""

import json

import numpy as np
import pytest
from _csv_log import write_csv_log

from agvnav.logs import Localization, RecordedLog, estimator_from_settings, judge, localize, read_csv_log
from agvnav.logs.localize import MIN_REFLECTIONS_USED_SHARE, MIN_TRACKING_SHARE, TRUTH_TOLERANCE_M
from agvnav.logs.outputs import localization_summary
from agvnav.world import load_map


def _known(status, accepted=8, reflections=10, offset=None):
    """A localization along t = 0, 1, ..., 10 s with the given status per instant, at the truth (+ ``offset`` m)."""
    t = np.arange(11.0)
    truth = np.zeros((11, 3))
    est = truth.copy()
    if offset is not None:
        est[:, 0] += offset
    series = {"t": t, "est_x": est[:, 0], "est_y": est[:, 1], "est_psi": est[:, 2],
              "est_status": np.asarray(status, dtype=np.float64)}
    log = RecordedLog(t, np.zeros((10, 3)), np.linspace(0.5, 9.5, reflections), np.linspace(0.5, 9.5, reflections),
                      np.zeros(reflections), truth=truth)
    return Localization(series, "ekf", reflections, accepted, 0, 0), log


def test_the_tracking_time_is_the_intervals_whose_state_is_tracking():
    # the state at t[k] holds over (t[k-1], t[k]]: instants 1..6 tracking -> 6 of 10 s
    loc, log = _known([0, 1, 1, 1, 1, 1, 1, 2, 2, 4, 4])
    v = judge(loc, log)
    assert v.tracking_s == 6.0 and v.tracking_share == pytest.approx(0.6) and v.reflections_used_share == 0.8
    assert v.outcome == "completed" and v.reason is None and v.tracking_off_truth_s == 0.0


def test_below_either_threshold_the_localization_failed():
    loc, log = _known([0] * 7 + [1] * 4)  # 4 of 10 s
    v = judge(loc, log)
    assert v.tracking_share < MIN_TRACKING_SHARE and v.outcome == "failed" and "tracked 40 % of the log" in v.reason
    loc, log = _known([1] * 11, accepted=4)
    v = judge(loc, log)
    assert v.reflections_used_share < MIN_REFLECTIONS_USED_SHARE and v.outcome == "failed"
    assert "used 4 of 10 reflections" in v.reason and "tracked" not in v.reason


def test_with_truth_tracking_off_the_truth_does_not_count():
    offset = np.zeros(11)
    offset[6:] = 2 * TRUTH_TOLERANCE_M  # the estimator says tracking, but is 0.2 m off from t = 6 s on
    loc, log = _known([1] * 11, offset=offset)
    v = judge(loc, log)
    assert v.tracking_s == 5.0 and v.tracking_off_truth_s == 5.0 and v.outcome == "completed"
    offset[4:] = 2 * TRUTH_TOLERANCE_M
    v = judge(*_known([1] * 11, offset=offset))
    assert v.tracking_s == 3.0 and v.outcome == "failed" and "within 0.1 m of the truth" in v.reason


def test_a_recorded_run_passes_and_the_same_run_without_its_start_pose_fails(short_run, tmp_path):
    world = load_map("lab")
    log = read_csv_log(write_csv_log(short_run, tmp_path / "good"))
    loc = localize(log, estimator_from_settings(log.settings, world))
    doc = localization_summary(loc, log)
    assert doc["outcome"] == "completed" and doc["tracking_share"] > 0.95 and doc["reflections_used_share"] > 0.9
    # the headline figures agree with the details: the time series' tracking rows and the counts
    tracking = loc.series["est_status"][1:] == 1.0
    assert doc["tracking_s"] == pytest.approx(np.sum(np.diff(loc.series["t"])[tracking]))
    assert doc["tracking_share"] == pytest.approx(doc["tracking_s"] / doc["duration_s"])
    assert doc["reflections_used_share"] == pytest.approx(doc["accepted"] / doc["reflections"])
    settings = json.loads((tmp_path / "good" / "settings.json").read_text())
    del settings["initial_pose"], settings["initial_covariance"]  # the estimator must search its start pose
    log = read_csv_log(write_csv_log(short_run, tmp_path / "bad", settings))
    loc = localize(log, estimator_from_settings(log.settings, world))
    doc = localization_summary(loc, log)
    assert doc["outcome"] == "failed" and doc["tracking_share"] < MIN_TRACKING_SHARE and "tracked" in doc["reason"]
