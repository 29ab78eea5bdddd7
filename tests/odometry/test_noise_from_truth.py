"""The filter's odometry noise derived from the truth's random errors (issue 12): Monte Carlo known answers.

Each coefficient of :func:`agvnav.odometry.noise_from_truth` is checked against a Monte
Carlo of the truth's own error model (:class:`agvnav.odometry.NonSystematicErrors`, the
slip and steering draws the simulated vehicles use) at the configuration where it is
exact; and the shipped tricycle scenarios carry the coefficients of their truth.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.odometry import NonSystematicErrors, differential_increments, noise_from_truth
from agvnav.world.scenario import builtin_scenario, load_scenario

SLIP_K = 1e-4
STEER = math.radians(0.05)
N = 200_000


def _tricycle(gamma: float, s: float, rear: bool, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``(dD, dtheta)`` samples of one step: the drive wheel rolls ``s`` with slip, points ``gamma`` + error."""
    ns = NonSystematicErrors(slip_k=SLIP_K, steering_std=STEER)
    ds = ns.perturb(np.full(N, s), rng)
    g = gamma + STEER * rng.standard_normal(N)
    if rear:
        return ds, ds * np.tan(g) / 1.0
    return ds * np.cos(g), ds * np.sin(g) / 1.0


def test_tricycle_straight_step_matches_k_d_and_k_dtheta() -> None:
    step = 0.01
    dd, dth = _tricycle(0.0, step, False, np.random.default_rng(1))
    k = noise_from_truth("tricycle", SLIP_K, 1.0, STEER, step)
    assert np.var(dd) == pytest.approx(k.k_d * step, rel=0.02)
    assert np.var(dth) == pytest.approx(k.k_dtheta * step, rel=0.02)


def test_tricycle_at_90_degrees_matches_k_theta() -> None:
    step = 0.01
    _, dth = _tricycle(0.5 * math.pi, step, False, np.random.default_rng(2))
    k = noise_from_truth("tricycle", SLIP_K, 1.0, STEER, step)
    assert np.var(dth) == pytest.approx(k.k_theta * abs(np.mean(dth)), rel=0.02)


def test_rear_tricycle_at_r_equal_l_matches_k_theta() -> None:
    step = 0.02
    _, dth = _tricycle(0.25 * math.pi, step, True, np.random.default_rng(3))
    k = noise_from_truth("tricycle_rear", SLIP_K, 1.0, 0.0, step)
    assert np.var(dth) == pytest.approx(k.k_theta * abs(np.mean(dth)), rel=0.01)


@pytest.mark.parametrize("pivot", [False, True])
def test_differential_straight_and_pivot(pivot: bool) -> None:
    track, step = 0.5, 0.02
    ns = NonSystematicErrors(slip_k=SLIP_K)
    rng = np.random.default_rng(4)
    right = ns.perturb(np.full(N, step), rng)
    left = ns.perturb(np.full(N, -step if pivot else step), rng)
    dd, dth = differential_increments(right, left, track)
    k = noise_from_truth("differential", SLIP_K, track)
    if pivot:
        assert np.var(dth) == pytest.approx(k.k_theta * abs(np.mean(dth)), rel=0.02)
    else:
        assert np.var(dd) == pytest.approx(k.k_d * step, rel=0.02)
        assert np.var(dth) == pytest.approx(k.k_dtheta * step, rel=0.02)


def test_bad_input_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown model"):
        noise_from_truth("hovercraft", SLIP_K, 1.0)
    with pytest.raises(ValueError, match="base_m"):
        noise_from_truth("tricycle", SLIP_K, 0.0)
    with pytest.raises(ValueError, match="slip_k"):
        noise_from_truth("tricycle", -1.0, 1.0)


#: Shipped tricycle scenarios positioned by the EKF whose filter takes the truth's noise.
DERIVED = ("guidance_test", "seed000_guidance_agvnav", "seed000_positioning_agvnav", "tricycle_rear_loop",
           "fault_blackout", "fault_clutter", "fault_counter_wrap", "fault_delay", "fault_odometry",
           "fault_reflectors")


@pytest.mark.parametrize("name", DERIVED)
def test_shipped_scenarios_carry_their_truths_noise(name: str) -> None:
    """The exact steered-wheel model (issue 12) with the truth's random errors and, as the labelled
    assumption of a calibration tolerance, the truth's systematic magnitudes."""
    sc = load_scenario(builtin_scenario(name))
    v, wo = sc.vehicle, sc.positioning.wheel_odometry
    assert wo is not None
    assert (wo.slip_std, wo.steering_noise_std_deg) == (v.truth.slip_std, v.truth.steering_noise_std_deg)
    assert wo.wheel_radius_std == abs(v.truth.wheel_radius_error)
    assert wo.steering_offset_std_deg == abs(v.truth.steering_offset_deg)
