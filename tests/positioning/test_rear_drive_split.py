"""A rear-drive increment past the steering limit does not blow the steered-wheel model up (issue 12 review).

When a reflection arrives just before the next odometry message the estimator extrapolates
to it at the last rate and integrates the remainder with the next message: on a straight
followed by a message steering 10 deg, the remainder is ``dD ~ 1 um`` with the whole step's
``dtheta``. Its implied steering angle is ~90 deg, beyond what the vehicle steers, and the
rear-drive terms ``dtheta^2 / |dD|`` used to take the heading std from 0.29 deg to 140 deg.
The model now takes such an increment at the steering limit (``|s| >= L |dtheta| / tan g_max``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.odometry import motion_covariance, steered_noise
from agvnav.positioning import _fast
from agvnav.positioning.ekf import EkfEstimator
from agvnav.positioning.integrity import IntegrityLimits
from agvnav.world import load_builtin_map

L = 1.2
G_MAX = math.radians(80.0)


def _noise(max_steering: float = G_MAX):  # type: ignore[no-untyped-def]
    return steered_noise("tricycle_rear", 1e-4, L, math.radians(0.05), 0.025, 0.003, math.radians(0.2), max_steering)


def _heading_std(reflection_gap_s: float) -> float:
    """Straight at 0.5 m/s (20 Hz odometry) for 2 s, then a reflection ``gap`` before a message steering 10 deg."""
    world = load_builtin_map("lab")
    P0 = np.diag([0.01, 0.01, math.radians(0.2)]) ** 2
    est = EkfEstimator(world, (0.0, 0.0, 0.0), bearing_std=2e-4, bearing_offset=0.0, map_std=0.0,
                       odometry_noise=_noise(), initial_pose=(3.0, 2.0, 0.0), initial_covariance=P0,
                       integrity=IntegrityLimits(enabled=False))
    dt, v = 0.05, 0.5
    est.predict(0.0, 0.0, 0.0)
    t = 0.0
    for _ in range(40):
        t += dt
        est.predict(t, v * dt, 0.0)
    if reflection_gap_s > 0.0:
        est.update(t + dt - reflection_gap_s, 1.0)  # rejected or not, the estimator extrapolates to it first
    est.predict(t + dt, v * dt, v * dt * math.tan(math.radians(10.0)) / L)
    return math.degrees(math.sqrt(est.covariance[2, 2]))


def test_reflection_just_before_a_steering_message_keeps_the_heading_std() -> None:
    plain = _heading_std(0.0)
    split = _heading_std(2e-6)
    assert plain < 0.5
    assert split == pytest.approx(plain, abs=0.05)  # was 140 deg


def test_the_increment_is_taken_at_the_steering_limit() -> None:
    noise = _noise()
    dd, dth = 1e-6, 0.0037
    s_min = L * dth / math.tan(G_MAX)
    assert noise.driven_distance(dd, dth) == pytest.approx(s_min, rel=1e-12)
    # the same as an increment of that distance at the limit, in the heading variance
    at_limit = motion_covariance(np.zeros(3), s_min, dth, noise)
    split = motion_covariance(np.zeros(3), dd, dth, noise)
    assert split[2, 2] == pytest.approx(at_limit[2, 2], rel=1e-3)
    assert np.all(np.isfinite(split))
    # within the limit nothing changes: 30 deg of steering, against the unlimited model
    dd, dth = 0.02, 0.02 * math.tan(math.radians(30.0)) / L
    np.testing.assert_array_equal(motion_covariance(np.zeros(3), dd, dth, noise),
                                  motion_covariance(np.zeros(3), dd, dth, _noise(math.pi / 2)))


@pytest.mark.parametrize("max_steering", [G_MAX, math.pi / 2])
def test_zero_distance_with_a_turn_is_not_silent(max_steering: float) -> None:
    noise = _noise(max_steering)
    dth = 0.004
    Q = motion_covariance(np.array([1.0, 2.0, 0.3]), 0.0, dth, noise)
    assert Q[2, 2] > 0.0 and np.all(np.isfinite(Q))
    Qk, W = _fast.steered_noise(0.3, 0.0, dth, False, L, noise.slip_k, noise.steering_std**2 * noise.step_m,
                                noise.min_roll_per_rad)
    np.testing.assert_allclose(np.reshape(Qk, (3, 3)), Q, rtol=1e-12, atol=1e-20)
    if max_steering >= math.pi / 2:  # nothing in the wheel model explains the turn: Crowley's bound
        assert Q[2, 2] == pytest.approx(noise.k_theta * dth, rel=1e-12)
        assert W == (0.0,) * 6
    # dD = 0 and dtheta = 0: standing, nothing
    Q0, W0 = _fast.steered_noise(0.3, 0.0, 0.0, False, L, noise.slip_k, 1e-8, noise.min_roll_per_rad)
    assert Q0 == (0.0,) * 9 and W0 == (0.0,) * 6


def test_max_steering_is_validated() -> None:
    with pytest.raises(ValueError, match="max_steering_rad"):
        _noise(0.0)
    with pytest.raises(ValueError, match="max_steering_rad"):
        _noise(2.0)
