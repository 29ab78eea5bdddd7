"""Nominal geometry records and footprints of the plants."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from agvnav.vehicles import HolonomicGeometry, SteeredGeometry, UnicycleGeometry, box_footprint, check_footprint


def test_valid_records() -> None:
    g = SteeredGeometry(1.24, "C", math.pi / 2)
    assert (g.wheelbase, g.drive_point, g.max_steer) == (1.24, "C", math.pi / 2)
    assert UnicycleGeometry(0.5, 0.1).track == 0.5
    assert HolonomicGeometry(0.05, 0.3, 0.25).half_width == 0.25


@pytest.mark.parametrize(
    ("make", "word"),
    [
        (lambda: SteeredGeometry(0.0, "C", 1.0), "wheelbase"),
        (lambda: SteeredGeometry(1.0, "B", 1.0), "drive_point"),
        (lambda: SteeredGeometry(1.0, "O", 1.6), "max_steer"),
        (lambda: SteeredGeometry(1.0, "O", float("nan")), "max_steer"),
        (lambda: UnicycleGeometry(-0.5, 0.1), "track"),
        (lambda: UnicycleGeometry(0.5, float("inf")), "wheel_radius"),
        (lambda: HolonomicGeometry(0.05, 0.0, 0.2), "half_length"),
        (lambda: box_footprint(0.5, -0.5, 0.2), "front"),
        (lambda: box_footprint(0.5, 0.5, 0.0), "half_width"),
        (lambda: check_footprint([[0, 0], [1, 0]]), "footprint"),
        (lambda: check_footprint([[0, 0], [1, 0], [2, 0]]), "zero area"),
        (lambda: check_footprint([[0, 0], [1, 0], [0, float("nan")]]), "footprint"),
    ],
)
def test_bad_input(make, word: str) -> None:
    with pytest.raises(ValueError, match=word):
        make()


@given(st.floats(-1.0, 3.0), st.floats(-1.0, 3.0), st.floats(0.01, 2.0))
def test_box_is_counter_clockwise_with_the_expected_area(front: float, rear: float, half_width: float) -> None:
    assume(front + rear > 1e-6)
    poly = box_footprint(front, rear, half_width)
    x, y = poly[:, 0], poly[:, 1]
    area = 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    assert area == pytest.approx((front + rear) * 2 * half_width, rel=1e-12)
    np.testing.assert_array_equal(check_footprint(poly), poly)
