"""The encoders' scalar fast paths equal the vectorised encoder methods they mirror."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.sensors.encoders import SteeringEncoder, WheelEncoder, steering_reading, wheel_count


@given(st.floats(-1e4, 1e4))
def test_wheel_count_equals_encoder(angle: float) -> None:
    enc = WheelEncoder(4096, 0.1)
    assert wheel_count(angle, enc.angle_resolution) == int(enc.counts(angle))


@given(st.floats(-1.6, 1.6), st.floats(-0.01, 0.01))
def test_steering_reading_equals_encoder(angle: float, offset: float) -> None:
    enc = SteeringEncoder(16384, offset=offset)
    assert steering_reading(angle, offset, enc.resolution) == float(enc.angle(enc.counts(angle)))


def test_encoder_fast_paths_refuse_nan() -> None:
    with pytest.raises(ValueError, match="wheel_angle"):
        wheel_count(math.nan, 0.001)
    with pytest.raises(ValueError, match="steering_angle"):
        steering_reading(math.inf, 0.0, 0.001)
