"""The SE(2) exponential's kernels (kinematics.twist) against a NumPy oracle and against each other."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.kinematics import twist_step
from agvnav.kinematics.twist import (
    fleet_twist_poses,
    fleet_twist_tables,
    twist_log,
    twist_pose,
    twist_table_poses,
)
from agvnav.vehicles.motion import piecewise_twist_pose


def _exp_oracle(pose: np.ndarray, vx: np.ndarray, vy: np.ndarray, w: np.ndarray, dt: np.ndarray) -> np.ndarray:
    """The SE(2) exponential in NumPy, written independently: V(dth) (dx, dy) with V = sinc(h) R(h), h = dth/2."""
    dth = w * dt
    h = 0.5 * dth
    small = np.abs(h) < 1e-6
    sinc = np.where(small, 1.0 - h * h / 6.0, np.sin(np.where(small, 1.0, h)) / np.where(small, 1.0, h))
    mid = pose[..., 2] + h
    fwd, lat = sinc * vx * dt, sinc * vy * dt
    return np.stack([pose[..., 0] + np.cos(mid) * fwd - np.sin(mid) * lat,
                     pose[..., 1] + np.sin(mid) * fwd + np.cos(mid) * lat, pose[..., 2] + dth], axis=-1)


def test_twist_step_equals_the_oracle_over_broadcast_batches() -> None:
    rng = np.random.default_rng(1)
    pose = np.column_stack([rng.uniform(-10, 10, (200, 2)), rng.uniform(-7, 7, 200)]).reshape(20, 10, 3)
    vx, vy = rng.uniform(-3, 3, (2, 20, 10))
    w = np.where(rng.uniform(size=(20, 10)) < 0.2, rng.uniform(-1e-7, 1e-7, (20, 10)), rng.uniform(-5, 5, (20, 10)))
    dt = rng.uniform(1e-4, 0.5, 10)  # broadcast along the last axis
    got = twist_step(pose, vx, vy, w, dt)
    assert got.shape == (20, 10, 3)
    np.testing.assert_allclose(got, _exp_oracle(pose, vx, vy, w, dt), rtol=0, atol=1e-12)
    scalar = twist_step(np.array([1.0, 2.0, 0.3]), 0.5, 0.0, 1e-6, 0.1)  # the series branch, one pose
    np.testing.assert_allclose(scalar, [1.0 + 0.05 * math.cos(0.3 + 5e-8), 2.0 + 0.05 * math.sin(0.3 + 5e-8),
                                        0.3 + 1e-7], atol=1e-15)
    with pytest.raises(ValueError, match="trailing length"):
        twist_step(np.zeros(2), 1.0, 0.0, 0.0, 0.1)


def test_twist_log_inverts_the_exponential() -> None:
    rng = np.random.default_rng(2)
    for _ in range(500):
        x, y, th = rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-20, 20)
        vx, vy, w = rng.uniform(-2, 2), rng.uniform(-1, 1), rng.choice([rng.uniform(-3, 3), 1e-9])
        x1, y1, th1 = twist_pose(x, y, th, vx, vy, w, 1.0)
        assert twist_log(x, y, th, x1, y1, th1) == pytest.approx((vx, vy, w), abs=1e-9)
        # a heading given wrapped is the same turn
        wrapped = math.remainder(th1, 2 * math.pi)
        assert twist_log(x, y, th, x1, y1, wrapped) == pytest.approx((vx, vy, w), abs=1e-9)


def _table(rng: np.random.Generator, n: int, h: float) -> tuple[np.ndarray, np.ndarray]:
    twists = np.column_stack([rng.uniform(-1, 1, n), rng.uniform(-0.2, 0.2, n), rng.uniform(-2, 2, n)])
    states = [np.array([rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-3, 3)])]
    for tw in twists:
        states.append(_exp_oracle(states[-1], tw[0], tw[1], tw[2], h))
    return np.array(states), twists


def test_a_table_s_poses_are_each_sub_step_s_exponential_clipped_to_the_step() -> None:
    rng = np.random.default_rng(3)
    h, t0 = 0.01, 4.0
    states, twists = _table(rng, 5, h)
    t = np.concatenate([rng.uniform(t0, t0 + 0.05, 100), [t0 - 1.0, t0, t0 + 0.03, t0 + 0.05, t0 + 9.0]])
    got = piecewise_twist_pose(t, t0, h, states, twists)
    rel = np.clip(t - t0, 0.0, 0.05)
    i = np.minimum((rel / h).astype(int), 4)
    want = _exp_oracle(states[i], twists[i, 0], twists[i, 1], twists[i, 2], rel - i * h)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got[-5:], states[[0, 0, 3, 5, 5]], atol=1e-12)  # boundaries and clipping


def test_the_fleet_kernel_gives_each_vehicle_s_own_table_and_the_sampled_tables_are_exact() -> None:
    rng = np.random.default_rng(4)
    h, n = 0.01, 6
    tables = [_table(rng, 5, h) for _ in range(n)]
    states = np.stack([s for s, _ in tables])
    twists = np.stack([w for _, w in tables])
    t0 = rng.uniform(0, 10, n)
    rows = rng.integers(0, n, 300)
    t = t0[rows] + rng.uniform(-0.01, 0.06, 300)
    got = fleet_twist_poses(states, twists, np.full(n, 5), t0, np.full(n, h), rows, t)
    for r in range(n):
        mine = rows == r
        np.testing.assert_array_equal(got[mine], twist_table_poses(states[r], twists[r], t0[r], h, t[mine]))
    # the twists recovered from the boundary poses give the same motion (the fleet's bodies)
    back = np.zeros_like(twists)
    fleet_twist_tables(states, h, back)
    np.testing.assert_allclose(back, twists, atol=1e-9)
    again = fleet_twist_poses(states, back, np.full(n, 5), t0, np.full(n, h), rows, t)
    np.testing.assert_allclose(again, got, atol=1e-10)
