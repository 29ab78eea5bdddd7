"""The fleet's bodies in arrays (sim.bodies): line-of-sight tests against shapely, interpolation, the view."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import LineString, Polygon

from agvnav.sim.bodies import BodiesInView, FleetBodies, footprint_gaps, placed_footprints, segment_hits_box
from agvnav.world.obstacles import ObstacleSet, ObstacleSpec, obstacle_from_spec


def _box_polygon(pose: np.ndarray, box: np.ndarray) -> Polygon:
    x0, x1, y0, y1 = box
    local = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    return Polygon(placed_footprints(local[None], pose[None])[0])


def _segments_hit_boxes_oracle(a: np.ndarray, b: np.ndarray, poses: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """The slab test in NumPy: each segment ``a -> b (k, 2)`` in its box frame (``poses (k, 3)``, ``boxes (k, 4)``)."""
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    ax, ay, bx, by = a[:, 0] - poses[:, 0], a[:, 1] - poses[:, 1], b[:, 0] - poses[:, 0], b[:, 1] - poses[:, 1]
    lo, hi, ok = np.zeros(len(a)), np.ones(len(a)), np.ones(len(a), dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        for p0, p1, bmin, bmax in ((c * ax + s * ay, c * bx + s * by, boxes[:, 0], boxes[:, 1]),
                                   (-s * ax + c * ay, -s * bx + c * by, boxes[:, 2], boxes[:, 3])):
            d = p1 - p0
            flat = d == 0.0
            ok &= ~flat | ((p0 >= bmin) & (p0 <= bmax))
            ta, tb = (bmin - p0) / d, (bmax - p0) / d
            lo = np.where(flat, lo, np.maximum(lo, np.minimum(ta, tb)))
            hi = np.where(flat, hi, np.minimum(hi, np.maximum(ta, tb)))
    return ok & (lo <= hi)


def test_segment_hits_box_agrees_with_shapely_and_the_oracle_on_random_segments() -> None:
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
    got = np.array([segment_hits_box(*a[k], *b[k], *poses[k], *boxes[k]) for k in range(n)])
    want = np.array([_box_polygon(poses[k], boxes[k]).intersects(
        LineString([a[k], b[k]]) if not np.array_equal(a[k], b[k]) else Polygon([a[k], a[k], a[k]]).centroid)
        for k in range(n)])
    assert got.shape == (n,)
    assert 0.1 < want.mean() < 0.9
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(_segments_hit_boxes_oracle(a, b, poses, boxes), want)


def test_poses_inside_the_step_follow_the_constant_twist_through_the_wrap() -> None:
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


def test_moving_bodies_block_sight_as_the_brute_force_at_their_true_poses() -> None:
    """The compiled line-of-sight test (bounding circles, then slabs) against every body at its pose then."""
    rng = np.random.default_rng(6)
    n = 12
    fp = np.array([[0.45, 0.3], [-0.45, 0.3], [-0.45, -0.3], [0.45, -0.3]])
    start = np.column_stack([rng.uniform(0, 10, (n, 2)), rng.uniform(-math.pi, math.pi, n)])
    bodies = FleetBodies([fp * rng.uniform(0.5, 2.0) for _ in range(n)], start)
    grid = FleetBodies.sample_times(2.0, 2.05)
    turn = rng.uniform(-2, 2, n)
    poses = start[:, None, :] + np.stack([np.outer(rng.uniform(-1, 1, n), grid - 2.0),
                                          np.outer(rng.uniform(-1, 1, n), grid - 2.0), np.outer(turn, grid - 2.0)], -1)
    bodies.begin_step(2.0, 2.05, poses)
    k = 2000
    p0, p1 = rng.uniform(-1, 11, (k, 2)), rng.uniform(-1, 11, (k, 2))
    t = rng.uniform(2.0, 2.05, k)
    idx = np.arange(n)[rng.uniform(size=n) < 0.8]
    got = bodies.block_sight(p0, p1, t, idx)
    at = bodies.poses_at(t, idx)  # (k, m, 3)
    want = _segments_hit_boxes_oracle(np.repeat(p0, idx.size, 0), np.repeat(p1, idx.size, 0), at.reshape(-1, 3),
                                      np.tile(bodies.boxes[idx], (k, 1))).reshape(k, idx.size).any(axis=1)
    assert 0.1 < want.mean() < 0.9
    np.testing.assert_array_equal(got, want)
    # the sampled poses are the motion's: each body passes through them, and its edges are its box there
    np.testing.assert_allclose(bodies.poses_at(grid, np.arange(n)), poses.transpose(1, 0, 2), atol=1e-12)
    edges = bodies.edges_at(2.03)
    corners = bodies.corners(bodies.poses_at(np.array(2.03), np.arange(n)), np.arange(n))
    np.testing.assert_allclose(edges[:, :, 0, :], corners, atol=1e-12)
    np.testing.assert_allclose(edges[:, :, 1, :], np.roll(corners, -1, axis=1), atol=1e-12)


def test_footprint_gaps_equal_shapely_distances_of_placed_footprints() -> None:
    """The compiled polygon distance: apart, touching, overlapping and one inside the other, convex or an L
    (padded with a repeated vertex, as the fleet pads its footprints)."""
    rng = np.random.default_rng(9)
    box = np.array([[0.6, 0.4], [-0.6, 0.4], [-0.6, -0.4], [0.6, -0.4], [0.6, -0.4], [0.6, -0.4]])
    ell = np.array([[1.0, 0.3], [-0.5, 0.3], [-0.5, -0.8], [-0.2, -0.8], [-0.2, 0.0], [1.0, 0.0]])
    n = 40
    shapes = np.stack([box if i % 2 else ell for i in range(n)])
    poses = np.column_stack([rng.uniform(0, 6, (n, 2)), rng.uniform(-math.pi, math.pi, n)])
    poses[1] = poses[0] + [0.01, 0.0, 0.0]  # nearly coincident
    placed = placed_footprints(shapes * np.where(np.arange(n) == 3, 0.2, 1.0)[:, None, None], poses)
    poses[3, :2] = poses[2, :2]  # a small box inside another body
    placed[3] = placed_footprints(shapes[3:4] * 0.2, poses[2:3])[0]
    a, b = np.triu_indices(n, 1)
    got = footprint_gaps(placed, a.astype(np.int64), b.astype(np.int64))
    polys = [Polygon(p) for p in placed]
    want = np.array([polys[i].distance(polys[j]) for i, j in zip(a, b, strict=True)])
    assert (want == 0.0).sum() > 10 and (want > 0.5).sum() > 100
    np.testing.assert_allclose(got, want, atol=1e-12)
