"""Footprint collision with walls (issue 12 §2): a known geometry, and the prefilter never misses."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agvnav.geometry import segment_distances
from agvnav.sim.collision import CollisionWatch, WallCollider

# a 1 m x 0.5 m box centred on base_link; a wall along x = 2 (y from -5 to 5) and a 0.4 m pillar at (5, 0)
BOX = np.array([[0.5, 0.25], [-0.5, 0.25], [-0.5, -0.25], [0.5, -0.25]])
WALLS = np.array([
    [[2.0, -5.0], [2.0, 5.0]],
    [[4.8, -0.2], [5.2, -0.2]], [[5.2, -0.2], [5.2, 0.2]], [[5.2, 0.2], [4.8, 0.2]], [[4.8, 0.2], [4.8, -0.2]],
])


def test_segment_distances_analytic():
    d = segment_distances((0.0, 0.0), WALLS)
    assert d[0] == pytest.approx(2.0)
    assert d[1] == pytest.approx(math.hypot(4.8, 0.2))  # nearest point: the corner (4.8, -0.2)
    assert d[4] == pytest.approx(4.8)


@pytest.mark.parametrize(
    ("pose", "hit"),
    [
        ((0.0, 0.0, 0.0), False),
        ((1.49, 0.0, 0.0), False),  # front face at 1.99 m
        ((1.51, 0.0, 0.0), True),  # front face at 2.01 m: through the wall
        ((1.74, 0.0, math.pi / 2), False),  # turned: the side at 1.99 m
        ((1.76, 0.0, math.pi / 2), True),
        ((3.5, 0.0, 0.0), False),  # the box spans x 3.0..4.0: clear of the wall and of the pillar
        ((5.0, 0.0, 0.0), True),  # inside the pillar's outline: touches its sides
        ((5.0, 1.0, 0.0), False),  # beside the pillar
    ],
)
def test_known_geometry(pose, hit):
    c = WallCollider(BOX, WALLS)
    assert c.hits(pose) is hit
    assert WallCollider(BOX, WALLS).check(*pose) is hit


def test_no_walls_never_collides():
    assert WallCollider(BOX, np.zeros((0, 2, 2))).check(0.0, 0.0, 0.0) is False


def test_bad_footprint_raises():
    with pytest.raises(ValueError, match="footprint"):
        WallCollider([[0, 0], [1, 0]], WALLS)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3), st.floats(-0.5, 0.5)), min_size=1, max_size=40))
def test_prefilter_agrees_with_the_exact_test_along_any_walk(steps):
    """The cheap check (bounding circle + clearance memory) equals shapely's exact answer at every step."""
    c = WallCollider(BOX, WALLS)
    x, y, psi = 0.5, 0.0, 0.0
    for dx, dy, dpsi in steps:
        x, y, psi = x + dx, y + dy, psi + dpsi
        assert c.check(x, y, psi) is c.hits((x, y, psi))


class _Plant:
    def __init__(self):
        self.pose = np.array([0.0, 0.0, 0.0])
        self.signal_names = ("x",)
        self.own = None

    def advance(self, command, t0, dt, rng):
        self.pose = self.pose + np.array([command[0] * dt, 0.0, 0.0])

    def pose_at(self, t):
        return np.tile(self.pose, (len(t), 1))

    def odometry(self):
        return 0.0, 0.0, 0.0

    def signals(self):
        return (float(self.pose[0]),)

    def failure(self):
        return self.own


def test_watch_reports_collision_and_keeps_the_plants_own_failure():
    plant = _Plant()
    w = CollisionWatch(plant, WallCollider(BOX, WALLS))
    steps = 0
    while w.failure() is None:
        w.advance((1.0,), 0.0, 0.05, None)
        steps += 1
    assert w.failure() == "collision" and 1.5 - 1e-9 <= plant.pose[0] <= 1.55  # the front face reached x = 2
    plant.own = "jackknife"
    assert w.failure() == "jackknife"
    assert w.signals() == (plant.pose[0],) and w.signal_names == ("x",)
