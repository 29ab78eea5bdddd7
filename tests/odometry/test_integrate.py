"""Seed 002 eqs. 20, 25, 26: exactness, error orders, Jacobians; eq. 17 covariance; eq. 16 increments."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.kinematics import TricycleStacker, TricycleStackerSimple, numerical_jacobian, rk4_step
from agvnav.odometry import (
    OdometryNoise,
    differential_increments,
    differential_wheel_distances,
    increment_jacobian,
    integrate_pose,
    motion_covariance,
    pose_jacobian,
    tricycle_increments,
)

RULES = ("arc", "midpoint", "euler")


def exact_arc(pose, dd, dth):
    """End of the circular arc of length dd turning dth, from its centre."""
    x, y, th = pose
    r = dd / dth
    cx, cy = x - r * np.sin(th), y + r * np.cos(th)
    return np.array([cx + r * np.sin(th + dth), cy - r * np.cos(th + dth), th + dth])


@given(dd=st.floats(-3, 3), dth=st.floats(0.01, 2.5) | st.floats(-2.5, -0.01), th=st.floats(-3, 3))
def test_arc_rule_is_exact_on_arcs(dd, dth, th):
    pose = np.array([1.0, -2.0, th])
    np.testing.assert_allclose(integrate_pose(pose, dd, dth, "arc")[:2], exact_arc(pose, dd, dth)[:2], atol=1e-12)


@pytest.mark.parametrize("dth", [0.01, 0.02, 0.04, 0.08])
def test_error_orders(dth):
    """Euler's position error is ΔD·Δθ/2 (first order), the midpoint's ΔD·Δθ²/24 (seed 002 §3.3)."""
    pose, dd = np.array([0.0, 0.0, 0.3]), 1.0
    exact = exact_arc(pose, dd, dth)[:2]
    err = {r: np.hypot(*(integrate_pose(pose, dd, dth, r)[:2] - exact)) for r in RULES}
    assert err["euler"] == pytest.approx(dd * dth / 2, rel=0.01)
    assert err["midpoint"] == pytest.approx(dd * dth**2 / 24, rel=0.01)
    assert err["arc"] < 1e-12


@pytest.mark.parametrize("rule", RULES)
def test_jacobians_match_numerical(rule):
    rng = np.random.default_rng(0)
    pose = rng.normal(size=(20, 3))
    inc = np.stack([rng.uniform(-1, 1, 20), rng.uniform(-1, 1, 20)], axis=-1)
    inc[0, 1] = 1e-7  # near-straight branch of the series
    F = pose_jacobian(pose, inc[:, 0], inc[:, 1], rule)
    Fn = numerical_jacobian(lambda p: _unwrapped(p, inc, rule), pose)
    np.testing.assert_allclose(F, Fn, atol=1e-8)
    G = increment_jacobian(pose, inc[:, 0], inc[:, 1], rule)
    Gn = numerical_jacobian(lambda d: _unwrapped(pose, d, rule), inc)
    np.testing.assert_allclose(G, Gn, atol=1e-8)


def _unwrapped(pose, inc, rule):
    out = integrate_pose(pose, inc[..., 0], inc[..., 1], rule)
    out[..., 2] = pose[..., 2] + inc[..., 1]
    return out


def test_integrate_rejects_unknown_rule():
    with pytest.raises(ValueError, match="rule"):
        integrate_pose([0, 0, 0], 1.0, 0.1, "rk4")


@given(
    th=st.floats(-4, 4), dd=st.floats(-2, 2), dth=st.floats(-2, 2), rule=st.sampled_from(["arc", "midpoint", "euler"])
)
def test_motion_covariance_is_psd_and_maps_the_increments_through_the_numeric_jacobian(th, dd, dth, rule):
    """Q = G diag(var_d, var_th) G^T with G the central-difference Jacobian of the pose update."""
    n = OdometryNoise()
    q = motion_covariance([0.0, 0.0, th], dd, dth, n, rule)
    assert np.min(np.linalg.eigvalsh(q)) > -1e-15
    eps = 1e-6
    G = np.empty((3, 2))
    for j, (a, b) in enumerate(((eps, 0.0), (0.0, eps))):
        hi = integrate_pose([0.0, 0.0, th], dd + a, dth + b, rule)
        lo = integrate_pose([0.0, 0.0, th], dd - a, dth - b, rule)
        diff = hi - lo
        diff[2] = (diff[2] + np.pi) % (2 * np.pi) - np.pi
        G[:, j] = diff / (2 * eps)
    var_d, var_t = n.k_d * abs(dd), n.k_dtheta * abs(dd) + n.k_theta * abs(dth)
    np.testing.assert_allclose(q, G @ np.diag([var_d, var_t]) @ G.T, atol=1e-9)


def test_seed_printed_diagonal_would_be_negative():
    """Why eq. 17 is not used as printed: K_D·ΔD·cos θ < 0 for θ = π, while our Q11 stays >= 0."""
    n = OdometryNoise()
    assert n.k_d * 1.0 * np.cos(np.pi) < 0
    assert motion_covariance([0, 0, np.pi], 1.0, 0.0, n)[0, 0] > 0
    with pytest.raises(ValueError, match="k_d"):
        OdometryNoise(k_d=-1.0)


@given(dr=st.floats(-1, 1), dl=st.floats(-1, 1))
def test_differential_increments_round_trip(dr, dl):
    dd, dth = differential_increments(dr, dl, 0.5)
    assert dd == pytest.approx((dr + dl) / 2) and dth == pytest.approx((dr - dl) / 0.5)
    np.testing.assert_allclose(differential_wheel_distances(dd, dth, 0.5), [dr, dl], atol=1e-12)


def test_tricycle_increments_exact_for_constant_steering():
    tri = TricycleStackerSimple(wheelbase=1.3)
    x0, v, g, dt = np.array([0.2, 0.1, 0.4]), 0.6, 0.35, 0.5
    dd, dth = tricycle_increments(v * dt, g, 1.3)
    np.testing.assert_allclose(integrate_pose(x0, dd, dth, "arc"), tri.step(x0, [v, g], dt), atol=1e-13)


def test_tricycle_mid_step_gamma_is_second_order():
    """With γ changing, using the mid-step γ gives an O(dt³) pose error per step."""
    tri = TricycleStacker(wheelbase=1.3)
    errs = []
    for dt in (0.2, 0.1):
        x0, u = np.array([0.0, 0.0, 0.0, 0.2]), np.array([1.0, 0.5])
        truth = rk4_step(tri.derivative, x0, u, dt, substeps=200)
        dd, dth = tricycle_increments(u[0] * dt, 0.5 * (x0[3] + truth[3]), 1.3)
        errs.append(np.hypot(*(integrate_pose(x0[:3], dd, dth)[:2] - truth[:2])))
    assert errs[0] / errs[1] > 6.0  # about 8 for third order


@given(dd=st.floats(-2, 2), dth=st.floats(-2, 2), frac=st.floats(0, 1))
def test_arc_rule_splits_exactly(dd, dth, frac):
    """Two arc steps of the same curvature equal one: extrapolating then completing an increment is exact."""
    p = np.array([0.3, -0.7, 2.9])
    half = integrate_pose(p, frac * dd, frac * dth, "arc")
    both = integrate_pose(half, (1 - frac) * dd, (1 - frac) * dth, "arc")
    once = integrate_pose(p, dd, dth, "arc")
    np.testing.assert_allclose(both[:2], once[:2], atol=1e-12)
    assert abs(np.angle(np.exp(1j * (both[2] - once[2])))) < 1e-12
