"""The plant's and the autopilot's scalar fast paths equal the package kernels they mirror."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.guidance.paths import path_from_moves
from agvnav.sim.tricycle import TricycleAutopilot


def test_autopilot_direction_equals_path_direction_at() -> None:
    path = path_from_moves(
        [0.0, 0.0, 0.0], [("line", 1.0), ("arc", 2.0, 0.5, -1), ("line", 0.5), ("line", 1.5, -1), ("arc", 1.0, -0.3)]
    )
    pilot = TricycleAutopilot(controller=None, path=path, profile=None, wheelbase=1.0)
    starts = path.segment_starts
    probes = np.concatenate([np.linspace(-1.0, path.length + 1.0, 401), starts, np.nextafter(starts, -np.inf)])
    for s in probes:
        assert pilot._direction(float(s)) == int(path.direction_at(s)), s


def test_scalar_pose_at_is_bit_identical_to_the_vectorised_branch(short_scenario) -> None:
    from agvnav.sim.build import build

    built = build(short_scenario)
    built.loop.run(1.0)
    plant = built.loop.plant
    t = plant._t0 + plant._dt * np.array([-0.1, 0.0, 0.37, 0.5, 0.91, 1.0, 1.2])
    ref = plant.pose_at(np.concatenate([t, t]))  # > 4 instants: the vectorised branch
    for k in range(1, 5):
        np.testing.assert_array_equal(plant.pose_at(t[:k]), ref[:k])
    np.testing.assert_array_equal(plant.pose_at(t[3:7]), ref[3:7])
