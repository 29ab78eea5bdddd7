"""The exact steered-wheel odometry model (issue 12): Monte Carlo of the truth's own error draws.

:class:`agvnav.odometry.SteeredOdometryNoise` maps the driven wheel's slip and the
steering error along the directions they move the increment (rank one each). Known
answers: a Monte Carlo of :class:`agvnav.odometry.NonSystematicErrors` (the draws the
simulated tricycles make) for one step at several steering angles, front and rear drive;
the pose covariance after several steps (large and small) against a Monte Carlo of the
same draws integrated by the arc rule; the systematic Jacobian against finite
differences of the increment in the radius scale and the steering offset.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.odometry import (
    NonSystematicErrors,
    SteeredOdometryNoise,
    calibration_jacobian,
    integrate_pose,
    noise_from_truth,
    propagate,
    steered_noise,
)

SLIP_K = 1e-4
STEER = math.radians(0.05)
L = 1.2


def _increments(s: np.ndarray, g: np.ndarray, rear: bool) -> tuple[np.ndarray, np.ndarray]:
    if rear:
        return s, s * np.tan(g) / L
    return s * np.cos(g), s * np.sin(g) / L


def _draw(s: float, gamma: float, rear: bool, n: int, rng: np.random.Generator,
          steer: float = STEER) -> tuple[np.ndarray, np.ndarray]:
    """``(dD, dtheta)`` samples: the drive wheel rolls ``s`` with the truth's slip, points ``gamma`` + its error."""
    ns = NonSystematicErrors(slip_k=SLIP_K, steering_std=steer)
    ds = ns.perturb(np.full(n, s), rng)
    g = gamma + steer * rng.standard_normal(n)
    return _increments(ds, g, rear)


@pytest.mark.parametrize("rear", [False, True])
@pytest.mark.parametrize("gamma_deg", [0.0, 20.0, 45.0, 70.0])
def test_one_step_matches_the_truth_draws(rear: bool, gamma_deg: float) -> None:
    """Full 2x2 covariance of one control step (``step_m = s``), off-diagonal included."""
    s, g = 0.02, math.radians(gamma_deg)
    dd, dth = _draw(s, g, rear, 400_000, np.random.default_rng(int(gamma_deg) + 100 * rear))
    mc = np.cov(np.vstack([dd, dth]))
    noise = steered_noise("tricycle_rear" if rear else "tricycle", SLIP_K, L, STEER, s)
    dd0, dth0 = _increments(np.array(s), np.array(g), rear)
    model = noise.increment_covariance(dd0, dth0)
    scale = np.sqrt(np.outer(np.diag(model), np.diag(model)))
    np.testing.assert_allclose(mc / scale, model / scale, atol=0.015)


def test_slip_alone_is_rank_one_along_the_increment() -> None:
    """``Sigma_slip = slip_k / |s| u u^T`` (check of the brief's formula): ``u`` spans it, zero across."""
    noise = steered_noise("tricycle", SLIP_K, L)
    dd, dth = _increments(np.array(0.3), np.array(0.6), False)
    cov = noise.increment_covariance(dd, dth)
    u = np.array([dd, dth])
    s = math.hypot(dd, L * dth)
    np.testing.assert_allclose(cov, SLIP_K / s * np.outer(u, u), rtol=1e-14)
    assert abs(np.array([-u[1], u[0]]) @ cov @ np.array([-u[1], u[0]])) < 1e-20


def test_crowley_bound_is_kept_for_three_coefficient_consumers() -> None:
    noise = steered_noise("tricycle", SLIP_K, L, STEER, 0.01)
    bound = noise_from_truth("tricycle", SLIP_K, L, STEER, 0.01)
    assert (noise.k_d, noise.k_dtheta, noise.k_theta) == (bound.k_d, bound.k_dtheta, bound.k_theta)
    # the exact heading variance on a curve is below the bound's k_theta |dtheta| + k_dtheta |dD|
    dd, dth = _increments(np.array(0.05), np.array(0.4), False)
    exact = noise.increment_covariance(dd, dth)[1, 1]
    assert exact < bound.k_theta * abs(dth) + bound.k_dtheta * abs(dd)


