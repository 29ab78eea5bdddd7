"""Bad input (issue 2 §3): the single-fix path raises ValueError naming the problem, batches flag."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.geometry import bearing_to
from agvnav.positioning import METHODS, triangulate

R = np.array([[0.0, 10.0], [-8.0, -5.0], [9.0, -6.0]])
POSE = np.array([1.0, 2.0, 0.3])
B = bearing_to(POSE, R)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"method": "magic"}, "unknown triangulation method"),
        ({"reflectors": R[:, 0]}, r"reflectors must have shape \(\.\.\., N, 2\)"),
        ({"bearings": B[:2]}, "bearings must have shape"),
        ({"reflectors": np.stack([R, R]), "bearings": np.stack([B, B, B])}, "batch shapes do not broadcast"),
        ({"heading_estimate": [0.1, 0.2, 0.3], "bearings": np.stack([B, B])}, "batch shapes do not broadcast"),
        ({"method": "least_squares", "reflectors": R[:2], "bearings": B[:2]}, "at least 3 reflectors"),
        ({"method": "total", "reflectors": np.vstack([R, [[3.0, 3.0]]]), "bearings": np.r_[B, 0.0]}, "exactly 3"),
        ({"bearing_std": -1.0}, "bearing_std must be positive"),
        ({"heading_std": 0.0}, "heading_std must be positive"),
        ({"bearings": [0.1, "a", 0.2]}, "bearings must be numeric"),
    ],
)
def test_structural_problems_raise_on_every_path(kwargs, message):
    args = {"reflectors": R, "bearings": B, "method": "absolute_angles", "heading_estimate": 0.3}
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        triangulate(**args)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize(
    ("reflectors", "bearings", "message"),
    [
        (R, np.array([B[0], np.nan, B[2]]), "bearings contains NaN or inf"),
        (R, np.array([B[0], np.inf, B[2]]), "bearings contains NaN or inf"),
        (np.array([[0.0, 10.0], [np.nan, -5.0], [9.0, -6.0]]), B, "reflectors contains NaN"),
        (np.array([[0.0, 10.0], [0.0, 10.0], [9.0, -6.0]]), B, "reflectors 0 and 1 coincide"),
    ],
)
def test_value_problems_raise_for_a_single_fix(method, reflectors, bearings, message):
    with pytest.raises(ValueError, match=message):
        triangulate(reflectors, bearings, method, heading_estimate=0.3)


def test_nan_heading_estimate_raises_for_a_single_fix():
    with pytest.raises(ValueError, match="heading_estimate contains NaN"):
        triangulate(R, B, heading_estimate=math.nan)


@pytest.mark.parametrize("method", METHODS)
def test_bad_batch_elements_are_flagged_without_poisoning_neighbours(method):
    rng = np.random.default_rng(3)
    poses = np.concatenate([rng.uniform(-3, 3, (6, 2)), rng.uniform(-3, 3, (6, 1))], axis=-1)
    layouts = np.broadcast_to(R, (6, 3, 2)).copy()
    bearings = bearing_to(poses[:, None, :], R)
    bearings[1, 2] = np.nan
    bearings[2, 0] = np.inf
    layouts[3, 1] = layouts[3, 0]  # coincident
    layouts[4] = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]  # collinear, and P on their line (issue 13):
    bearings[4] = poses[4, 2] + np.array([0.7, 0.7, 0.7 - math.pi])  # parallel rays, the fix is undetermined
    heading = poses[:, 2] + 0.2
    fix = triangulate(layouts, bearings, method, heading_estimate=heading, bearing_std=1e-3)
    assert fix.valid.tolist() == [True, False, False, False, False, True]
    assert np.all(np.isnan(fix.x[1:5])) and not np.any(fix.heading_from_estimate[1:5])
    for k in (0, 5):
        np.testing.assert_allclose(fix.pose[k], poses[k], atol=1e-9)
        assert np.all(np.isfinite(fix.covariance[k]))


def test_nan_heading_estimate_in_a_batch_is_flagged():
    fix = triangulate(R, np.stack([B, B]), heading_estimate=[0.2, math.nan])
    assert fix.valid.tolist() == [True, False]
    np.testing.assert_allclose(fix.pose[0], POSE, atol=1e-9)


def test_degenerate_geometry_is_not_bad_input():
    """On the critical circle nothing raises: relative angles and ToTal flag, absolute angles keeps psi_est."""
    r = np.array([[0.0, 1.0], [-math.sqrt(3) / 2, -0.5], [math.sqrt(3) / 2, -0.5]])
    pose = np.array([math.cos(2.0), math.sin(2.0), 0.4])
    b = bearing_to(pose, r)
    assert not triangulate(r, b, "relative_angles").valid
    fix = triangulate(r, b, "absolute_angles", heading_estimate=0.4)
    assert fix.valid and fix.heading_from_estimate
    np.testing.assert_allclose(fix.pose, pose, atol=1e-9)
