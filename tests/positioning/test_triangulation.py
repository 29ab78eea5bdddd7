"""Triangulation: exact recovery (hypothesis), published vector, critical circle, heading correction."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from agvnav.geometry import angle_diff, bearing_to, circumcentre
from agvnav.positioning import METHODS, crlb, triangulate

coord = st.floats(-20.0, 20.0, allow_nan=False)
point = st.tuples(coord, coord)
angle = st.floats(-math.pi, math.pi, allow_nan=False)


def _layout_ok(r: np.ndarray) -> bool:
    """Non-degenerate triangle: every angle above 10 degrees, sides above 1 m."""
    for i in range(3):
        a, b, c = r[i], r[(i + 1) % 3], r[(i + 2) % 3]
        u, v = b - a, c - a
        if min(np.linalg.norm(u), np.linalg.norm(v)) < 1.0:
            return False
        cosang = np.dot(u, v) / (np.linalg.norm(u) * np.linalg.norm(v))
        if cosang > math.cos(math.radians(10.0)):
            return False
    return True


def _critical_distance(r: np.ndarray, p: np.ndarray) -> float:
    """|distance of P from the circumcentre - circumradius|, relative to the circumradius."""
    c, _ = circumcentre(r[0], r[1], r[2])
    rad = np.linalg.norm(r[0] - c)
    return abs(np.linalg.norm(p - c) - rad) / rad


def _generic(r: np.ndarray, pose: np.ndarray) -> bool:
    p = pose[:2]
    return (
        _layout_ok(r)
        and min(np.linalg.norm(r - p, axis=1)) > 0.5
        and _critical_distance(r, p) > 0.1
        and np.all(np.isfinite(crlb(r, pose, 1.0)))
    )


@given(st.tuples(point, point, point), point, angle, st.floats(-1.55, 1.55), st.sampled_from(METHODS))
def test_every_method_recovers_the_pose_from_exact_bearings(refl, p, psi, err, method):
    r = np.array(refl)
    pose = np.array([p[0], p[1], psi])
    assume(_generic(r, pose))
    fix = triangulate(r, bearing_to(pose, r), method, heading_estimate=psi + err)
    assert fix.valid and not fix.heading_from_estimate
    assert math.hypot(fix.x - p[0], fix.y - p[1]) < 1e-9
    assert abs(angle_diff(fix.heading, psi)) < 1e-9


@given(st.tuples(point, point, point), point, angle, st.floats(-math.pi / 2, math.pi / 2))
def test_absolute_angles_corrects_heading_errors_up_to_90_degrees(refl, p, psi, err):
    r = np.array(refl)
    pose = np.array([p[0], p[1], psi])
    assume(_generic(r, pose))
    fix = triangulate(r, bearing_to(pose, r), "absolute_angles", heading_estimate=psi + err)
    assert fix.valid and not fix.heading_from_estimate
    assert abs(angle_diff(fix.heading, psi)) < 1e-9
    assert math.hypot(fix.x - p[0], fix.y - p[1]) < 1e-9


def _on_critical_circle(refl, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r = np.array(refl)
    c, _ = circumcentre(r[0], r[1], r[2])
    rad = np.linalg.norm(r[0] - c)
    p = c + rad * np.array([math.cos(s), math.sin(s)])
    return r, c, p


@given(st.tuples(point, point, point), angle, angle, st.floats(-math.pi / 6, math.pi / 6))
def test_absolute_angles_on_the_critical_circle_keeps_the_estimate(refl, s, psi, err):
    """On the critical circle the heading is unobservable (every point of the arc gives the
    same bearings), so the position is fixed by the heading estimate: the lines it defines
    meet at P turned by 2*err about the circle centre; with err = 0 that is P itself."""
    r, c, p = _on_critical_circle(refl, s)
    assume(_layout_ok(r) and np.linalg.norm(r - p, axis=1).min() > 0.05 * np.linalg.norm(r[0] - c))
    assume(np.linalg.norm(r - c, axis=1).max() < 100.0)
    pose = np.array([p[0], p[1], psi])
    fix = triangulate(r, bearing_to(pose, r), "absolute_angles", heading_estimate=psi + err)
    assert fix.valid and fix.heading_from_estimate
    assert abs(angle_diff(fix.heading, psi + err)) < 1e-12
    rot = np.array([[math.cos(2 * err), -math.sin(2 * err)], [math.sin(2 * err), math.cos(2 * err)]])
    expected = c + rot @ (p - c)
    scale = np.linalg.norm(r[0] - c)
    assert np.hypot(fix.x - expected[0], fix.y - expected[1]) < 1e-8 * scale
    exact = triangulate(r, bearing_to(pose, r), "absolute_angles", heading_estimate=psi)
    assert np.hypot(exact.x - p[0], exact.y - p[1]) < 1e-8 * scale


@given(st.tuples(point, point, point), angle, angle)
def test_relative_angles_and_total_are_invalid_on_the_critical_circle(refl, s, psi):
    r, c, p = _on_critical_circle(refl, s)
    assume(_layout_ok(r) and np.linalg.norm(r - p, axis=1).min() > 0.05 * np.linalg.norm(r[0] - c))
    for method in ("relative_angles", "total"):
        fix = triangulate(r, bearing_to(np.array([p[0], p[1], psi]), r), method)
        assert not fix.valid
        assert np.isnan(fix.x) and np.isnan(fix.y)


def test_least_squares_starts_from_another_triple_when_the_first_is_critical():
    r3 = np.array([[0.0, 1.0], [-math.sqrt(3) / 2, -0.5], [math.sqrt(3) / 2, -0.5]]) * 10.0
    r = np.vstack([r3, [[3.0, 9.0]]])
    pose = np.array([10.0 * math.cos(2.0), 10.0 * math.sin(2.0), 0.4])  # on the first triple's circle
    for bearings in (bearing_to(pose, r), bearing_to(pose, r)[None]):
        fix = triangulate(r, bearings, "least_squares")
        np.testing.assert_allclose(np.reshape(fix.pose, 3), pose, atol=1e-9)


def test_without_heading_estimate_absolute_angles_is_invalid_only_on_the_critical_circle():
    r = np.array([[0.0, 1.0], [-math.sqrt(3) / 2, -0.5], [math.sqrt(3) / 2, -0.5]])
    pose_on = np.array([math.cos(0.3), math.sin(0.3), 1.0])
    pose_off = np.array([0.1, -0.2, 2.5])
    batch = bearing_to(np.stack([pose_on, pose_off])[:, None, :], r)
    fix = triangulate(r, batch)
    assert fix.valid.tolist() == [False, True]
    assert abs(angle_diff(fix.heading[1], 2.5)) < 1e-12


PUBLISHED_R = [(0.0, 1.0), (-math.sqrt(3) / 2, -0.5), (math.sqrt(3) / 2, -0.5)]


def test_published_vector_bearings():
    bearings = bearing_to(np.zeros(3), np.array(PUBLISHED_R))
    np.testing.assert_allclose(np.rad2deg(bearings), [90.0, -150.0, -30.0], atol=1e-12)


@pytest.mark.parametrize("method", METHODS)
def test_published_vector_every_method(method):
    fix = triangulate(PUBLISHED_R, np.deg2rad([90.0, -150.0, -30.0]), method, heading_estimate=0.4)
    assert fix.valid
    assert fix.x.shape == () and fix.heading.shape == ()
    np.testing.assert_allclose(fix.pose, [0.0, 0.0, 0.0], atol=1e-12)


def test_heading_estimate_half_turn_is_resolved():
    """Lines fix delta modulo 180 degrees; reflectors must end up ahead along their rays."""
    pose = np.array([0.3, -0.2, 0.7])
    r = np.array(PUBLISHED_R) * 5.0
    for err in (math.radians(120.0), math.radians(-170.0), math.pi):
        fix = triangulate(r, bearing_to(pose, r), heading_estimate=pose[2] + err)
        np.testing.assert_allclose(fix.pose, pose, atol=1e-9)


@pytest.mark.parametrize("method", METHODS)
def test_batch_shapes_broadcast_and_match_single_fixes(method):
    rng = np.random.default_rng(4)
    r = np.array([[0.0, 10.0], [-8.0, -5.0], [9.0, -6.0]])
    poses = np.concatenate([rng.uniform(-3, 3, (2, 5, 2)), rng.uniform(-3, 3, (2, 5, 1))], axis=-1)
    bearings = bearing_to(poses[..., None, :], r) + rng.normal(0, 1e-3, (2, 5, 3))
    fix = triangulate(r, bearings, method, heading_estimate=poses[..., 2], bearing_std=1e-3)
    assert fix.x.shape == (2, 5) and fix.covariance.shape == (2, 5, 3, 3)
    one = triangulate(r, bearings[1, 3], method, heading_estimate=poses[1, 3, 2], bearing_std=1e-3)
    np.testing.assert_allclose(fix.pose[1, 3], one.pose, atol=1e-10)
    np.testing.assert_allclose(fix.covariance[1, 3], one.covariance, rtol=1e-7)
    assert fix.quality[1, 3] == pytest.approx(float(one.quality), rel=1e-9)


@pytest.mark.parametrize("method", METHODS)
def test_batch_with_per_element_layouts(method):
    rng = np.random.default_rng(5)
    r = np.array([[0.0, 10.0], [-8.0, -5.0], [9.0, -6.0]]) + rng.normal(0, 0.5, (40, 3, 2))
    poses = np.concatenate([rng.uniform(-3, 3, (40, 2)), rng.uniform(-3, 3, (40, 1))], axis=-1)
    fix = triangulate(r, bearing_to(poses[:, None, :], r), method, heading_estimate=poses[:, 2] + 0.3)
    assert np.all(fix.valid)
    np.testing.assert_allclose(fix.x, poses[:, 0], atol=1e-9)
    assert np.max(np.abs(angle_diff(fix.heading, poses[:, 2]))) < 1e-9


@pytest.mark.parametrize("method", METHODS)
def test_covariance_is_the_crlb_for_three_exact_bearings(method):
    r = np.array([[0.0, 10.0], [-8.0, -5.0], [9.0, -6.0]])
    pose = np.array([1.0, 2.0, 0.3])
    fix = triangulate(r, bearing_to(pose, r), method, heading_estimate=0.2, bearing_std=1e-4)
    np.testing.assert_allclose(fix.covariance, crlb(r, pose, 1e-4), rtol=1e-6)


def test_p_aligned_with_two_reflectors():
    """Eq. 5 case: one vertex of the error triangle at infinity; ToTal's infinite cotangent."""
    r = np.array([[0.0, 1.0], [0.0, 3.0], [2.0, 0.0]])
    pose = np.array([0.0, 0.0, 0.3])
    for method in METHODS:
        for est in (0.3, 0.9, -0.5):
            fix = triangulate(r, bearing_to(pose, r), method, heading_estimate=est)
            assert fix.valid, method
            np.testing.assert_allclose(fix.pose, pose, atol=1e-9)
        batch = triangulate(r, bearing_to(pose, r)[None], method, heading_estimate=[0.9])
        np.testing.assert_allclose(batch.pose[0], pose, atol=1e-9)