def _mc_pose(steps: int, s: float, gamma: float, rear: bool, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    pose = np.zeros((n, 3))
    for _ in range(steps):
        dd, dth = _draw(s, gamma, rear, n, rng)
        pose = integrate_pose(pose, dd, dth, "arc")
    return pose


@pytest.mark.parametrize("rear", [False, True])
@pytest.mark.parametrize(("steps", "s", "gamma"), [(4, 0.625, 0.35), (40, 0.02, 0.5)])
def test_pose_covariance_after_several_steps_matches_monte_carlo(rear: bool, steps: int, s: float,
                                                                  gamma: float) -> None:
    """Large steps (4 x 0.625 m, the issue's arc) and small ones (40 x 2 cm): ``P`` by ``propagate`` vs the draws."""
    noise = steered_noise("tricycle_rear" if rear else "tricycle", SLIP_K, L, STEER, s)
    dd0, dth0 = _increments(np.array(s), np.array(gamma), rear)
    pose, P = np.zeros(3), np.zeros((3, 3))
    for _ in range(steps):
        pose, P = propagate(pose, P, float(dd0), float(dth0), noise, "arc")
    mc = np.cov(_mc_pose(steps, s, gamma, rear, 200_000, 7 + steps).T)
    scale = np.sqrt(np.outer(np.diag(P), np.diag(P)))
    np.testing.assert_allclose(mc / scale, P / scale, atol=0.02)


@pytest.mark.parametrize("rear", [False, True])
def test_systematic_jacobian_matches_finite_differences(rear: bool) -> None:
    """``B = d(dD, dtheta)/d(eps, beta)``: radius scale ``s -> (1 + eps) s``, offset ``g -> g + beta``."""
    noise = steered_noise("tricycle_rear" if rear else "tricycle", SLIP_K, L, radius_scale_std=0.003,
                          steering_offset_std=0.004)
    s, g, h = 0.4, 0.5, 1e-7
    dd, dth = _increments(np.array(s), np.array(g), rear)
    B = noise.systematic_jacobian(dd, dth)
    col_eps = (np.array(_increments(np.array(s * (1 + h)), np.array(g), rear)) - [dd, dth]) / h
    col_beta = (np.array(_increments(np.array(s), np.array(g + h), rear)) - [dd, dth]) / h
    np.testing.assert_allclose(B[:, 0], col_eps, rtol=1e-6)
    np.testing.assert_allclose(B[:, 1], col_beta, rtol=1e-6)
    pose = np.array([1.0, 2.0, 0.3])
    W = calibration_jacobian(pose, dd, dth, noise)
    fd = np.column_stack([
        (integrate_pose(pose, *_increments(np.array(s * (1 + h)), np.array(g), rear)) - integrate_pose(pose, dd, dth))
        / h,
        (integrate_pose(pose, *_increments(np.array(s), np.array(g + h), rear)) - integrate_pose(pose, dd, dth)) / h,
    ])
    np.testing.assert_allclose(W, fd, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(noise.calibration_covariance(), np.diag([0.003**2, 0.004**2]))


def test_standstill_has_no_noise() -> None:
    for model in ("tricycle", "tricycle_rear"):
        noise = steered_noise(model, SLIP_K, L, STEER, 0.01, 0.003, 0.003)
        assert not np.any(noise.increment_covariance(0.0, 0.0))
        assert not np.any(noise.systematic_jacobian(0.0, 0.0))


def test_bad_input_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown model"):
        SteeredOdometryNoise(model="differential", slip_k=SLIP_K)
    with pytest.raises(ValueError, match="radius_scale_std"):
        steered_noise("tricycle", SLIP_K, L, radius_scale_std=-0.1)
    with pytest.raises(ValueError, match="steering_offset_std"):
        steered_noise("tricycle", SLIP_K, L, steering_offset_std=math.nan)
    with pytest.raises(ValueError, match="base_m"):
        steered_noise("tricycle", SLIP_K, 0.0)
