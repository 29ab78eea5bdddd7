"""The spot-turn lever of fine positioning (issue 14 review): the traction limit over it is the turn acceleration."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.kinematics import MecanumBase
from agvnav.navigation.fine_positioning import spot_turn_lever
from agvnav.vehicles import HolonomicGeometry, SteeredGeometry, UnicycleGeometry


def test_differential_turns_on_half_its_track() -> None:
    assert spot_turn_lever(UnicycleGeometry(0.6, 0.1)) == pytest.approx(0.3)


@pytest.mark.parametrize(("layout", "lever"), [("X", 0.55), ("O", 0.05)])
def test_mecanum_lever_is_the_wheel_speed_per_yaw_rate(layout: str, lever: float) -> None:
    # a = 0.3, b = 0.25: X needs a + b = 0.55 m per rad (hypot(a, b) = 0.39 m would overstate the
    # spot-turn acceleration by 41 %), O |a - b| = 0.05 m
    g = HolonomicGeometry(0.05, 0.3, 0.25)
    assert spot_turn_lever(g, layout) == pytest.approx(lever)
    base = MecanumBase(0.05, 0.3, 0.25, layout)  # the kinematics: wheel ground speeds of a pure 1 rad/s yaw
    ground = np.abs(base.wheel_rates(np.array([0.0, 0.0, 1.0]))) * base.wheel_radius
    np.testing.assert_allclose(ground, lever, rtol=1e-12)


def test_no_lever_without_a_spot_turn() -> None:
    with pytest.raises(ValueError, match="SteeredGeometry"):
        spot_turn_lever(SteeredGeometry(1.2, "C", math.radians(80.0)))
    with pytest.raises(ValueError, match="layout 'O'"):
        spot_turn_lever(HolonomicGeometry(0.05, 0.3, 0.3), "O")  # a square O base cannot yaw
    with pytest.raises(ValueError, match="layout 'Y'"):
        spot_turn_lever(HolonomicGeometry(0.05, 0.3, 0.25), "Y")
