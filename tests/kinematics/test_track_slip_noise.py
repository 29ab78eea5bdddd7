"""Random track slip (TrackSlipNoise) and the tracked-base scalar twist against the kernels."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.kinematics import TrackedVehicle, TrackSlipNoise
from agvnav.kinematics.scalar import track_twist


@given(st.floats(0.0, 2.0), st.floats(0.0, 0.05), st.integers(0, 2**32 - 1))
def test_factors_scalar_equals_vectorised_factors(distance, std, seed):
    noise = TrackSlipNoise(std)
    a, b = np.random.default_rng(seed), np.random.default_rng(seed)
    vec = noise.factors(distance, a)
    assert vec.shape == (2,)
    np.testing.assert_allclose(noise.factors_scalar(distance, b), vec, rtol=1e-15, atol=0)
    assert a.random() == b.random()  # same draws


def test_ground_distance_error_is_std_per_metre_whatever_the_step():
    noise = TrackSlipNoise(0.003)
    rng = np.random.default_rng(0)
    for step in (0.01, 0.25):  # m rolled per step; 1 m in total
        n = round(1.0 / step)
        f = noise.factors(np.full((20000, n), step), rng)  # (runs, steps, 2)
        err = ((f - 1.0) * step).sum(axis=1)  # ground minus rolled distance after 1 m, per track
        assert np.std(err) == pytest.approx(0.003, rel=0.03)
        assert abs(np.corrcoef(err[:, 0], err[:, 1])[0, 1]) < 0.03  # independent tracks


def test_no_noise_draws_nothing_and_bad_std_is_refused():
    rng = np.random.default_rng(5)
    assert TrackSlipNoise().factors_scalar(0.1, rng) == (1.0, 1.0)
    np.testing.assert_array_equal(TrackSlipNoise().factors([0.1, 0.2], rng), np.ones((2, 2)))
    assert rng.random() == np.random.default_rng(5).random()
    assert TrackSlipNoise(0.01).factors_scalar(0.0, rng) == (1.0, 1.0)
    for bad in (-0.1, math.nan, math.inf):
        with pytest.raises(ValueError, match="slip noise std"):
            TrackSlipNoise(bad)


@given(st.floats(-2, 2), st.floats(-2, 2), st.sampled_from(["ideal", "concrete", "artificial_grass"]))
def test_track_twist_equals_body_twist(v_right, v_left, terrain):
    veh = TrackedVehicle(0.4, 0.05, terrain)
    T = veh.twist_matrix.tolist()
    np.testing.assert_allclose(track_twist(v_right, v_left, T), veh.body_twist([v_right, v_left]),
                               rtol=0, atol=1e-12)
