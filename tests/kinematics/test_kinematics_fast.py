"""The kinematics' scalar fast paths equal the vectorised kernels they mirror (to 1e-12)."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from agvnav.kinematics import TricycleStacker, twist_step
from agvnav.kinematics.scalar import stacker_rk4, twist_pose


def test_scalar_stacker_step_matches_kinematics_package():
    model = TricycleStacker(1.1)
    model.substeps = 1
    rng = np.random.default_rng(3)
    for _ in range(50):
        x = np.array([*rng.normal(size=2), rng.uniform(-3, 3), rng.uniform(-1.4, 1.4)])
        v, gd = rng.normal(), rng.normal()
        new, der = stacker_rk4(x, v, gd, 1.1, 0.05)
        np.testing.assert_allclose(new, model.step(x, np.array([v, gd]), 0.05), rtol=0, atol=1e-12)
        np.testing.assert_allclose(der, model.derivative(np.stack([x, new]), np.array([v, gd])), atol=1e-12)


speed = st.floats(-3.0, 3.0)


@given(st.floats(-10, 10), st.floats(-10, 10), st.floats(-7, 7), speed, speed, st.floats(-5, 5), st.floats(1e-4, 0.2))
def test_twist_pose_equals_twist_step(x, y, th, vx, vy, w, h):
    ref = twist_step(np.array([x, y, th]), vx, vy, w, h)
    np.testing.assert_allclose(twist_pose(x, y, th, vx, vy, w, h), ref, rtol=0, atol=1e-12)


def test_twist_pose_straight_line_series_branch():
    # |w h / 2| < 1e-4 takes the series; it must still equal the kernel and the straight line
    got = twist_pose(1.0, 2.0, 0.3, 0.5, 0.0, 1e-6, 0.1)
    np.testing.assert_allclose(got, twist_step(np.array([1.0, 2.0, 0.3]), 0.5, 0.0, 1e-6, 0.1), atol=1e-15)
