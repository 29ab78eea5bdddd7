"""The EKF's Schmidt-Kalman consider filter for the reflectors' survey errors (issue 12).

* the scalar update and the factored ``P_xp = M C^T`` against the augmented-state form
  of the same filter (state ``[pose, survey errors]``, gain zero on the survey errors,
  Joseph form on the whole covariance): identical pose, ``P_xx`` and ``P_xp``;
* the consider filter's ``P_xx`` is never below the full augmented EKF's (which also
  estimates the survey errors: the consider filter is the suboptimal one);
* NEES by Monte Carlo on a synthetic drive with a known survey error drawn per run:
  consistent for the consider filter, and far outside the band for the filter that
  takes the survey error as white bearing noise (the band can be left).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from _drive import arc_pose_at, drive_nees
from scipy.stats import chi2

from agvnav.geometry import wrap_angle
from agvnav.odometry import OdometryNoise, integrate_pose, motion_covariance, pose_jacobian
from agvnav.positioning import _fast
from agvnav.positioning.edge_bearing import bearing_model
from agvnav.positioning.ekf import EkfEstimator
from agvnav.positioning.gating import BearingIndex, GateSpec
from agvnav.positioning.integrity import IntegrityLimits
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import WorldMap, load_builtin_map

MOUNT = np.array([0.3, 0.0, 0.0])


def _augmented_update(
    x: np.ndarray, Pa: np.ndarray, y: float, H: np.ndarray, j: int, R: float, consider: bool
) -> tuple[np.ndarray, np.ndarray]:
    """One bearing on the augmented state ``[pose, p_1x, p_1y, ...]``; ``consider``: no gain on ``p``."""
    Ha = np.zeros(Pa.shape[0])
    Ha[:3] = H
    Ha[3 + 2 * j: 5 + 2 * j] = -H[:2]  # the bearing moves with the reflector as against the head
    S = Ha @ Pa @ Ha + R
    K = Pa @ Ha / S
    if consider:
        K[3:] = 0.0
    A = np.eye(Pa.shape[0]) - np.outer(K, Ha)
    Pa = A @ Pa @ A.T + R * np.outer(K, K)
    x = x + K[:3] * y
    x[2] = wrap_angle(x[2])
    return x, 0.5 * (Pa + Pa.T)


def test_schmidt_update_matches_the_augmented_form() -> None:
    rng = np.random.default_rng(3)
    n = 3
    for _ in range(20):
        L = rng.normal(size=(3 + 2 * n, 3 + 2 * n)) * 0.01
        Pa = L @ L.T + 1e-6 * np.eye(3 + 2 * n)
        svar = rng.uniform(1e-6, 1e-4, n)
        Pa[3:, 3:] = np.diag(np.repeat(svar, 2))  # consider parameters: fixed diagonal
        w = np.linalg.eigvalsh(Pa)
        if w.min() <= 0.0:
            Pa[:3, :3] += (1e-6 - w.min()) * np.eye(3)
        x = rng.normal(size=3)
        H = rng.normal(size=3)
        j, y, R = int(rng.integers(n)), float(rng.normal(0.0, 0.01)), 1e-6
        xr, Pr = _augmented_update(x, Pa, y, H, j, R, consider=True)
        M = tuple(rng.normal(size=9) + 3.0 * np.eye(3).ravel())  # any invertible factor of P_xp = M C^T
        C = np.linalg.solve(np.asarray(M).reshape(3, 3), Pa[:3, 3:]).T.reshape(n, 6)
        v = _fast.consider_cross(M, C[j, :3], C[j, 3:], -H[0], -H[1])
        b = svar[j] * (H[0] ** 2 + H[1] ** 2)
        x1, P1, K, _ = _fast.schmidt_update(tuple(x), tuple(Pa[:3, :3].ravel()), y, tuple(H), R, v, b)
        np.testing.assert_allclose(x1, xr, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(np.reshape(P1, (3, 3)), Pr[:3, :3], rtol=1e-9, atol=1e-15)
        M1 = _fast.left_update(M, K, tuple(H))
        C1 = C.copy()
        C1[j, :3] += _fast.solve3(M1, tuple(np.asarray(K) * H[0] * svar[j]), _fast.det3(M1))
        C1[j, 3:] += _fast.solve3(M1, tuple(np.asarray(K) * H[1] * svar[j]), _fast.det3(M1))
        np.testing.assert_allclose(
            np.reshape(M1, (3, 3)) @ C1.reshape(-1, 3).T, Pr[:3, 3:], rtol=1e-8, atol=1e-14
        )
        np.testing.assert_allclose(Pr[3:, 3:], Pa[3:, 3:], atol=0.0)  # never updated


def _moved(world: WorldMap, offsets: np.ndarray) -> WorldMap:
    moved = [dataclasses.replace(r, x=r.x + d[0], y=r.y + d[1]) for r, d in zip(world.reflectors, offsets, strict=True)]
    return dataclasses.replace(world, reflectors=tuple(moved))


def _drive_both(seed: int, seconds: float) -> tuple[EkfEstimator, np.ndarray, np.ndarray, np.ndarray, int]:
    """The estimator and the augmented reference driven side by side; returns their final state."""
    world = load_builtin_map("lab")
    n = world.reflector_xy.shape[0]
    std, sigma = 0.005, 2e-4
    rng = np.random.default_rng(seed)
    truth = _moved(world, rng.normal(0.0, std, (n, 2)))
    noise = OdometryNoise(k_d=1e-4, k_dtheta=1e-5, k_theta=1e-4)
    start = np.array([6.0, 3.0, 0.3])
    P0 = np.diag([0.01, 0.01, 0.005]) ** 2
    x0 = start + rng.multivariate_normal(np.zeros(3), P0)
    est = EkfEstimator(
        world, MOUNT, bearing_std=sigma, bearing_offset=0.0, map_std=std, odometry_noise=noise,
        initial_pose=x0, initial_covariance=P0, integrity=IntegrityLimits(enabled=False),
    )
    x = x0.copy()
    Pa = np.zeros((3 + 2 * n, 3 + 2 * n))
    Pa[:3, :3] = P0
    Pa[3:, 3:] = std**2 * np.eye(2 * n)
    gon = Goniometer(pulses_per_rev=2**30, mount=tuple(MOUNT))
    speed, omega = 0.4, 0.15
    pose_at = arc_pose_at(start, speed, omega)
    refl = gon.scan(truth, pose_at, 0.0, seconds, None)
    z = refl.bearing + rng.normal(0.0, sigma, refl.bearing.shape)
    est.predict(0.0, 0.0, 0.0)
    last, used = 0.0, 0
    for t, zk in zip(refl.t.tolist(), z.tolist(), strict=True):
        dd, dth = speed * (t - last), omega * (t - last)
        est.predict(t, dd, dth)
        F = pose_jacobian(x, dd, dth)
        Q = motion_covariance(x, dd, dth, noise)
        x = integrate_pose(x, dd, dth)
        x[2] = wrap_angle(x[2])
        Pa[:3, :3] = F @ Pa[:3, :3] @ F.T + Q
        Pa[:3, 3:] = F @ Pa[:3, 3:]
        Pa[3:, :3] = Pa[:3, 3:].T
        last = t
        if est.update(t, zk):
            j = est.last_reflector
            h, H, _ = bearing_model(x, MOUNT, world.reflector_xy[j], world.reflector_radius[j])
            x, Pa = _augmented_update(x, Pa, float(wrap_angle(zk - h)), H, j, sigma**2, consider=True)
            used += 1
    return est, x, Pa, world.reflector_xy, used


def test_estimator_matches_the_augmented_schmidt_filter() -> None:
    """A 6 s drive past the lab's 9 reflectors (~300 bearings, M folded many times): same x, P_xx, P_xp."""
    est, x, Pa, _, used = _drive_both(5, 6.0)
    assert used > 200
    np.testing.assert_allclose(est.pose, x, rtol=0.0, atol=1e-10)
    np.testing.assert_allclose(est.covariance, Pa[:3, :3], rtol=1e-7, atol=1e-16)
    np.testing.assert_allclose(est.cross_covariance, Pa[:3, 3:], rtol=1e-6, atol=1e-14)


