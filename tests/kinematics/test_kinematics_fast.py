"""The kinematics' scalar fast paths equal the vectorised kernels they mirror (to 1e-12)."""

from __future__ import annotations

import numpy as np

from agvnav.kinematics import TricycleStacker
from agvnav.kinematics.scalar import stacker_rk4


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

