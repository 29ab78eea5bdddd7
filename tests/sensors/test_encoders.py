"""Wheel and steering encoders: quantisation and conversions."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.sensors.encoders import SteeringEncoder, WheelEncoder


@given(phi0=st.floats(-100, 100), dphi=st.floats(-10, 10))
def test_increment_error_is_below_one_count(phi0, dphi):
    enc = WheelEncoder(500, 0.08, gear_ratio=3.0)
    n = enc.counts(phi0 + dphi) - enc.counts(phi0)
    assert abs(enc.distance(n) - dphi * 0.08) <= enc.distance_resolution * (1 + 1e-9)


def test_resolution_and_round_trip():
    enc = WheelEncoder(1024, 0.1, gear_ratio=2.0)
    assert enc.angle_resolution == pytest.approx(2 * np.pi / 2048)
    assert enc.distance_resolution == pytest.approx(2 * np.pi * 0.1 / 2048)
    assert enc.counts(2 * np.pi) == 2048
    d = np.linspace(-3, 3, 101)
    err = enc.distance(enc.counts_for_distance(d)) - d
    assert np.all((err <= 1e-12) & (err > -enc.distance_resolution))
    assert enc.quantisation_std() == pytest.approx(enc.distance_resolution / np.sqrt(12))


def test_steering_encoder_rounds_and_carries_offset():
    enc = SteeringEncoder(4096)
    g = np.linspace(-1.5, 1.5, 77)
    assert np.max(np.abs(enc.angle(enc.counts(g)) - g)) <= enc.resolution / 2 + 1e-12
    biased = SteeringEncoder(4096, offset=0.01)
    assert biased.angle(biased.counts(0.0)) == pytest.approx(-0.01, abs=enc.resolution)


@pytest.mark.parametrize("cpr", [0, -5, 2.5, True])
def test_bad_counts_per_rev(cpr):
    with pytest.raises(ValueError, match="counts_per_rev"):
        WheelEncoder(cpr, 0.1)


def test_bad_values_named():
    with pytest.raises(ValueError, match="wheel_radius"):
        WheelEncoder(100, -0.1)
    with pytest.raises(ValueError, match="wheel_angle"):
        WheelEncoder(100, 0.1).counts(np.nan)
    with pytest.raises(ValueError, match="steering_angle"):
        SteeringEncoder(100).counts([0.0, np.inf])
