"""Shared model fixtures: one instance of every configuration with a state/input sampler."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.kinematics import (
    Ackermann,
    AckermannSimple,
    DifferentialDrive,
    MecanumBase,
    TrackedVehicle,
    TrackTerrain,
    TractorTrailer,
    TricycleRearDrive,
    TricycleRearDriveSimple,
    TricycleStacker,
    TricycleStackerSimple,
)

MODELS = {
    "differential": lambda: DifferentialDrive(track=0.5, wheel_radius=0.1),
    "stacker": lambda: TricycleStacker(wheelbase=1.3, max_steer_rate=1.0),
    "stacker_simple": lambda: TricycleStackerSimple(wheelbase=1.3),
    "rear_drive": lambda: TricycleRearDrive(wheelbase=1.0, max_steer=np.deg2rad(60)),
    "rear_drive_simple": lambda: TricycleRearDriveSimple(wheelbase=1.0, max_steer=np.deg2rad(60)),
    "ackermann": lambda: Ackermann(wheelbase=2.5, track=1.5),
    "ackermann_simple": lambda: AckermannSimple(wheelbase=2.5, track=1.5),
    "tractor_trailer": lambda: TractorTrailer(trailer_length=2.0, hitch_offset=0.5),
    "mecanum_x": lambda: MecanumBase(wheel_radius=0.05, half_length=0.3, half_width=0.25, layout="X"),
    "tracked": lambda: TrackedVehicle(gauge=0.35, terrain=TrackTerrain(0.03, 0.05, 1.2, 1.3, 0.02)),
}


def sample(model, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """States and inputs well inside the model's limits."""
    state = rng.uniform(-2.0, 2.0, size=(n, model.n_state))
    u = rng.uniform(-1.0, 1.0, size=(n, model.n_input))
    names = model.state_names + model.input_names
    for k, name in enumerate(names):
        if name in ("gamma", "phi") or "steer" in name:
            arr = state if k < model.n_state else u
            arr[:, k if k < model.n_state else k - model.n_state] = rng.uniform(-0.6, 0.6, n)
    return state, u


@pytest.fixture
def sampler():
    """The ``sample`` function, for tests that need states and inputs."""
    return sample


@pytest.fixture(params=sorted(MODELS))
def model(request):
    return MODELS[request.param]()
