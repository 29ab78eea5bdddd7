"""The fleet's bodies in arrays (sim.bodies): line-of-sight tests against shapely, interpolation, the view."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import LineString, Polygon

from agvnav.sim.bodies import BodiesInView, FleetBodies, placed_footprints, segments_hit_boxes
from agvnav.world.obstacles import ObstacleSet, ObstacleSpec, obstacle_from_spec


def _box_polygon(pose: np.ndarray, box: np.ndarray) -> Polygon:
    x0, x1, y0, y1 = box
    local = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    return Polygon(placed_footprints(local[None], pose[None])[0])


def test_segments_hit_boxes_agrees_with_shapely_on_random_segments() -> None:
    rng = np.random.default_rng(4)
    n = 4000
    a = rng.uniform(-3, 3, (n, 2))
    b = rng.uniform(-3, 3, (n, 2))
    b[:200] = a[:200]  # points
    b[200:400, 1] = a[200:400, 1]  # horizontal segments
    poses = np.column_stack([rng.uniform(-1, 1, (n, 2)), rng.uniform(-math.pi, math.pi, n)])
    poses[400:600, 2] = 0.0  # axis-aligned boxes with the horizontal and vertical segments
    b[400:500, 0] = a[400:500, 0]
    boxes = np.column_stack([-rng.uniform(0.1, 1, n), rng.uniform(0.1, 1, n), -rng.uniform(0.1, 1, n),
                             rng.uniform(0.1, 1, n)])
    got = segments_hit_boxes(a, b, poses, boxes)
    want = np.array([_box_polygon(poses[k], boxes[k]).intersects(
        LineString([a[k], b[k]]) if not np.array_equal(a[k], b[k]) else Polygon([a[k], a[k], a[k]]).centroid)
        for k in range(n)])
    assert got.shape == (n,)
    assert 0.1 < want.mean() < 0.9
    np.testing.assert_array_equal(got, want)


def test_poses_inside_the_step_are_interpolated_through_the_wrap() -> None:
    fp = np.array([[0.45, 0.3], [-0.45, 0.3], [-0.45, -0.3], [0.45, -0.3]])
    bodies = FleetBodies([fp, fp], np.array([[0.0, 0.0, 3.1], [5.0, 0.0, 0.0]]))
    bodies.begin_step(1.0, 1.1, np.array([[0.1, 0.0, -3.1], [5.0, 0.0, 0.0]]))
    p = bodies.poses_at(np.array([1.0, 1.05, 1.1, 2.0]), np.array([0]))
    assert p.shape == (4, 1, 3)
    np.testing.assert_allclose(p[:, 0, 0], [0.0, 0.05, 0.1, 0.1])
    # 3.1 -> -3.1 is a turn of +0.083 rad through pi, not -6.2 rad
    np.testing.assert_allclose(p[1, 0, 2], 3.1 + 0.5 * (2 * math.pi - 6.2))


def test_a_view_sees_the_other_bodies_within_reach_indexed_after_its_own_obstacles() -> None:
    fp = np.array([[0.45, 0.3], [-0.45, 0.3], [-0.45, -0.3], [0.45, -0.3]])
    poses = np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [40.0, 0.0, 0.0]])
    bodies = FleetBodies([fp, fp, fp], poses)
    bodies.begin_step(0.0, 0.05, poses)
    pallet = obstacle_from_spec(ObstacleSpec(id="pallet", shape="box", length_m=1.0, width_m=1.0, position=(0.0, 5.0)))
    view = BodiesInView((pallet,), bodies=bodies, me=0, reach=10.0)
    edges, owner = view.segments_at(0.02)
    assert edges.shape == (8, 2, 2) and owner.tolist() == [0] * 4 + [1 + 1] * 4  # body 2 is 40 m away
    assert view.blocks((1.0, 0.0), (6.0, 0.0), 0.02)  # through body 1
    assert not view.blocks((1.0, 1.0), (6.0, 1.0), 0.02)
    assert view.blocks((0.0, 3.0), (0.0, 6.0), 0.02)  # through the pallet (the own obstacles' test)
    many = view.blocked(np.array([[1.0, 0.0], [1.0, 1.0]]), np.array([[6.0, 0.0], [6.0, 1.0]]),
                        np.array([0.01, 0.04]))
    assert many.tolist() == [True, False]
    shapes = view.shapes_at(0.02)
    assert len(shapes) == 2 and shapes[1].area == pytest.approx(0.9 * 0.6)
    assert ObstacleSet((pallet,)).blocked(np.array([[0.0, 3.0]]), np.array([[0.0, 6.0]]), np.array([0.0])).tolist() \
        == [True]
