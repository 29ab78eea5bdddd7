"""The differential-drive plant: analytic motion, encoders vs truth, systematic drift, pose_at, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _plants import differential, drive, integrate_odometry
from hypothesis import given
from hypothesis import strategies as st

from agvnav.actuators import WheelSpeedLoop
from agvnav.kinematics import body_speeds, twist_step
from agvnav.odometry import DifferentialGeometry, NonSystematicErrors, SystematicErrors
from agvnav.sensors.encoders import WheelEncoder
from agvnav.vehicles import DifferentialPlant, UnicycleGeometry, WheelPairPlant
from agvnav.vehicles.motion import differential_twist_matrix

R, B = 0.1, 0.5
QUANTUM = 2 * math.pi / 100000 * R  # one encoder count of wheel travel (m)


@given(st.floats(-2, 2), st.floats(-2, 2), st.floats(0.1, 2.0))
def test_twist_matrix_is_the_differential_kinematics(v_r: float, v_l: float, track: float) -> None:
    t = differential_twist_matrix(track)
    v, w = body_speeds(v_r, v_l, track)
    assert t[0][0] * v_r + t[0][1] * v_l == pytest.approx(float(v), abs=1e-12)
    assert t[1][0] * v_r + t[1][1] * v_l == 0.0
    assert t[2][0] * v_r + t[2][1] * v_l == pytest.approx(float(w), abs=1e-12)


def test_straight_line_and_odometry_equal_truth() -> None:
    plant = differential()
    inc = drive(plant, (3.0, 3.0), 100)
    x = plant.pose
    assert x[1] == 0.0 and x[2] == 0.0
    assert plant.signals()[3] == pytest.approx(3.0, abs=1e-3)  # the PID reached the set-point
    assert sum(d for d, _, _ in inc) == pytest.approx(x[0], abs=QUANTUM)


def test_steady_turn_is_the_icr_circle() -> None:
    """Wheel rates w_R, w_L: radius (B/2)(w_R + w_L)/(w_R - w_L) about the ICR on the axle line [seed002 eq16]."""
    plant = differential()
    drive(plant, (3.0, 2.0), 100)  # settle
    radius = 0.5 * B * (3.0 + 2.0) / (3.0 - 2.0)
    centre = plant.pose[:2] + radius * np.array([-math.sin(plant.pose[2]), math.cos(plant.pose[2])])
    pts = []
    for k in range(40):
        drive(plant, (3.0, 2.0), 1, t0=5.0 + 0.05 * k)
        pts.append(plant.pose[:2].copy())
    np.testing.assert_allclose(np.linalg.norm(np.array(pts) - centre, axis=1), radius, atol=1e-4)
    assert plant.signals()[6] == pytest.approx(R * (3.0 - 2.0) / B, rel=1e-3)


def test_odometry_integrates_to_the_truth_without_errors() -> None:
    plant = differential(pose=(1.0, 2.0, 0.5))
    inc = drive(plant, (3.0, 1.0), 60) + drive(plant, (-1.0, 2.5), 60, t0=3.0)
    dead = integrate_odometry((1.0, 2.0, 0.5), inc)
    np.testing.assert_allclose(dead, plant.pose, atol=5e-4)


def test_wheel_diameter_ratio_drifts_as_predicted() -> None:
    """E_d: equal wheel rotations phi turn the true vehicle by (r_R - r_L) phi / (E_b B); the odometry sees 0."""
    errors = SystematicErrors(e_d=1.01)
    plant = differential(errors)
    inc = drive(plant, (3.0, 3.0), 200)
    true_geo = errors.true_geometry(DifferentialGeometry.symmetric(R, B))
    phi = sum(d[0] for d in inc) / R  # both wheels turned this much (rad), to within one count
    expected = (true_geo.radius_right - true_geo.radius_left) * phi / true_geo.track
    assert plant.pose[2] == pytest.approx(expected, rel=1e-4)
    assert abs(sum(d[1] for d in inc)) < 1e-9


def test_track_error_scales_the_heading_odometry() -> None:
    """E_b: an in-place turn's odometry heading is E_b times the true one."""
    plant = differential(SystematicErrors(e_b=1.05))
    inc = drive(plant, (2.0, -2.0), 100)
    assert sum(d[1] for d in inc) == pytest.approx(1.05 * plant.pose[2], rel=1e-4)


