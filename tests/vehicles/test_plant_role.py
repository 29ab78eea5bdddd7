"""Every truth vehicle fulfils the engine's Plant role (docs/ARCHITECTURE.md, "One closed loop for every vehicle")."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from _plants import PLANTS

from agvnav.odometry import NonSystematicErrors
from agvnav.vehicles import HolonomicGeometry, SteeredGeometry, UnicycleGeometry

GEOMETRY = {"steered": SteeredGeometry, "unicycle": UnicycleGeometry, "holonomic": HolonomicGeometry}
FAMILY = {
    "tricycle": "steered", "tricycle_rear": "steered", "ackermann": "steered", "differential": "unicycle",
    "tracked": "unicycle", "tractor_trailer": "unicycle", "mecanum": "holonomic",
}


@pytest.mark.parametrize("name", sorted(PLANTS))
def test_role_members(name: str) -> None:
    factory, command = PLANTS[name]
    plant = factory()
    assert plant.family == FAMILY[name]
    assert isinstance(plant.geometry, GEOMETRY[plant.family])
    with pytest.raises(dataclasses.FrozenInstanceError):
        plant.geometry.__setattr__(dataclasses.fields(plant.geometry)[0].name, 1.0)
    assert plant.signal_names[:3] == ("x", "y", "psi")
    fp = np.asarray(plant.footprint)
    assert fp.ndim == 2 and fp.shape[1] == 2 and fp.shape[0] >= 3
    assert fp[:, 0].min() < 0.0 < fp[:, 0].max() and fp[:, 1].min() < 0.0 < fp[:, 1].max()  # base_link inside
    before = plant.pose.copy()
    plant.advance(command, 2.0, 0.05, np.random.default_rng(0))
    odo = plant.odometry()
    assert len(odo) == 3 and all(isinstance(v, float) for v in odo)
    sig = plant.signals()
    assert len(sig) == len(plant.signal_names)
    np.testing.assert_array_equal(np.asarray(sig[:3]), plant.pose)
    assert not np.allclose(plant.pose, before)
    ends = plant.pose_at(np.array([2.0, 2.05]))
    assert ends.shape == (2, 3)
    np.testing.assert_allclose(ends[0], before, atol=1e-12)
    np.testing.assert_allclose(ends[1], plant.pose, atol=1e-12)
    assert plant.failure() is None
    if plant.family == "steered":
        assert isinstance(plant.gamma_meas, float)


@pytest.mark.parametrize("name", sorted(PLANTS))
def test_same_seed_same_run_other_seed_differs(name: str) -> None:
    factory, command = PLANTS[name]
    noise = NonSystematicErrors(slip_k=1e-4)

    def run(seed: int) -> list[tuple[float, ...]]:
        # the tracked robot's random slip is its own TrackSlipNoise
        plant = factory(slip_noise_std=0.01) if name == "tracked" else factory(nonsystematic=noise)
        rng = np.random.default_rng(seed)
        out = []
        for k in range(40):
            plant.advance(command, 0.05 * k, 0.05, rng)
            out.append(plant.signals() + plant.odometry())
        return out

    a, b, c = run(3), run(3), run(4)
    assert a == b
    assert a != c
