"""Analytic Jacobians of the mapping factors against central differences; whitening."""

from __future__ import annotations

import numpy as np
import pytest

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


def _graph(rng: np.random.Generator, interpolated: bool = False) -> tuple[FactorGraph, np.ndarray]:
    K, N, B = 4, 3, 12
    odo = OdometryFactors(np.arange(3), np.arange(1, 4), rng.normal(size=(3, 3)) * 0.3,
                          np.broadcast_to(np.diag([10.0, 20.0, 30.0]), (3, 3, 3)).copy(), rng.normal(size=3) * 0.3)
    bear = BearingFactors(rng.integers(0, K - 1 if interpolated else K, B), rng.integers(0, N, B),
                          rng.normal(size=(B, 3)) * 0.1, rng.normal(size=B), np.full(B, 0.01),
                          np.array([0.3, 0.1, 0.2]), 0.04, 1, rng.normal(size=B) * 0.1,
                          rng.uniform(0.0, 1.0, B) if interpolated else None)
    g = FactorGraph(K, N, odo, bear, PosePriors(np.array([1]), rng.normal(size=(1, 3)), np.eye(3)[None] * 5),
                    ReflectorPriors(np.array([2]), rng.normal(size=(1, 2)), np.eye(2)[None] * 3),
                    DistanceFactors(np.array([0]), np.array([1]), np.array([2.0]), np.array([0.01])), (1.0, 0.01),
                    (0.01, 0.05))
    x = g.pack(rng.normal(size=(K, 3)), rng.normal(size=(N, 2)) * 5 + 10, 1.1, (0.004, 0.02))
    return g, x


@pytest.mark.parametrize("interpolated", [False, True])
def test_jacobian_matches_central_differences(interpolated: bool) -> None:
    g, x = _graph(np.random.default_rng(3), interpolated)
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


def test_interpolated_bearing_shares_the_interval_between_its_keyframes() -> None:
    """With ``alpha`` the head pose is ``p_k + α (p_{k+1} − p_k) + R(ψ_k) s v_t`` turned by ``α Δψ`` (graph
    docstring): at α = 0 it is the keyframe's own bearing, and the head pose agrees with head_poses."""
    from agvnav.mapping.association import head_poses

    rng = np.random.default_rng(7)
    g, x = _graph(rng, interpolated=True)
    poses, landmarks, scale = g.unpack(x)
    f = g.bearings
    assert f.alpha is not None
    beta, *_ = bearing_prediction(poses, landmarks, scale, f)
    heads = head_poses(poses, f.pose, f.offset, f.mount, scale, f.offset_dist, (0.0, 0.0), f.alpha)
    for k in range(f.pose.size):
        X, Xn, a, v, m = poses[f.pose[k]], poses[f.pose[k] + 1], f.alpha[k], f.offset[k], f.mount
        w = v[2] + a * np.angle(np.exp(1j * (Xn[2] - X[2])))
        c, s = np.cos(X[2]), np.sin(X[2])
        t = np.array([scale * v[0] + np.cos(w) * m[0] - np.sin(w) * m[1],
                      scale * v[1] + np.sin(w) * m[0] + np.cos(w) * m[1]])
        head = np.array([X[0] + a * (Xn[0] - X[0]) + c * t[0] - s * t[1],
                         X[1] + a * (Xn[1] - X[1]) + s * t[0] + c * t[1], X[2] + w + m[2]])
        np.testing.assert_allclose(heads[k], head, atol=1e-12)
        expected = leading_edge_bearing(head, landmarks[f.landmark[k]][None], np.array([f.radius]))[0]
        assert abs(np.angle(np.exp(1j * (beta[k] - float(np.ravel(expected)[0]))))) < 1e-12
    at_zero = BearingFactors(f.pose, f.landmark, f.offset, f.z, f.sigma, f.mount, f.radius, f.direction,
                             f.offset_dist, np.zeros(f.pose.size))
    plain = BearingFactors(f.pose, f.landmark, f.offset, f.z, f.sigma, f.mount, f.radius, f.direction, f.offset_dist)
    np.testing.assert_allclose(bearing_prediction(poses, landmarks, scale, at_zero)[0],
                               bearing_prediction(poses, landmarks, scale, plain)[0], atol=1e-15)


