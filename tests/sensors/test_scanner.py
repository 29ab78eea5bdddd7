"""The safety scanner's ranges against known geometry (issue 18)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.sensors.scanner import SafetyScanner, cast_rays


def test_ray_to_a_wall_is_the_perpendicular_distance_over_cos():
    wall = np.array([[[5.0, -10.0], [5.0, 10.0]]])
    angles = np.radians([0.0, 30.0, -60.0, 180.0])
    r, hit = cast_rays([[1.0, 0.0]], angles, wall)
    assert r[0, :3] == pytest.approx([4.0, 4.0 / math.cos(math.radians(30)), 4.0 / math.cos(math.radians(60))],
                                     abs=1e-12)
    assert r[0, 3] == math.inf and hit[0, 3] == -1
    assert list(hit[0, :3]) == [0, 0, 0]


def test_ray_to_a_box_hits_the_near_face_and_the_corner():
    # unit box [2, 3] x [-0.5, 0.5] as four segments
    c = np.array([[2.0, -0.5], [3.0, -0.5], [3.0, 0.5], [2.0, 0.5]])
    box = np.stack([c, np.roll(c, -1, axis=0)], axis=1)
    to_corner = math.atan2(0.5, 2.0)
    r, hit = cast_rays([[0.0, 0.0]], [0.0, to_corner, math.atan2(0.6, 2.0), math.pi / 2], box)
    assert r[0, 0] == pytest.approx(2.0, abs=1e-12)
    assert r[0, 1] == pytest.approx(math.hypot(2.0, 0.5), abs=1e-12)
    assert r[0, 2] == math.inf  # passes above the box
    assert r[0, 3] == math.inf
    assert hit[0, 0] == 3  # the face x = 2 is the segment from (2, 0.5) to (2, -0.5)


def test_ray_to_a_cylinder_and_from_inside():
    circles = np.array([[4.0, 0.0, 1.0]])
    r, hit = cast_rays([[0.0, 0.0], [4.0, 0.5]], [[0.0, math.atan2(1.0, math.sqrt(15.0)) - 1e-9],
                                                  [0.0, 1.0]], np.zeros((0, 2, 2)), circles)
    assert r[0, 0] == pytest.approx(3.0, abs=1e-12)
    # tangent ray: the touching point at distance sqrt(4^2 - 1^2)
    assert r[0, 1] == pytest.approx(math.sqrt(15.0), abs=1e-3)
    assert r[1, 0] == 0.0 and r[1, 1] == 0.0  # inside the cylinder
    assert hit[0, 0] == 0  # index M + j with M = 0 segments


def test_nearest_surface_wins_and_max_range_cuts():
    wall = np.array([[[10.0, -5.0], [10.0, 5.0]]])
    circles = np.array([[6.0, 0.0, 0.5]])
    r, hit = cast_rays([[0.0, 0.0]], [0.0, 0.3], wall, circles, max_range=8.0)
    assert r[0, 0] == pytest.approx(5.5, abs=1e-12) and hit[0, 0] == 1
    assert r[0, 1] == math.inf and hit[0, 1] == -1  # the wall at 10.46 m is beyond 8 m


def test_scanner_measure_is_exact_without_noise_and_seeded_with_noise():
    wall = np.array([[[5.0, -10.0], [5.0, 10.0]]])
    sc = SafetyScanner(mount=(0.5, 0.0, 0.0), fov=math.radians(180.0), step=math.radians(1.0), noise_std=0.0)
    assert sc.angles.size == 181
    ranges, _, pts = sc.measure([1.0, 0.0, 0.0], wall, None, np.random.default_rng(0))
    j = 90  # straight ahead
    assert ranges[0, j] == pytest.approx(3.5, abs=1e-12)
    assert pts[0, j] == pytest.approx([4.0, 0.0], abs=1e-12)  # in base_link
    noisy = SafetyScanner(noise_std=0.01)
    a = noisy.measure([0.0, 0.0, 0.0], wall, None, np.random.default_rng(3))[0]
    b = noisy.measure([0.0, 0.0, 0.0], wall, None, np.random.default_rng(3))[0]
    assert np.array_equal(a, b)
    exact = SafetyScanner(noise_std=0.0).measure([0.0, 0.0, 0.0], wall, None, np.random.default_rng(3))[0]
    both = np.isfinite(exact) & np.isfinite(a)
    err = a[both] - exact[both]
    assert err.size > 200 and 0.008 < float(np.std(err)) < 0.012


def test_scan_times_cover_half_open_windows_once():
    sc = SafetyScanner(rate_hz=25.0)
    t = np.concatenate([sc.scan_times(0.0, 0.05), sc.scan_times(0.05, 0.1), sc.scan_times(0.1, 1.0)])
    assert t == pytest.approx(np.arange(1, 26) / 25.0)


def test_bad_parameters_are_named():
    with pytest.raises(ValueError, match="fov"):
        SafetyScanner(fov=0.0)
    with pytest.raises(ValueError, match="noise_std"):
        SafetyScanner(noise_std=-1.0)


def test_a_person_who_appears_at_start_is_not_scanned_before():
    """``appears_at_start``: the person steps out at start_s; before, the scanner sees the wall behind its spot."""
    from agvnav.world.obstacles import ObstacleSet, ObstacleSpec, obstacle_from_spec

    spec = ObstacleSpec(id="p", shape="cylinder", radius_m=0.25, path=[(3.0, 0.0), (3.0, 5.0)], speed_m_s=1.0,
                        start_s=2.0, appears_at_start=True)
    obs = ObstacleSet((obstacle_from_spec(spec),))
    wall = np.array([[[5.0, -10.0], [5.0, 10.0]]])
    sc = SafetyScanner(mount=(0.0, 0.0, 0.0), fov=math.radians(180.0), step=math.radians(1.0), noise_std=0.0)
    ahead = []
    for t in (1.99, 2.0):
        circles, _ = obs.circles_at(t)
        ranges = sc.measure([0.0, 0.0, 0.0], wall, circles, np.random.default_rng(0))[0]
        ahead.append(float(ranges[0, 90]))
    assert ahead == pytest.approx([5.0, 2.75], abs=1e-12)
    assert np.isnan(obs.clearances([0.0, 0.0, 0.0], np.array([[0.5, -0.3], [0.5, 0.3], [-0.5, 0.3]]), 1.0)[0])
    assert not obs.blocks([0.0, 0.0], [5.0, 0.0], 1.0) and obs.blocks([0.0, 0.0], [5.0, 0.0], 2.0)
