"""mapping.drive: the odometry covariance of a keyframe interval against a Monte Carlo of the noise it models."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.logs import RecordedLog
from agvnav.mapping.drive import (
    ODOMETRY_FLOOR,
    SLIP_LENGTH,
    odometry_poses,
    prepare_drive,
    repeated_readings,
    unit_increment_cov,
)
from agvnav.odometry import OdometryNoise


def _arc_log(dd: np.ndarray, dth: np.ndarray, noise: OdometryNoise) -> RecordedLog:
    n = dd.size
    inc = np.column_stack([dd, dth, np.zeros(n)])
    return RecordedLog(np.arange(n + 1) * 0.05, inc, np.zeros(0), np.zeros(0), np.zeros(0),
                       {"odometry_noise": [noise.k_d, noise.k_dtheta, noise.k_theta]})


def test_traction_slip_moves_the_pose_along_the_arc_as_the_monte_carlo_does() -> None:
    """A steered vehicle on a 1.5 m radius quarter circle whose traction wheel slips (each step's increment
    scaled by 1 + ε, var ε = k_d / |ΔD|: it rolls more or less of the same arc): the keyframe interval's
    covariance matches the Monte Carlo's within sampling error. Without the distance-turn correlation
    ([seed002 eq17]'s distance part alone) the heading variance and the cross terms were missing: the end heading
    varied 0.06 mrad in the draws against 0 modelled."""
    n, k_d = 160, 1e-6  # small: the draws stay in the linear regime (1e-4 adds second-order terms to x)
    dd = np.full(n, 2.36 / n)
    dth = dd / 1.5
    noise = OdometryNoise(k_d, 1e-12, 1e-12)
    drive = prepare_drive(_arc_log(dd, dth, noise), keyframe_s=1e9)
    assert drive.between_cov.shape == (1, 3, 3)
    model = drive.between_cov[0] - np.diag(ODOMETRY_FLOOR)
    rng = np.random.default_rng(5)
    ends = []
    for _ in range(4000):
        eps = rng.normal(size=n) * np.sqrt(k_d / dd)
        ends.append(odometry_poses(np.column_stack([dd * (1 + eps), dth * (1 + eps), np.zeros(n)]))[-1])
    mc = np.cov(np.array(ends).T)
    sd = np.sqrt(np.diag(mc))
    assert sd[2] > 5e-5
    # every entry within 4 sampling stds of the Monte Carlo's (var of a sample covariance ~ (C_ii C_jj + C_ij^2)/N),
    # plus 1e-3 of the largest (the radial x variance, 4 µm std, is second order)
    tol = 4.0 * np.sqrt((np.outer(np.diag(mc), np.diag(mc)) + mc ** 2) / 4000) + 1e-3 * np.abs(mc).max()
    assert np.all(np.abs(model - mc) < tol)


def test_unit_increment_cov_is_bounded_when_the_vehicle_turns_on_the_spot() -> None:
    """Straight: the slip is the distance's alone; turning on the spot (ΔD = 0): a heading variance per radian
    over SLIP_LENGTH, finite; reversing keeps the correlation's sign (the slip scales the increment)."""
    u = unit_increment_cov(np.array([0.02, 0.0, -0.02]), np.array([0.0, 0.01, -0.01]))
    np.testing.assert_allclose(u[0, 0], [[0.02, 0.0], [0.0, 0.0]])
    np.testing.assert_allclose(u[1, 0], [[0.0, 0.0], [0.0, 0.01 / SLIP_LENGTH]])
    assert u[2, 0, 0, 1] == pytest.approx(0.02 * 0.5)  # (-0.02)(-0.01) / 0.02: positive, kappa = 0.5 /m
    np.testing.assert_allclose(u[:, 1, 1, 1], [0.02, 0.0, 0.02])
    np.testing.assert_allclose(u[:, 2, 1, 1], [0.0, 0.01, 0.01])
    assert np.all(np.linalg.eigvalsh(u[:, 0]) >= -1e-15)


def test_a_run_of_identical_readings_is_one_measurement() -> None:
    """Standing 3 s at 8 Hz: two reflectors repeat their counts 24 times each, one reading of each run stays (its
    middle); a count seen again after a pause longer than 1.5 revolutions is a new run; prepare_drive drops the
    rest (and keeps them all with drop_repeats=False)."""
    stamp = np.concatenate([np.arange(24) / 8.0 + 0.01, np.arange(24) / 8.0 + 0.07, [3.01, 5.0, 5.125]])
    bearing = np.concatenate([np.full(24, 0.5), np.full(24, -1.25), [0.7, 0.5, 0.5]])
    drop = repeated_readings(stamp, bearing, 8.0)
    kept = np.flatnonzero(~drop)
    assert kept.tolist() == [12, 36, 48, 50]  # middles of the two runs, the single 0.7, the new 0.5 run's (of 2)
    n = 120
    t = np.arange(n + 1) * 0.05
    order = np.argsort(stamp, kind="stable")
    log = RecordedLog(t, np.zeros((n, 3)), stamp[order], stamp[order], bearing[order],
                      {"odometry_noise": [1e-6, 1e-6, 1e-6], "rate_hz": 8.0})
    assert prepare_drive(log, 0.0).bearing.size == 4
    assert prepare_drive(log, 0.0, drop_repeats=False).bearing.size == stamp.size