def test_interpolated_drive_carries_no_odometry_noise_when_every_instant_is_a_keyframe() -> None:
    """A reflection between two odometry instants: with a keyframe at every instant its interpolated offset
    ``u − α z`` is only the arc's sagitta (the offset is the step split by time) and its covariance is 0;
    with keyframes 3 steps
    apart the bridge covariance is positive inside the interval and below the offset's own."""
    from agvnav.mapping.drive import interpolate_drive, prepare_drive

    log = _arc_log(12, [0.12, 0.33, 0.41])
    every = interpolate_drive(prepare_drive(log, 0.0))
    # what remains of the offset is the arc's departure from the straight interpolation (its sagitta)
    np.testing.assert_allclose(every.refl_offset[:, 2], 0.0, atol=1e-15)
    assert np.all(np.hypot(every.refl_offset[:, 0], every.refl_offset[:, 1]) <= 0.02 * 0.01 / 8.0 + 1e-12)
    np.testing.assert_allclose(every.refl_offset_cov, 0.0, atol=1e-18)
    assert every.refl_alpha is not None and np.all((every.refl_alpha > 0.0) & (every.refl_alpha < 1.0))
    sparse_drive = prepare_drive(log, 0.15)
    sparse = interpolate_drive(sparse_drive)
    var = sparse.refl_offset_cov[:, 2, 2]
    assert np.all(var > 0.0) and np.all(var < sparse_drive.refl_offset_cov[:, 2, 2])


def test_in_step_slip_is_a_brownian_bridge_shared_by_the_bearings_of_one_step() -> None:
    """Two reflections a quarter and three quarters through one odometry step, a reflector 100 m off (the
    bearing moves with the heading alone): their in-step covariance is ``(min f − f_i f_j) C_ψψ``, i.e.
    0.1875, 0.1875 and 0.0625 times the step's heading variance; a reflection of the next step is
    independent of them."""
    from agvnav.mapping.drive import interpolate_drive, prepare_drive
    from agvnav.mapping.slam import MappingOptions, _step_noise, _used

    log = _arc_log(4, [0.0625, 0.0875, 0.1125])
    d = interpolate_drive(prepare_drive(log, 0.0))
    poses = np.zeros((d.keyframe_t.size, 3))
    heads = np.zeros((3, 3))
    assoc = np.zeros(3, dtype=np.int64)
    use = _used(d, assoc, poses.shape[0])
    noise = _step_noise(d, use, heads, np.array([[100.0, 0.0]]), assoc, poses, np.full(3, 1e-5), np.ones(3),
                        MappingOptions(radius=0.0))
    assert noise is not None and noise.blocks.shape == (2, 2)
    assert d.step_parts is not None and d.odometry_k is not None
    c_psi = float(np.einsum("c,c->", d.odometry_k, d.step_parts[:, 0, 2, 2]))
    first = noise.step[0]
    np.testing.assert_allclose(first, np.array([[0.1875, 0.0625], [0.0625, 0.1875]]) * c_psi, rtol=1e-3)
    assert noise.step[1, 0, 1] == 0.0 and noise.blocks[1, 1] == -1
    W, _ = noise.whitener(1.0, 1.0, 3)
    cov = noise.covariance(1.0, 1.0)
    np.testing.assert_allclose((W.T @ W).toarray()[:2, :2], np.linalg.inv(cov[0]), rtol=1e-9)


def _arc_log(n: int, stamps: list[float]):
    """A log of ``n`` 50 ms odometry steps of 2 cm and 0.01 rad each, with reflections at ``stamps`` (s)."""
    from agvnav.logs import RecordedLog

    t = np.arange(n + 1) * 0.05
    inc = np.column_stack([np.full(n, 0.02), np.full(n, 0.01), np.zeros(n)])
    z = np.asarray(stamps, dtype=np.float64)
    # distinct readings (identical ones within 1.5 revolutions would be one measurement: repeated_readings)
    return RecordedLog(t, inc, z, z.copy(), 0.001 * np.arange(z.size), {"odometry_noise": [1e-4, 1e-5, 1e-4]})