def test_consider_covariance_is_not_below_the_full_augmented_ekf() -> None:
    """The full EKF that also estimates the survey errors reports less; the consider filter is suboptimal."""
    rng = np.random.default_rng(8)
    n = 4
    Pa = np.zeros((3 + 2 * n, 3 + 2 * n))
    Pa[:3, :3] = np.diag([1e-4, 1e-4, 1e-5])
    Pa[3:, 3:] = 2.5e-5 * np.eye(2 * n)
    Pc, Pf = Pa.copy(), Pa.copy()
    x = np.zeros(3)
    for _ in range(40):
        H = np.r_[rng.normal(size=2) * 0.3, -1.0]
        j = int(rng.integers(n))
        _, Pc = _augmented_update(x, Pc, 0.0, H, j, 1e-7, consider=True)
        _, Pf = _augmented_update(x, Pf, 0.0, H, j, 1e-7, consider=False)
    assert np.linalg.eigvalsh(Pc[:3, :3] - Pf[:3, :3]).min() > -1e-15
    assert np.trace(Pc[:3, :3]) > np.trace(Pf[:3, :3])


class _WhiteNoiseEkf(EkfEstimator):
    """The filter before issue 12's consider filter: survey error as white bearing noise ``(std / d)^2``."""

    consider = False

    def _accept(self, t: float, bearing: float, assoc) -> None:  # type: ignore[no-untyped-def]
        H = (float(assoc.H[0]), float(assoc.H[1]), float(assoc.H[2]))
        self._x_t, self._P_t = _fast.joseph_update(self._x_t, self._P_t, assoc.innovation, H, assoc.R)

    @property
    def covariance(self) -> np.ndarray:
        return self._P


