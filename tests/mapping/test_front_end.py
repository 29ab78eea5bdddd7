"""The front end on the differential AGV's drive, whose log states the truth's random odometry noise (issue 17)."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.bench.mapping import HALLS, _drive, log_from_result
from agvnav.mapping import MappingOptions
from agvnav.mapping.drive import repeated_readings
from agvnav.mapping.slam import front_end


@pytest.mark.parametrize("seed", [0])
def test_front_end_gates_on_the_heading_dead_reckoned_since_the_last_solution(seed: int) -> None:
    """With the stated random noise (heading 8e-4 rad²/m: ~20 mrad over a 0.5 m chunk) the gate must allow the
    heading dead-reckoned since the last window solution, not only the odometry inside one step (~3 mrad): that
    gate left 43 % of the true reflections with their reflector and created 47 false ones (new gate: 89 %, 11).
    Ground truth: the simulator's reflector index of each reflection."""
    result = _drive(HALLS["hall_differential"], seed)
    log = log_from_result(result)
    assert log.truth is not None
    assert list(log.settings["odometry_noise"]) == [5e-5, 8e-4, 2e-4]  # the stated random-only noise
    opt = MappingOptions()
    fe = front_end(log, log.truth[0].copy(), opt)
    true = result.world.reflector_xy
    index = np.asarray(result.events["reflections"]["reflector_index"]).astype(np.int64)
    stamp = np.asarray(log.reflection_stamp)
    kept = (stamp > log.t[0]) & (stamp <= log.t[-1])
    k = np.clip(np.searchsorted(log.t, stamp, side="left") - 1, 0, log.t.size - 2)
    still = np.flatnonzero(kept & np.all(log.increments[k] == 0.0, axis=1))
    kept[still[repeated_readings(stamp[still], log.bearing[still], log.settings["rate_hz"])]] = False
    index = index[kept]  # the reflections prepare_drive keeps
    d = np.hypot(*(fe.landmarks[:, None, :] - true[None]).transpose(2, 0, 1))
    landmark_truth = np.where(d.min(axis=1) < 0.1, np.argmin(d, axis=1), -1)
    seen = np.flatnonzero(np.bincount(index[index >= 0], minlength=true.shape[0]) >= opt.init.min_sightings)
    assert set(seen.tolist()) <= set(landmark_truth.tolist())  # every seen reflector initialised
    ok = index >= 0
    right = (fe.assoc >= 0) & (landmark_truth[np.maximum(fe.assoc, 0)] == index)
    assert float(np.mean(right[ok])) > 0.8
    assert int(np.sum(landmark_truth < 0)) <= 20  # the batch removes the rest (min sightings, tracks)


def _lane_track(target: np.ndarray, y: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """Head poses along a lane at ``y`` heading west (x 15.8 -> 15.2 m) and their exact bearings of ``target``."""
    from agvnav.sensors.goniometer import leading_edge_bearing

    x = np.linspace(15.8, 15.2, 16)
    heads = np.column_stack([x, np.full_like(x, y), np.full_like(x, np.pi)])
    b = np.array([float(np.ravel(leading_edge_bearing(h, target[None], np.array([0.04]))[0])[0]) for h in heads])
    return heads, b


def test_a_track_along_one_line_of_sight_through_two_reflectors_is_not_merged_into_the_farther() -> None:
    # hall_differential seed 8: P2's reflections from the north lane, P1 0.5 m behind it on nearly the same line of
    # sight, triangulated 0.13 m from P1. The old rule (the nearest reflector within merge_distance) gave P1.
    from agvnav.mapping.slam import NEW_REFLECTOR, MappingOptions, _track_target

    p1, p2 = np.array([15.0, 6.75]), np.array([15.0, 7.25])
    landmarks = np.vstack([p1, p2])
    opt = MappingOptions()
    heads, b = _lane_track(p2)
    slid = np.array([14.92, 6.85])  # the track's centre slid along the rays towards P1
    assert float(np.hypot(*(slid - p1))) < opt.merge_distance
    assert _track_target(heads, b, slid, landmarks, opt) == -1  # ambiguous: left out, not given to P1
    assert _track_target(heads, b, p2 + 0.05, landmarks, opt) == 1  # near P2 and fitting it: P2
    heads1, b1 = _lane_track(p1, y=4.0)  # P1 from the south lane, where it is the nearer one: merged into P1
    assert _track_target(heads1, b1, p1 + np.array([0.05, 0.1]), landmarks, opt) == 0
    assert _track_target(heads, b, np.array([20.0, 0.0]), landmarks, opt) == NEW_REFLECTOR
