"""agvnav.odometry.noise_kernels: the one kernel of the odometry variances [seed002 eq17]."""

from __future__ import annotations

import numpy as np

from agvnav.odometry import OdometryNoise, increment_variances, increment_variances_array


def test_the_kernel_is_crowley_s_variances_by_hand() -> None:
    """``var_d = K_D |s|``, ``var_th = K_Dθ |s| + K_θ |Δθ|`` on hand values (backwards and turning right)."""
    var_d, var_th = increment_variances(-0.5, -0.2, 1e-3, 3e-3, 2e-3)
    assert np.isclose(var_d, 5e-4, rtol=1e-15, atol=0.0)
    assert np.isclose(var_th, 1.5e-3 + 4e-4, rtol=1e-15, atol=0.0)


def test_the_batch_form_and_the_increment_covariance_are_the_kernel() -> None:
    """The NumPy batch form and ``OdometryNoise.increment_covariance`` give the kernel's numbers."""
    rng = np.random.default_rng(3)
    dd, dth = rng.uniform(-2.0, 2.0, 200), rng.uniform(-1.0, 1.0, 200)
    noise = OdometryNoise(2e-3, 5e-3, 1e-3)
    var_d, var_th = increment_variances_array(dd, dth, noise.k_d, noise.k_dtheta, noise.k_theta)
    cov = noise.increment_covariance(dd, dth)
    k = (noise.k_d, noise.k_dtheta, noise.k_theta)
    want = np.array([increment_variances(a, b, *k) for a, b in zip(dd, dth, strict=True)])
    np.testing.assert_allclose(np.column_stack([var_d, var_th]), want, rtol=1e-14, atol=0.0)
    np.testing.assert_array_equal(cov[:, 0, 0], var_d)
    np.testing.assert_array_equal(cov[:, 1, 1], var_th)
    assert np.all(cov[:, 0, 1] == 0.0) and np.all(cov[:, 1, 0] == 0.0)
    assert increment_variances_array(0.3, dth[:4], 1e-3, 1e-3, 1e-3)[0].shape == (4,)  # broadcast
