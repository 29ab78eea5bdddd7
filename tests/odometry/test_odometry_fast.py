"""The odometry's scalar fast paths equal the vectorised kernels / vehicle models they mirror."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.kinematics.tracked import TrackedVehicle, TrackTerrain
from agvnav.odometry import differential_increments, tricycle_increments
from agvnav.odometry.scalar import track_increments, tricycle_increments_scalar


@given(st.floats(-0.1, 0.1), st.floats(-1.5707, 1.5707))
def test_tricycle_increments_scalar_equals_kernel(ds: float, gamma: float) -> None:
    ref = tricycle_increments(ds, gamma, 1.3)
    got = tricycle_increments_scalar(ds, gamma, 1.3)
    np.testing.assert_allclose(got, [float(ref[0]), float(ref[1])], rtol=1e-15, atol=1e-18)


@pytest.mark.parametrize("ds, gamma", [(0.01, 0.5 * math.pi), (0.01, -2.0), (math.nan, 0.1), (0.01, math.nan)])
def test_tricycle_increments_scalar_refuses_like_kernel(ds: float, gamma: float) -> None:
    with pytest.raises(ValueError):
        tricycle_increments(ds, gamma, 1.3)
    with pytest.raises(ValueError):
        tricycle_increments_scalar(ds, gamma, 1.3)


@given(st.floats(-0.2, 0.2), st.floats(-0.2, 0.2), st.sampled_from(["concrete", "artificial_grass", "ideal"]))
def test_track_increments_equal_body_twist_of_the_model(dr: float, dl: float, terrain: str) -> None:
    veh = TrackedVehicle(0.33, 0.05, terrain)
    twist = veh.body_twist(np.array([dr, dl]))  # twist over a unit time = displacement of the step
    got = track_increments(dr, dl, veh.twist_matrix.tolist())
    np.testing.assert_allclose(got, [twist[0], twist[2]], rtol=0, atol=1e-12)


@given(st.floats(-0.2, 0.2), st.floats(-0.2, 0.2))
def test_track_increments_without_slip_are_seed_002_eq_16(dr: float, dl: float) -> None:
    veh = TrackedVehicle(0.33, 0.05, TrackTerrain(slip_left=0.0, slip_right=0.0, icr_left=1.0, icr_right=1.0))
    ref = differential_increments(dr, dl, 0.33)
    np.testing.assert_allclose(track_increments(dr, dl, veh.twist_matrix.tolist()), [ref[0], ref[1]], atol=1e-12)
