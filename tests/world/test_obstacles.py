"""Obstacles: schema, motion along waypoints, shapes, occlusion (issue 18)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError
from shapely.geometry import Point

from agvnav.world.obstacles import Obstacle, ObstacleSet, ObstacleSpec, ReactiveSpec, obstacle_from_spec


def test_moving_obstacle_waits_walks_and_stops():
    ob = Obstacle("p", "cylinder", (0.25,), np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 4.0]]), speed=1.0, start=2.0)
    pose = ob.pose_at(np.array([0.0, 2.0, 3.0, 5.0, 7.0, 100.0]))
    assert pose[:, :2] == pytest.approx(np.array([[0, 0], [0, 0], [1, 0], [3, 0], [3, 2], [3, 4]]), abs=1e-12)
    assert ob.centre_at(7.0) == pytest.approx((3.0, 2.0))
    assert not ob.static


def test_moving_box_faces_its_travel_and_static_box_its_heading():
    moving = Obstacle("cart", "box", (2.0, 1.0), np.array([[0.0, 0.0], [0.0, 5.0]]), speed=1.0)
    corners = moving.corners_at(1.0)
    assert corners[:, 1].max() - corners[:, 1].min() == pytest.approx(2.0)  # length along y
    static = Obstacle("pallet", "box", (1.2, 0.8), np.array([[5.0, 4.0]]), heading=math.pi / 2)
    assert static.shape_at(0.0).bounds == pytest.approx((4.6, 3.4, 5.4, 4.6))


def test_distance_is_exact_for_cylinders_and_boxes():
    cyl = Obstacle("c", "cylinder", (0.5,), np.array([[3.0, 0.0]]))
    box = Obstacle("b", "box", (1.0, 1.0), np.array([[3.0, 0.0]]))
    assert cyl.distance(Point(0.0, 0.0), 0.0) == pytest.approx(2.5, abs=1e-12)
    assert box.distance(Point(0.0, 0.0), 0.0) == pytest.approx(2.5, abs=1e-12)
    assert cyl.distance(Point(3.2, 0.0), 0.0) == 0.0


def test_set_blocks_line_of_sight_and_batches_geometry():
    obs = ObstacleSet((Obstacle("c", "cylinder", (0.3,), np.array([[5.0, 0.0]])),
                       Obstacle("b", "box", (1.0, 1.0), np.array([[0.0, 5.0]]))))
    assert obs.blocks([0.0, 0.0], [10.0, 0.0], 0.0)
    assert not obs.blocks([0.0, 0.0], [10.0, 1.0], 0.0)  # passes 0.5 m beside the cylinder... and misses the box
    assert obs.blocks([-2.0, 5.0], [2.0, 5.0], 0.0)
    segs, owner = obs.segments_at(0.0)
    circles, c_owner = obs.circles_at(0.0)
    assert segs.shape == (4, 2, 2) and list(owner) == [1, 1, 1, 1]
    assert circles == pytest.approx(np.array([[5.0, 0.0, 0.3]])) and list(c_owner) == [0]
    body = np.array([[0.5, -0.5], [0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5]])
    exact = obs.clearances([0.0, 0.0, 0.0], body, 0.0, exact_within=10.0)
    assert exact == pytest.approx([4.2, 4.0], abs=1e-9)
    bound = obs.clearances([0.0, 0.0, 0.0], body, 0.0)  # far: the cheap lower bound
    assert np.all(bound <= exact) and bound[0] == pytest.approx(5.0 - math.sqrt(0.5) - 0.3)


def test_spec_refuses_inconsistent_entries():
    with pytest.raises(ValidationError, match="either position"):
        ObstacleSpec(id="x", shape="cylinder", radius_m=0.2)
    with pytest.raises(ValidationError, match="needs radius_m"):
        ObstacleSpec(id="x", shape="cylinder", position=(0.0, 0.0))
    with pytest.raises(ValidationError, match="length_m and width_m"):
        ObstacleSpec(id="x", shape="box", length_m=1.0, position=(0.0, 0.0))
    with pytest.raises(ValidationError, match="warning_length_m"):
        ReactiveSpec(protective_length_m=2.0, warning_length_m=1.0)
    ob = obstacle_from_spec(ObstacleSpec(id="p", shape="cylinder", radius_m=0.25, path=[(0, 0), (0, 2)],
                                         speed_m_s=0.5, start_s=1.0))
    assert ob.centre_at(3.0) == pytest.approx((0.0, 1.0))


def test_duplicate_ids_are_refused():
    a = Obstacle("a", "cylinder", (0.3,), np.array([[0.0, 0.0]]))
    with pytest.raises(ValueError, match="unique"):
        ObstacleSet((a, a))