def test_least_squares_with_heading_prior_and_two_reflectors():
    r = np.array([[0.0, 10.0], [-8.0, -5.0]])
    pose = np.array([1.0, 2.0, 0.3])
    with pytest.raises(ValueError, match="at least 3"):
        triangulate(r, bearing_to(pose, r), "least_squares", heading_estimate=0.3)
    fix = triangulate(r, bearing_to(pose, r), "least_squares", heading_estimate=0.3, heading_std=0.01, bearing_std=1e-4)
    assert fix.valid
    np.testing.assert_allclose(fix.pose, pose, atol=1e-9)
    assert fix.covariance[2, 2] == pytest.approx(0.01**2, rel=1e-6)  # two bearings add nothing on psi


def test_least_squares_many_reflectors_batch_matches_float_path():
    rng = np.random.default_rng(8)
    r = rng.uniform(-15, 15, (7, 2))
    poses = np.concatenate([rng.uniform(-4, 4, (30, 2)), rng.uniform(-3, 3, (30, 1))], axis=-1)
    bearings = bearing_to(poses[:, None, :], r) + rng.normal(0, 1e-3, (30, 7))
    batch = triangulate(r, bearings, "least_squares", bearing_std=1e-3)
    for k in (0, 11, 29):
        one = triangulate(r, bearings[k], "least_squares", bearing_std=1e-3)
        np.testing.assert_allclose(batch.pose[k], one.pose, atol=1e-10)
        np.testing.assert_allclose(batch.covariance[k], one.covariance, rtol=1e-7)


def test_doctests_of_the_module():
    import doctest

    import agvnav.positioning.triangulation as mod

    assert doctest.testmod(mod).failed == 0
