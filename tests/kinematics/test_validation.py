"""Review fixes: the validated public path never returns a silent NaN; the kernels stay unchecked."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.kinematics import (
    Ackermann,
    DifferentialDrive,
    TricycleStacker,
    ackermann_wheel_angles,
    body_speeds,
    wheel_speeds,
)
from agvnav.odometry import differential_increments, tricycle_increments


def test_step_rejects_nan_wrong_shapes_and_bad_dt():
    tri = TricycleStacker(1.3)
    with pytest.raises(ValueError, match="input v contains NaN"):
        tri.step([0, 0, 0, 0], [np.nan, 0], 0.1)
    with pytest.raises(ValueError, match="u must have shape"):
        tri.step([0, 0, 0, 0], [1, 0, 0], 0.1)
    with pytest.raises(ValueError, match="state must have shape"):
        tri.derivative([0, 0, 0], [1, 0])
    with pytest.raises(ValueError, match="u must have shape"):
        Ackermann(2.0, 1.0).jacobian_input([0, 0, 0, 0], [1])
    with pytest.raises(ValueError, match="dt"):
        tri.step([0, 0, 0, 0], [1, 0], -1.0)
    with pytest.raises(ValueError, match="state x contains NaN"):
        DifferentialDrive(0.5).jacobian_state([np.nan, 0, 0], [1, 0])


def test_step_checks_the_resulting_state():
    tri = TricycleStacker(1.3)
    with pytest.raises(ValueError, match=r"after a step.*gamma"):
        tri.step([0, 0, 0, 0], [1, 100], 0.1)
    with pytest.raises(ValueError, match=r"after a step.*gamma"):
        tri.checked_step([0, 0, 0, 0], [1, 100], 0.1)
    # The kernel does no checking (hot loops): it integrates past the limit.
    assert tri.step_unchecked([0, 0, 0, 0], [1, 100], 0.1)[3] == pytest.approx(10.0)


def test_validated_step_equals_kernel_on_good_input():
    tri = TricycleStacker(1.3)
    x, u = np.array([1.0, 2.0, 0.3, 0.2]), np.array([0.8, 0.1])
    np.testing.assert_array_equal(tri.step(x, u, 0.05), tri.step_unchecked(x, u, 0.05))
    np.testing.assert_array_equal(tri.derivative(x, u), tri.derivative_unchecked(x, u))


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: tricycle_increments(0.1, 0.2, -1.0), "wheelbase"),
        (lambda: tricycle_increments(0.1, 0.2, 0.0), "wheelbase"),
        (lambda: tricycle_increments(0.1, np.pi / 2, 1.0), "gamma"),
        (lambda: tricycle_increments(np.nan, 0.1, 1.0), "ds_c"),
        (lambda: differential_increments(0.1, 0.2, 0.0), "track"),
        (lambda: differential_increments(0.1, np.inf, 0.5), "d_left"),
        (lambda: wheel_speeds(np.nan, 0.0, 0.5), "v"),
        (lambda: wheel_speeds(1.0, 0.0, -0.5), "track"),
        (lambda: body_speeds(1.0, 1.0, -0.5), "track"),
        (lambda: body_speeds(1.0, np.nan, 0.5), "v_left"),
        (lambda: ackermann_wheel_angles(2.0, 2.5, 1.5), "phi"),
        (lambda: ackermann_wheel_angles(0.1, 0.0, 1.5), "wheelbase"),
        (lambda: ackermann_wheel_angles(0.1, 2.5, -1.0), "track"),
    ],
)
def test_free_functions_raise_on_scalar_bad_input(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_free_functions_flag_batch_elements_without_poisoning_neighbours():
    left, right = ackermann_wheel_angles([0.1, 2.0, np.nan, -0.2], 2.5, 1.5)
    assert np.isnan(left[1:3]).all() and np.isnan(right[1:3]).all()
    assert np.isfinite(left[[0, 3]]).all() and np.isfinite(right[[0, 3]]).all()
    dd, dth = tricycle_increments([0.1, 0.1, 0.1], [0.2, 1.6, 0.0], 1.3)
    assert np.isnan(dd[1]) and np.isnan(dth[1]) and np.isfinite(dd[[0, 2]]).all()
    assert dd[0] == pytest.approx(0.1 * np.cos(0.2)) and dth[0] == pytest.approx(0.1 * np.sin(0.2) / 1.3)
