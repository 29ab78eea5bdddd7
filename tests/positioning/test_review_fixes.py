"""Review fixes of issue 2: ahead vote, critical-circle covariance, LM stall, crlb/pdop input checks."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.geometry import bearing_to, circumcentre
from agvnav.positioning import crlb, pdop, triangulate
from agvnav.positioning import least_squares as ls

R3 = np.array([[0.0, 5.0], [-4.0, -3.0], [4.5, -2.0]])


def test_one_reflector_cannot_flip_the_heading_alone():
    pose = np.array([0.5, 0.3, 0.4])
    b = bearing_to(pose, R3)
    b[0] = b[0] + math.pi  # same line, opposite ray (a mirrored reading of reflector 1)
    for batch in (False, True):
        bb = b[None] if batch else b
        fix = triangulate(R3, bb, "absolute_angles", heading_estimate=pose[2] + 0.2)
        assert np.all(fix.valid)
        np.testing.assert_allclose(np.ravel(fix.pose), pose, atol=1e-9)


def _critical_pose():
    centre, _ = circumcentre(R3[0], R3[1], R3[2])
    rad = float(np.linalg.norm(R3[0] - centre))
    xy = centre + rad * np.array([math.cos(2.0), math.sin(2.0)])
    return np.array([xy[0], xy[1], 0.3])


def test_critical_circle_covariance_without_heading_std_is_flagged_not_nan():
    pose = _critical_pose()
    b = bearing_to(pose, R3)
    for bb in (b, b[None]):
        fix = triangulate(R3, bb, "absolute_angles", heading_estimate=pose[2] + 0.01, bearing_std=1e-4)
        assert np.all(fix.valid) and np.all(fix.heading_from_estimate)
        cov = np.reshape(fix.covariance, (3, 3))
        assert not np.any(np.isnan(cov))
        assert np.all(np.isinf(np.diag(cov)))
    with_std = triangulate(R3, b, "absolute_angles", heading_estimate=pose[2] + 0.01, bearing_std=1e-4,
                           heading_std=0.01)
    assert np.all(np.isfinite(with_std.covariance))


def test_critical_circle_position_is_rotated_by_twice_the_heading_error():
    pose = _critical_pose()
    centre, _ = circumcentre(R3[0], R3[1], R3[2])
    delta = 0.05
    fix = triangulate(R3, bearing_to(pose, R3), "absolute_angles", heading_estimate=pose[2] + delta)
    c, s = math.cos(2 * delta), math.sin(2 * delta)
    d = pose[:2] - centre
    rotated = centre + np.array([c * d[0] - s * d[1], s * d[0] + c * d[1]])
    rotated_other = centre + np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])
    got = np.array([float(fix.x), float(fix.y)])
    assert min(np.linalg.norm(got - rotated), np.linalg.norm(got - rotated_other)) < 1e-9


def test_stalled_damping_is_not_convergence(monkeypatch):
    rng = np.random.default_rng(3)
    refl = rng.uniform(-10, 10, (5, 2))
    pose = np.array([0.3, -0.2, 0.1])
    b = bearing_to(pose, refl) + rng.normal(0, 1e-3, 5)
    # No trial ever lowers the cost: the damping grows past LAM_MAX away from the minimum.
    monkeypatch.setattr(ls, "_cost_single", lambda *a, **k: math.inf)
    monkeypatch.setattr(ls, "_cost", lambda *a, **k: np.inf)
    assert not bool(triangulate(refl, b, "least_squares").valid)
    assert not np.any(triangulate(refl, b[None], "least_squares").valid)


def test_least_squares_still_converges_normally():
    rng = np.random.default_rng(4)
    refl = rng.uniform(-10, 10, (5, 2))
    pose = np.array([0.3, -0.2, 0.1])
    b = bearing_to(pose, refl) + rng.normal(0, 1e-3, (200, 5))
    fix = triangulate(refl, b, "least_squares")
    assert np.all(fix.valid)
    one = triangulate(refl, b[0], "least_squares")
    assert bool(one.valid)
    np.testing.assert_allclose(one.pose, fix.pose[0], atol=1e-9)


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: crlb(R3, [0, 0, 0], -1e-3), "bearing_std"),
        (lambda: crlb(R3, [0, 0, 0], np.nan), "bearing_std"),
        (lambda: crlb(R3, [0, 0], 1e-3), "pose"),
        (lambda: crlb(R3, [np.nan, 0, 0], 1e-3), "pose"),
        (lambda: crlb(R3[:, :1], [0, 0, 0], 1e-3), "reflectors"),
        (lambda: pdop(R3, [0, 0]), "pose"),
        (lambda: pdop(R3, [0, np.inf, 0]), "pose"),
        (lambda: pdop([[0, 1], [np.nan, 2], [3, 3]], [0, 0, 0]), "reflectors"),
    ],
)
def test_crlb_and_pdop_name_bad_input(call, match):
    with pytest.raises(ValueError, match=match):
        call()
