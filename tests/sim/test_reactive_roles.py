"""The reactive wiring roles (issue 18): obstacles occlude the goniometer, collide, and are scanned at their instant."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.navigation.reactive import ReactiveInputs, ReactiveWatch
from agvnav.sensors.goniometer import Goniometer
from agvnav.sensors.scanner import SafetyScanner
from agvnav.sim.reactive import ObstacleCollisionWatch, OccludedReflections, ScannerRole
from agvnav.sim.roles import GoniometerSensor
from agvnav.world import Reflector, WorldMap
from agvnav.world.obstacles import Obstacle, ObstacleSet


def _still(pose):
    return lambda t: np.tile(np.asarray(pose, dtype=np.float64), (np.size(t), 1))


def test_an_obstacle_hides_the_reflector_behind_it_only():
    world = WorldMap(reflectors=(Reflector("A", 5.0, 0.0, 0.04), Reflector("B", 0.0, 5.0, 0.04),
                                 Reflector("C", -5.0, 0.0, 0.04)), walls=())
    role = GoniometerSensor(Goniometer(rate_hz=8.0), world, None)
    rng = np.random.default_rng(0)
    seen = role.observe(_still([0.0, 0.0, 0.0]), 0.0, 1.0, rng)
    assert set(seen[:, 2].astype(int)) == {0, 1, 2}
    person = ObstacleSet((Obstacle("p", "cylinder", (0.3,), np.array([[2.5, 0.0]])),))
    occl = OccludedReflections(role, person, world.reflector_xy, (0.0, 0.0, 0.0))
    ev = occl.observe(_still([0.0, 0.0, 0.0]), 0.0, 1.0, np.random.default_rng(0))
    assert set(ev[:, 2].astype(int)) == {1, 2}
    assert occl.n_occluded == int(np.sum(seen[:, 2] == 0))


class _Plant:
    footprint = np.array([[0.5, -0.3], [0.5, 0.3], [-0.5, 0.3], [-0.5, -0.3]])
    signal_names = ("x",)

    def __init__(self):
        self.pose = np.array([0.0, 0.0, 0.0])

    def advance(self, command, t0, dt, rng):
        self.pose = self.pose + np.array([command[0] * dt, 0.0, 0.0])

    def pose_at(self, t):
        return np.tile(self.pose, (np.size(t), 1))

    def odometry(self):
        return 0.0, 0.0, 0.0

    def failure(self):
        return None

    def signals(self):
        return (float(self.pose[0]),)


def test_collision_with_a_moving_obstacle_at_its_instant():
    # a cart crossing x = 1.0 from below, reaching y = 0 at t = 2 s
    cart = ObstacleSet((Obstacle("cart", "box", (0.4, 0.4), np.array([[1.0, -2.0], [1.0, 2.0]]), speed=1.0),))
    watch = ObstacleCollisionWatch(_Plant(), cart)
    rng = np.random.default_rng(0)
    watch.advance((0.3, 0.0), 0.0, 1.0, rng)  # x = 0.3 at t = 1: cart at y = -1, clear
    assert watch.failure() is None
    watch.advance((0.0, 0.0), 1.0, 1.0, rng)  # t = 2: the cart at y = 0 overlaps the front (x up to 0.8)
    assert watch.failure() == "collision" and watch.hit == 0


def test_scanner_role_sees_the_obstacle_where_it_is_at_the_scan():
    person = ObstacleSet((Obstacle("p", "cylinder", (0.25,), np.array([[3.0, -2.0], [3.0, 2.0]]), speed=1.0),))
    inputs = ReactiveInputs()
    role = ScannerRole(SafetyScanner(fov=math.radians(90.0), step=math.radians(0.25), noise_std=0.0, rate_hz=10.0),
                       np.zeros((0, 2, 2)), person, inputs)
    rows = role.observe(_still([0.0, 0.0, 0.0]), 1.9, 2.0, np.random.default_rng(0))
    assert rows.shape == (1, 3) and rows[0, 0] == pytest.approx(2.0)
    assert rows[0, 1] == pytest.approx(2.75, abs=1e-6) and rows[0, 2] == 0.0  # the person is at (3, 0) at t = 2
    assert inputs.t == pytest.approx(2.0) and np.all(inputs.owner == 0)
    assert np.all(np.abs(inputs.points[:, 1]) < 0.3)


def test_reactive_watch_takes_the_smaller_scale():
    class Guard:
        signal_names = ("guard_level",)

        def scale(self, t, estimator):
            return 0.3

        def signals(self):
            return (1.0,)

    w = ReactiveWatch(Guard(), ("p",))
    w.reactive_scale = 1.0
    assert w.scale(0.0, None) == 0.3
    w.reactive_scale = 0.0
    assert w.scale(0.0, None) == 0.0
    assert len(w.signals()) == len(w.signal_names)