def _nees_runs(cls: type[EkfEstimator], n_runs: int, seconds: float, seed: int) -> np.ndarray:
    """NEES at sampled instants ``(n_runs, n_samples)`` with a survey error of 5 mm drawn per run."""
    world = load_builtin_map("lab")
    gon = Goniometer(pulses_per_rev=2**30, mount=tuple(MOUNT))
    noise = OdometryNoise(k_d=1e-4, k_dtheta=1e-5, k_theta=1e-5)
    speed, omega, dt, sigma, std = 0.5, 0.05, 0.02, 2e-4, 0.005
    out = []
    for k in range(n_runs):
        rng = np.random.default_rng([seed, k])
        truth = _moved(world, rng.normal(0.0, std, (world.reflector_xy.shape[0], 2)))
        start = np.array([4.0, 3.0, 0.2])
        P0 = np.diag([0.01, 0.01, 0.003]) ** 2
        est = cls(
            world, MOUNT, bearing_std=sigma, bearing_offset=0.0, map_std=std, odometry_noise=noise,
            initial_pose=start + rng.multivariate_normal(np.zeros(3), P0), initial_covariance=P0,
            integrity=IntegrityLimits(enabled=False),
        )
        out.append(drive_nees(est, truth, gon, start, speed, omega, seconds, dt, rng, noise, sigma, 25))
    return np.array(out)


def _inside(nees: np.ndarray) -> float:
    """Share of the sampled instants whose mean over the runs lies in the 99.8 % band of chi2(3 n) / n."""
    n = nees.shape[0]
    lo, hi = chi2.ppf([0.001, 0.999], 3 * n) / n
    mean = nees.mean(axis=0)
    return float(np.mean((mean > lo) & (mean < hi)))


def test_consider_ekf_nees_consistent_with_a_survey_error_small() -> None:
    nees = _nees_runs(EkfEstimator, 16, 4.0, seed=21)
    assert _inside(nees) > 0.8 and 2.2 < nees.mean() < 3.8
    white = _nees_runs(_WhiteNoiseEkf, 16, 4.0, seed=21)  # same truth, noise and survey errors
    assert _inside(white) < 0.5 and white.mean() > 5.0


@pytest.mark.slow
def test_consider_ekf_nees_consistent_with_a_survey_error_large() -> None:
    nees = _nees_runs(EkfEstimator, 150, 8.0, seed=22)
    assert _inside(nees) > 0.8 and 2.6 < nees.mean() < 3.4


@pytest.mark.parametrize("seed", range(6))
def test_gate_takes_the_consider_update_s_and_the_index_keeps_its_reflector(seed: int) -> None:
    """``gate_one`` with ``consider``: ``S = H_a P_a H_a^T + sigma^2`` (augmented form); the index agrees."""
    world = load_builtin_map("lab")
    xy, radius = world.reflector_xy, world.reflector_radius
    n = xy.shape[0]
    rng = np.random.default_rng(seed)
    pose = np.array([6.0, 4.0, 0.3]) + rng.normal(0.0, [1.0, 1.0, 0.5])
    std = 0.005
    L = rng.normal(size=(3 + 2 * n, 3 + 2 * n)) * 1e-3
    Pa = L @ L.T
    Pa[3:, 3:] = 0.0
    Pa[3:, 3:] += std**2 * np.eye(2 * n)
    w = np.linalg.eigvalsh(Pa)
    if w.min() <= 0.0:
        Pa[:3, :3] += (1e-9 - w.min()) * np.eye(3)
    M = tuple(np.eye(3).ravel() + rng.normal(0.0, 0.2, 9))
    C = np.linalg.solve(np.reshape(M, (3, 3)), Pa[:3, 3:]).T.reshape(n, 6).copy()
    j_true = int(rng.integers(n))
    h, _, _ = bearing_model(pose, MOUNT, xy[j_true], radius[j_true])
    z = float(wrap_angle(h + rng.normal(0.0, 1e-3)))
    spec = GateSpec(bearing_var=1e-8, max_range=30.0, gate=10.8, map_std=std, sweep=0.1, consider=True)
    P = tuple(Pa[:3, :3].ravel())
    consider = (M, C, [std**2] * n)
    rows = _fast.reflector_rows(xy, radius)
    claimed = [-np.inf] * n
    got = _fast.gate_one(z, tuple(pose), P, tuple(MOUNT), rows, spec, claimed, 1.0, None, consider)
    assert got[0] == j_true
    Ha = np.zeros(3 + 2 * n)
    Ha[:3] = got[4]
    Ha[3 + 2 * j_true: 5 + 2 * j_true] = -np.asarray(got[4][:2])
    np.testing.assert_allclose(got[5], Ha @ Pa @ Ha + 1e-8, rtol=1e-9)
    cand = BearingIndex(xy, radius, MOUNT, spec).candidates(z, tuple(pose), P)
    assert _fast.gate_one(z, tuple(pose), P, tuple(MOUNT), rows, spec, claimed, 1.0, cand, consider)[:4] == got[:4]
