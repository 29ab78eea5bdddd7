"""Analytic Jacobians of the mapping factors against central differences; whitening."""

from __future__ import annotations

import numpy as np

from agvnav.mapping.graph import (
    BearingFactors,
    DistanceFactors,
    FactorGraph,
    OdometryFactors,
    PosePriors,
    ReflectorPriors,
    bearing_prediction,
    linearize,
    whitener,
)
from agvnav.sensors.goniometer import leading_edge_bearing


def _graph(rng: np.random.Generator) -> tuple[FactorGraph, np.ndarray]:
    K, N, B = 4, 3, 12
    odo = OdometryFactors(np.arange(3), np.arange(1, 4), rng.normal(size=(3, 3)) * 0.3,
                          np.broadcast_to(np.diag([10.0, 20.0, 30.0]), (3, 3, 3)).copy(), rng.normal(size=3) * 0.3)
    bear = BearingFactors(rng.integers(0, K, B), rng.integers(0, N, B), rng.normal(size=(B, 3)) * 0.1,
                          rng.normal(size=B), np.full(B, 0.01), np.array([0.3, 0.1, 0.2]), 0.04, 1,
                          rng.normal(size=B) * 0.1)
    g = FactorGraph(K, N, odo, bear, PosePriors(np.array([1]), rng.normal(size=(1, 3)), np.eye(3)[None] * 5),
                    ReflectorPriors(np.array([2]), rng.normal(size=(1, 2)), np.eye(2)[None] * 3),
                    DistanceFactors(np.array([0]), np.array([1]), np.array([2.0]), np.array([0.01])), (1.0, 0.01),
                    (0.01, 0.05))
    x = g.pack(rng.normal(size=(K, 3)), rng.normal(size=(N, 2)) * 5 + 10, 1.1, (0.004, 0.02))
    return g, x


def test_jacobian_matches_central_differences() -> None:
    g, x = _graph(np.random.default_rng(3))
    _, J = linearize(g, x)
    assert J is not None
    numeric = np.zeros(J.shape)
    h = 1e-6
    for i in range(x.size):
        xp, xm = x.copy(), x.copy()
        xp[i] += h
        xm[i] -= h
        numeric[:, i] = (linearize(g, xp, False)[0] - linearize(g, xm, False)[0]) / (2 * h)
    np.testing.assert_allclose(J.toarray(), numeric, atol=1e-6)


def test_bearing_model_is_the_goniometer_leading_edge() -> None:
    rng = np.random.default_rng(5)
    g, x = _graph(rng)
    poses, landmarks, scale = g.unpack(x)
    kappa, b = g.calibration(x)
    assert (kappa, b) == (0.004, 0.02)
    beta, *_ = bearing_prediction(poses, landmarks, scale, g.bearings, calibration=(kappa, b))
    f = g.bearings
    assert f.offset_dist is not None
    for k in range(f.pose.size):  # head = X ∘ [s u_t, (1 + b) u_psi + kappa u_D] ∘ mount
        X, u, m = poses[f.pose[k]], f.offset[k], f.mount
        c, s = np.cos(X[2]), np.sin(X[2])
        base = np.array([X[0] + c * scale * u[0] - s * scale * u[1], X[1] + s * scale * u[0] + c * scale * u[1],
                         X[2] + (1.0 + b) * u[2] + kappa * f.offset_dist[k]])
        cb, sb = np.cos(base[2]), np.sin(base[2])
        head = np.array([base[0] + cb * m[0] - sb * m[1], base[1] + sb * m[0] + cb * m[1], base[2] + m[2]])
        expected = leading_edge_bearing(head, landmarks[f.landmark[k]][None], np.array([f.radius]))[0]
        assert abs(np.angle(np.exp(1j * (beta[k] - float(np.ravel(expected)[0]))))) < 1e-12


def test_whitener_inverts_the_covariance() -> None:
    cov = np.array([[[4.0, 1.0], [1.0, 2.0]]])
    W = whitener(cov)
    np.testing.assert_allclose(W[0].T @ W[0], np.linalg.inv(cov[0]), atol=1e-12)


def test_odometry_heading_residual_carries_the_heading_rate_and_turn_scale() -> None:
    """A pose pair turned exactly (1 + b) θ + κ D apart has a zero heading residual."""
    W = np.eye(3)[None]
    odo = OdometryFactors(np.array([0]), np.array([1]), np.array([[1.0, 0.0, 0.2]]), W, np.array([1.0]))
    bear = BearingFactors(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros(0),
                          np.zeros(0), np.zeros(3))
    g = FactorGraph(2, 0, odo, bear, calibration_prior=(1.0, 1.0))
    kappa, b = 0.003, 0.01
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 1.01 * 0.2 + 0.003]])
    e, _ = linearize(g, g.pack(poses, np.zeros((0, 2)), 1.0, (kappa, b)), jacobian=False)
    assert abs(e[2]) < 1e-12
    e0, _ = linearize(g, g.pack(poses, np.zeros((0, 2)), 1.0), jacobian=False)
    assert abs(e0[2] - (0.01 * 0.2 + 0.003)) < 1e-12
