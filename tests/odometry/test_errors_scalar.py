"""Scalar fast paths of the non-systematic error model against the vectorised ``perturb``."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.odometry import NonSystematicErrors, TricycleErrors, TrueTricycleVehicle


@given(
    d=st.floats(-2.0, 2.0).filter(lambda v: abs(v) > 1e-9),
    slip_k=st.floats(1e-8, 1e-2),
    bump_rate=st.sampled_from([0.0, 0.5, 20.0]),
    seed=st.integers(0, 2**32 - 1),
)
def test_perturb_scalar_equals_vectorised_perturb(d, slip_k, bump_rate, seed):
    ns = NonSystematicErrors(slip_k=slip_k, bump_rate=bump_rate, bump_loss=0.01)
    a, b = np.random.default_rng(seed), np.random.default_rng(seed)
    vec = float(ns.perturb(np.array([d]), a)[0])
    assert ns.perturb_scalar(d, b) == pytest.approx(vec, rel=1e-12, abs=1e-15)
    assert a.random() == b.random()  # same number of draws: the streams stay aligned


def test_perturb_scalar_applies_a_standard_deviation_bit_for_bit_and_skips_idle_draws():
    s, d = 0.0123, 0.04
    z = float(np.random.default_rng(9).standard_normal())
    got = NonSystematicErrors(slip_k=s**2).perturb_scalar(d, np.random.default_rng(9))
    assert got == d + s * math.sqrt(abs(d)) * z
    rng = np.random.default_rng(4)
    assert NonSystematicErrors(slip_k=1e-3, bump_rate=1.0).perturb_scalar(0.0, rng) == 0.0
    assert NonSystematicErrors().perturb_scalar(0.3, rng) == 0.3
    assert rng.random() == np.random.default_rng(4).random()  # nothing was drawn


def test_perturb_scalar_slip_variance_grows_with_distance():
    ns = NonSystematicErrors(slip_k=1e-4)
    rng = np.random.default_rng(2)
    out = np.array([ns.perturb_scalar(2.0, rng) for _ in range(20000)])
    assert np.var(out) == pytest.approx(2e-4, rel=0.05)


def test_steering_noise_scalar_is_seeded_gaussian():
    ns = NonSystematicErrors(steering_std=0.01)
    rng = np.random.default_rng(3)
    g = np.array([ns.perturb_steering_scalar(0.2, rng) for _ in range(20000)])
    assert np.mean(g) == pytest.approx(0.2, abs=3e-4)
    assert np.std(g) == pytest.approx(0.01, rel=0.03)
    assert NonSystematicErrors().perturb_steering_scalar(0.2, rng) == 0.2
    with pytest.raises(ValueError, match="steering_std"):
        NonSystematicErrors(steering_std=-1.0)


def test_tricycle_steering_offset_turns_the_true_wheel():
    off = math.radians(1.0)
    with pytest.raises(ValueError, match="steering_offset"):
        TricycleErrors(steering_offset=math.nan)
    truth = TrueTricycleVehicle(1.3, 0.125, TricycleErrors(steering_offset=off))
    end = truth.advance(np.zeros(3), 8.0, 0.0)  # 1 m of the traction wheel, encoder reads straight
    assert end[2] == pytest.approx(math.sin(off) / 1.3)
