"""A synthetic mapping drive whose truth is known exactly: odometry poses are the truth.

The vehicle drives a loop of increments (0.3 m/s, curvature varying); its true poses are the
midpoint-rule integration of those increments, which is the drive model of
:mod:`agvnav.mapping.drive`, and every reflection is stamped at an odometry instant, so a
noise-free drive is explained exactly. Noise (bearing std, odometry noise on the increments)
and clutter (uniform random bearings) are seeded.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from agvnav.logs import RecordedLog
from agvnav.mapping.drive import odometry_poses
from agvnav.odometry import OdometryNoise
from agvnav.sensors.goniometer import leading_edge_bearing

REFLECTORS = np.array([[0.0, 0.0], [10.0, -1.0], [11.0, 8.0], [4.0, 10.0], [-2.0, 6.0], [6.0, 4.5]])
RADIUS = 0.04
MOUNT = np.array([0.3, 0.0, 0.0])
START = np.array([1.0, 2.0, 0.1])


def synthetic_drive(seed: int = 0, bearing_std: float = 0.0, noise: OdometryNoise | None = None,
                    clutter_per_step: float = 0.0, steps: int = 500, every: int = 2,
                    reflectors: Any = REFLECTORS) -> tuple[RecordedLog, np.ndarray]:
    """``(log, true_poses)`` of the synthetic loop (module docstring)."""
    rng = np.random.default_rng(seed)
    dt = 0.1
    t = np.arange(steps + 1, dtype=np.float64) * dt
    dd = np.full(steps, 0.03)
    dth = 0.03 * (0.25 + 0.1 * np.sin(np.arange(steps) * 2 * np.pi / steps))  # ~ one loop, radius ~ 3-7 m
    true_inc = np.column_stack([dd, dth, np.zeros(steps)])
    poses = odometry_poses(true_inc)
    c, s = np.cos(START[2]), np.sin(START[2])
    poses = np.column_stack([START[0] + c * poses[:, 0] - s * poses[:, 1],
                             START[1] + s * poses[:, 0] + c * poses[:, 1], START[2] + poses[:, 2]])
    meas_inc = true_inc.copy()
    if noise is not None:
        meas_inc[:, 0] += rng.normal(0.0, 1.0, steps) * np.sqrt(noise.k_d * dd)
        meas_inc[:, 1] += rng.normal(0.0, 1.0, steps) * np.sqrt(noise.k_dtheta * dd + noise.k_theta * np.abs(dth))
    rt, rb = [], []
    for k in range(1, steps + 1):
        if k % every:
            continue
        head = np.array([poses[k, 0] + np.cos(poses[k, 2]) * MOUNT[0], poses[k, 1] + np.sin(poses[k, 2]) * MOUNT[0],
                         poses[k, 2]])
        b = np.ravel(leading_edge_bearing(head, reflectors, np.full(reflectors.shape[0], RADIUS))[0])
        b = b + rng.normal(0.0, bearing_std, b.shape) if bearing_std > 0 else b
        n_cl = rng.poisson(clutter_per_step) if clutter_per_step > 0 else 0
        extra = rng.uniform(-np.pi, np.pi, n_cl)
        for v in np.concatenate([b, extra]):
            rt.append(t[k])
            rb.append(float(v))
    rt_arr = np.array(rt)
    settings = {"mount": MOUNT.tolist(), "pulses_per_rev": 65535, "max_range_m": 30.0,
                "odometry_noise": list((noise or OdometryNoise(1e-6, 1e-6, 1e-6)).__dict__.values()),
                "initial_pose": START.tolist(), "bearing_offset": 0.0}  # unquantised: no half pulse
    log = RecordedLog(np.asarray(t, dtype=np.float64), meas_inc, rt_arr, rt_arr.copy(), np.array(rb), settings,
                      truth=poses)
    return log, poses


@pytest.fixture
def syn() -> SimpleNamespace:
    """The synthetic drive generator and its truth: ``drive(...)``, ``reflectors (6, 2)``, ``start (3,)``."""
    return SimpleNamespace(drive=synthetic_drive, reflectors=REFLECTORS, start=START)
