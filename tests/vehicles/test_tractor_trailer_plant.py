"""The tractor-trailer plant: hitch-angle dynamics against seed 003 §3.2.7, analytic cases, jackknife."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _plants import differential, drive, tractor_trailer
from hypothesis import given
from hypothesis import strategies as st

from agvnav.kinematics import TractorTrailer
from agvnav.vehicles import TractorTrailerPlant
from agvnav.vehicles.tractor_trailer import hitch_rate

R, B = 0.1, 0.5


@given(st.floats(-1.4, 1.4), st.floats(-2, 2), st.floats(-2, 2), st.floats(0.3, 3.0), st.floats(0.0, 1.0))
def test_hitch_rate_is_the_seed_model_without_skid(phi: float, v: float, w: float, D: float, d: float) -> None:
    ref = TractorTrailer(D, d).derivative_unchecked([0.0, 0.0, 0.0, phi], [v, w])[3]
    assert hitch_rate(phi, v, 0.0, w, D, d) == pytest.approx(float(ref), abs=1e-12)


@given(st.floats(-1.4, 1.4), st.floats(-2, 2), st.floats(-2, 2), st.floats(-2, 2), st.floats(0.0, 1.0))
def test_hitch_rate_keeps_the_trailer_axle_from_sliding(phi: float, vx: float, vy: float, w: float, d: float) -> None:
    """With a sideways tractor velocity too: the trailer axle midpoint moves along the trailer heading."""
    D = 1.2
    th_t = -phi  # tractor heading 0
    rate_t = w - hitch_rate(phi, vx, vy, w, D, d)
    hitch_v = np.array([vx, vy - d * w])
    axle_v = hitch_v + D * rate_t * np.array([math.sin(th_t), -math.cos(th_t)])
    normal = np.array([-math.sin(th_t), math.cos(th_t)])
    assert float(axle_v @ normal) == pytest.approx(0.0, abs=1e-12)


def test_straight_line_straightens_the_trailer_as_predicted() -> None:
    """On-axle hitch, straight forward: tan(phi/2) = tan(phi0/2) exp(-s / D) (seed 003 §3.2.7 with omega = 0)."""
    plant = tractor_trailer(phi0=0.5, hitch_offset=0.0)
    drive(plant, (3.0, 3.0), 100)
    s = plant.tractor.distance
    expected = 2.0 * math.atan(math.tan(0.25) * math.exp(-s / 1.2))
    assert plant.hitch_angle == pytest.approx(expected, abs=1e-9)
    sig = dict(zip(plant.signal_names, plant.signals(), strict=True))
    tp = TractorTrailer(1.2, 0.0).trailer_pose(np.append(plant.pose, plant.hitch_angle))
    np.testing.assert_allclose([sig["x_trailer"], sig["y_trailer"], sig["psi_trailer"]], tp, atol=1e-15)
    assert sig["hitch_angle"] == plant.hitch_angle and plant.failure() is None


def test_steady_turn_settles_at_the_equilibrium_hitch_angle() -> None:
    plant = tractor_trailer(hitch_offset=0.3)
    drive(plant, (3.0, 2.7), 1200)  # 60 s on the 4.75 m circle: 14 time constants D / v
    curvature = 2.0 / B * (3.0 - 2.7) / (3.0 + 2.7)
    expected = float(TractorTrailer(1.2, 0.3).equilibrium_hitch_angle(curvature))
    assert plant.hitch_angle == pytest.approx(expected, abs=1e-5)


def test_reversing_jackknifes_and_the_failure_latches() -> None:
    plant = tractor_trailer(phi0=0.05)
    for k in range(400):
        drive(plant, (-3.0, -3.0), 1, t0=0.05 * k)
        if plant.failure() is not None:
            break
    assert plant.failure() == "jackknife"
    assert plant.max_hitch_angle_seen >= math.radians(60.0)
    drive(plant, (3.0, 3.0), 200, t0=30.0)  # straightening again does not undo a failure
    assert abs(plant.hitch_angle) < math.radians(60.0) and plant.failure() == "jackknife"


def test_odometry_pose_and_geometry_are_the_tractors() -> None:
    plant = tractor_trailer()
    twin = differential()
    drive(plant, (3.0, 2.0), 20)
    drive(twin, (3.0, 2.0), 20)
    assert plant.odometry() == twin.odometry()
    np.testing.assert_array_equal(plant.pose, twin.pose)
    np.testing.assert_array_equal(plant.pose_at(np.array([0.96])), twin.pose_at(np.array([0.96])))
    assert plant.geometry == twin.geometry and plant.signal_names[-4:] == (
        "hitch_angle", "x_trailer", "y_trailer", "psi_trailer")


@pytest.mark.parametrize("phi0", [math.radians(60.0), float("nan"), -2.0])
def test_bad_initial_hitch_angle(phi0: float) -> None:
    with pytest.raises(ValueError, match="initial_hitch_angle"):
        TractorTrailerPlant(differential(), TractorTrailer(1.2, 0.3, math.radians(60.0)), phi0)
