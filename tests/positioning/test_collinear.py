"""Collinear reflectors (issue 13): a correct fix off their line, an honest invalid flag on it, never a raise."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.positioning._drive import arc_pose_at, feed

from agvnav.geometry import angle_diff, bearing_to
from agvnav.odometry import OdometryNoise
from agvnav.positioning import triangulate
from agvnav.positioning.estimator import make_estimator
from agvnav.positioning.triangulation import METHODS
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import Reflector, WorldMap


def _wall(origin, direction_rad, spacing, n=3):
    d = np.array([math.cos(direction_rad), math.sin(direction_rad)])
    return np.asarray(origin, dtype=np.float64) + np.outer(np.arange(n) * spacing, d)


@settings(max_examples=60, deadline=None)
@given(
    ox=st.floats(-5, 5), oy=st.floats(-5, 5), direction=st.floats(-math.pi, math.pi), spacing=st.floats(0.5, 4.0),
    along=st.floats(-3.0, 8.0), off=st.floats(0.3, 6.0), side=st.sampled_from([-1.0, 1.0]),
    heading=st.floats(-math.pi, math.pi), n=st.sampled_from([3, 4]),
)
def test_off_the_line_every_method_returns_the_exact_pose(ox, oy, direction, spacing, along, off, side, heading, n):
    r = _wall((ox, oy), direction, spacing, n)
    d, nrm = np.array([math.cos(direction), math.sin(direction)]), np.array([-math.sin(direction), math.cos(direction)])
    p = np.array([ox, oy]) + along * d + side * off * nrm
    pose = np.array([p[0], p[1], heading])
    b = bearing_to(pose, r)
    for method in METHODS if n == 3 else ("least_squares",):
        fix = triangulate(r, b, method=method, heading_estimate=heading + 0.05)
        assert bool(fix.valid), method
        np.testing.assert_allclose([float(fix.x), float(fix.y)], p, atol=1e-6 * (1 + off + abs(along)), err_msg=method)
        assert abs(float(angle_diff(fix.heading, heading))) < 1e-6, method


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("p", [(1.0, 5.0), (-3.0, 5.0), (9.0, 5.0)])
def test_on_the_line_the_fix_is_flagged_invalid_not_raised(method, p):
    r = np.array([[0.0, 5.0], [2.0, 5.0], [4.0, 5.0]])
    pose = np.array([p[0], p[1], 0.3])
    fix = triangulate(r, bearing_to(pose, r), method=method, heading_estimate=0.3)
    assert not bool(fix.valid)
    assert np.isnan(float(fix.x)) and np.isnan(float(fix.y))


@pytest.mark.parametrize("method", METHODS)
def test_batch_mixes_collinear_and_general_layouts(method):
    wall = np.array([[0.0, 5.0], [2.0, 5.0], [4.0, 5.0]])
    tri = np.array([[0.0, 5.0], [2.0, 7.0], [4.0, 5.0]])
    layouts = np.stack([wall, tri, wall])
    poses = np.array([[1.0, 1.0, 0.2], [1.5, 2.0, -0.4], [-2.0, 5.0, 0.0]])  # the last one stands on the line
    b = np.stack([bearing_to(q, r) for q, r in zip(poses, layouts, strict=True)])
    fix = triangulate(layouts, b, method=method, heading_estimate=poses[:, 2])
    assert fix.valid.tolist() == [True, True, False]
    np.testing.assert_allclose(np.column_stack([fix.x, fix.y])[:2], poses[:2, :2], atol=1e-7)


def _perimeter(n_per_wall: int, width=20.0, depth=10.0) -> WorldMap:
    """``4 n_per_wall`` reflectors evenly spaced on the four walls of a hall: every wall holds collinear triples."""
    refl, k = [], 0
    for (x0, y0), (x1, y1) in (((0, 0), (width, 0)), ((width, 0), (width, depth)), ((width, depth), (0, depth)),
                               ((0, depth), (0, 0))):
        for s in (np.arange(n_per_wall) + 0.5) / n_per_wall:
            refl.append(Reflector(f"R{k}", x0 + s * (x1 - x0), y0 + s * (y1 - y0), 0.0))
            k += 1
    return WorldMap(tuple(refl), ())


@pytest.mark.parametrize("n_reflectors", [16, 32])
@pytest.mark.parametrize("method", ["angle_propagation", "naive"])
def test_estimators_run_through_perimeter_maps(n_reflectors, method):
    """Perimeter maps with 16 and 32 reflectors: the triples on one wall no longer crash the fix; it stays exact."""
    world = _perimeter(n_reflectors // 4)
    mount = np.array([0.3, 0.0, 0.0])
    gon = Goniometer(pulses_per_rev=2**24, mount=tuple(mount))
    start = np.array([4.0, 3.0, 0.1])
    speed, omega = (0.5, 0.05) if method == "angle_propagation" else (0.0, 0.0)
    est = make_estimator(method, world, mount, pulses_per_rev=2**24, map_std=0.0,
                         odometry_noise=OdometryNoise(0.0, 0.0, 0.0), initial_pose=start,
                         initial_covariance=np.diag([0.01, 0.01, 0.005]) ** 2)
    pose_at = arc_pose_at(start, speed, omega)
    t, x, _ = feed(est, world, gon, pose_at, speed, omega, 4.0)
    assert est.n_fixes > 10
    truth = pose_at(t)
    assert np.max(np.hypot(*(x[:, :2] - truth[:, :2]).T)) < 1e-4