def test_misalignment_moves_sideways() -> None:
    m = math.radians(2.0)
    plant = differential(SystematicErrors(misalignment=m))
    drive(plant, (3.0, 3.0), 100)
    assert plant.pose[1] == pytest.approx(math.tan(m) * plant.pose[0], rel=1e-9)


def test_random_slip_has_the_seed_002_variance() -> None:
    """Per wheel, ground distance error variance slip_k |d| whatever the sub-step (seed 002 §3.1)."""
    k = 1e-4
    ends = []
    for seed in range(200):
        plant = differential(nonsystematic=NonSystematicErrors(slip_k=k))
        drive(plant, (3.0, 3.0), 40, seed=seed)
        ends.append(plant.pose[2])
    d = 0.05 * 40 * 3.0 * R * 0.97  # about the distance each wheel rolled (spin-up)
    predicted_std = math.sqrt(2 * k * d) / B
    assert np.std(ends) == pytest.approx(predicted_std, rel=0.25)


def test_pose_at_is_the_sub_step_exponential() -> None:
    plant = differential()
    drive(plant, (3.0, 1.0), 10)
    start = plant.pose.copy()
    drive(plant, (1.0, 3.0), 1, t0=0.5)
    states = plant.pose_at(0.5 + 0.01 * np.arange(6))
    np.testing.assert_allclose(states[0], start, atol=1e-15)
    tw = plant.substep_twists
    for i in range(5):
        np.testing.assert_allclose(states[i + 1], twist_step(states[i], *tw[i], 0.01), atol=1e-12)
        mid = plant.pose_at(np.array([0.5 + 0.01 * i + 0.0037]))[0]
        np.testing.assert_allclose(mid, twist_step(states[i], *tw[i], 0.0037), atol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [
        ({"wheel_radius": 0.0}, "radius"),
        ({"track": -1.0}, "track"),
        ({"counts_per_rev": 0}, "counts_per_rev"),
        ({"substep": float("nan")}, "substep"),
        ({"footprint": [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]}, "footprint"),
    ],
)
def test_bad_input(kwargs: dict, word: str) -> None:
    args = {"wheel_radius": R, "track": B, "counts_per_rev": 100, "initial_pose": (0.0, 0.0, 0.0)} | kwargs
    with pytest.raises(ValueError, match=word):
        DifferentialPlant(**args)
    with pytest.raises(ValueError, match="dt"):
        DifferentialPlant(R, B, 100, (0, 0, 0)).advance((1.0, 1.0), 0.0, 0.0, np.random.default_rng(0))


def test_twist_matrices_are_checked() -> None:
    class Plain(WheelPairPlant):
        def _begin_step(self, setpoint: tuple[float, float], dt: float, rng: np.random.Generator) -> None:
            return

        def _ground_speeds(self, wr: float, wl: float, h: float, rng: np.random.Generator) -> tuple[float, float]:
            return wr * R, wl * R

    args = (WheelSpeedLoop(), WheelEncoder(100, R), differential_twist_matrix(B), differential_twist_matrix(B),
            (0.0, 0.0, 0.0), 0.01, UnicycleGeometry(B, R), [[1, 1], [-1, 1], [-1, -1]])
    Plain(*args)  # valid
    with pytest.raises(ValueError, match="nominal_twist"):
        Plain(*args[:3], [[0.5, 0.5], [1.0 / B, -1.0 / B]], *args[4:])
    with pytest.raises(ValueError, match="true_twist"):
        Plain(args[0], args[1], [[math.nan, 0.5], [0, 0], [2, -2]], *args[3:])
