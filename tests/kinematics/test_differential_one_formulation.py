"""Every differential-drive site computes through kinematics.differential (issue 10, one formulation).

``v = (v_R + v_L)/2``, ``ω = (v_R − v_L)/L`` and the inverse ``v_R,L = v ± ωL/2``
([seed002 eq4], [seed002 eq6], [seed004 eq1], [seed004 eq2], [seed002 eq16]) are checked
once against hand-written ground truth, then every other site is checked against them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.actuators import DriveGeometry, unicycle_to_wheels, wheels_to_unicycle
from agvnav.kinematics import (
    DifferentialDrive,
    TrackedVehicle,
    body_speeds,
    body_speeds_unchecked,
    body_twist_matrix,
    wheel_speeds,
    wheel_speeds_unchecked,
)
from agvnav.kinematics.scalar import track_twist
from agvnav.odometry import differential_increments, differential_wheel_distances
from agvnav.odometry.scalar import differential_increments_scalar, track_increments

speed = st.floats(-3.0, 3.0)
track = st.floats(0.05, 2.0)
radius = st.floats(0.01, 0.5)


def test_analytic_cases() -> None:
    # spin in place: wheels opposite, v = 0, ω = 2 v_R / L
    assert body_speeds_unchecked(0.5, -0.5, 0.4) == (0.0, 2.5)
    # straight: equal wheels
    assert body_speeds_unchecked(1.2, 1.2, 0.4) == (1.2, 0.0)
    # pivot on the left wheel: v_L = 0, the midpoint moves at v_R/2 on a radius L/2
    v, w = body_speeds_unchecked(1.0, 0.0, 0.5)
    assert (v, w) == (0.5, 2.0) and v / w == pytest.approx(0.25)
    assert wheel_speeds_unchecked(0.5, 2.0, 0.5) == (1.0, 0.0)


@given(speed, speed, track)
def test_round_trip_and_checked_equals_unchecked(vr: float, vl: float, b: float) -> None:
    v, w = body_speeds_unchecked(vr, vl, b)
    assert isinstance(v, float) and isinstance(w, float)  # the hot-loop form stays in floats
    back = wheel_speeds_unchecked(v, w, b)
    np.testing.assert_allclose(back, [vr, vl], rtol=0, atol=1e-12)
    assert tuple(map(float, body_speeds(vr, vl, b))) == (v, w)
    assert tuple(map(float, wheel_speeds(v, w, b))) == back


@given(speed, st.floats(-5.0, 5.0), radius, track)
def test_actuators_are_seed_004_eqs_1_2_bit_for_bit(v: float, w: float, r: float, b: float) -> None:
    # seed 004 eqs 1-2 as printed: ω_R = (2V + ωL)/(2r), ω_L = (2V − ωL)/(2r)
    seed = [(2.0 * v + w * b) / (2.0 * r), (2.0 * v - w * b) / (2.0 * r)]
    got = unicycle_to_wheels(v, w, r, b)
    assert got.tolist() == seed  # the rewrite through wheel_speeds_unchecked changed no bit
    assert DriveGeometry(r, b).to_wheels(v, w).tolist() == seed
    v2, w2 = wheels_to_unicycle(got, r, b)
    np.testing.assert_allclose([v2, w2], [v, w], rtol=0, atol=1e-12)


def test_drive_geometry_track_and_former_name() -> None:
    g = DriveGeometry(0.05, 0.33)
    assert g.track == g.track_width == 0.33
    with pytest.raises(ValueError, match="track"):
        DriveGeometry(0.05, 0.0)


@given(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), track)
def test_odometry_increments_are_body_speeds_on_distances(dr: float, dl: float, b: float) -> None:
    ref = body_speeds_unchecked(dr, dl, b)
    assert tuple(map(float, differential_increments(dr, dl, b))) == ref
    assert differential_increments_scalar(dr, dl, b) == ref
    np.testing.assert_allclose(differential_wheel_distances(*ref, b), [dr, dl], rtol=0, atol=1e-12)
    # the tracked ICR model with ideal tracks is the same equation
    ideal = TrackedVehicle(b, 0.05, "ideal")
    np.testing.assert_allclose(track_increments(dr, dl, ideal.twist_matrix.tolist()), ref, rtol=0, atol=1e-12)


@given(speed, st.floats(-5.0, 5.0), track)
def test_models_use_the_one_formulation(v: float, w: float, b: float) -> None:
    ref = np.array(wheel_speeds_unchecked(v, w, b))
    assert TrackedVehicle(b, 0.05, "ideal").track_speeds(v, w, compensate=False).tolist() == ref.tolist()
    assert DifferentialDrive(b).wheel_speeds([v, w]).tolist() == ref.tolist()
    np.testing.assert_allclose(DifferentialDrive(b).input_from_wheel_speeds(ref), [v, w], rtol=0, atol=1e-12)


def test_arrays_broadcast() -> None:
    vr, vl = wheel_speeds_unchecked(np.array([0.0, 1.0]), np.array([1.0, 0.0]), 0.5)
    np.testing.assert_array_equal(vr, [0.25, 1.0])
    np.testing.assert_array_equal(vl, [-0.25, 1.0])


@pytest.mark.parametrize(
    ("args", "word"),
    [((0.1, 0.2, 0.0), "track"), ((0.1, math.nan, 0.5), "d_right, d_left"), ((0.1, 0.2, math.inf), "track")],
)
def test_scalar_increments_refuse_bad_input(args: tuple[float, float, float], word: str) -> None:
    with pytest.raises(ValueError, match=word):
        differential_increments_scalar(*args)


def test_wheel_distances_refuse_bad_track() -> None:
    with pytest.raises(ValueError, match="track"):
        differential_wheel_distances(0.1, 0.2, -1.0)


def test_tracked_vehicle_track_and_former_gauge_keyword() -> None:
    by_track, by_gauge = TrackedVehicle(track=0.4), TrackedVehicle(gauge=0.4)
    assert by_track.track == by_gauge.track == by_gauge.gauge == 0.4
    np.testing.assert_array_equal(by_track.twist_matrix, by_gauge.twist_matrix)
    with pytest.raises(ValueError, match="track"):
        TrackedVehicle()
    with pytest.raises(ValueError, match="track"):
        TrackedVehicle(track=0.4, gauge=0.4)
    with pytest.raises(ValueError, match="track"):
        TrackedVehicle(gauge=-1.0)


@given(speed, speed, track)
def test_twist_matrix_is_body_speeds_in_matrix_form(vr: float, vl: float, b: float) -> None:
    m = body_twist_matrix(b)
    v, w = body_speeds_unchecked(vr, vl, b)
    np.testing.assert_allclose(track_twist(vr, vl, m), [v, 0.0, w], rtol=0, atol=1e-12)
    np.testing.assert_allclose(m, TrackedVehicle(b, 0.05, "ideal").twist_matrix, rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="track"):
        body_twist_matrix(0.0)
