"""Odometers fed by quantised encoders follow the truth to within the quantisation."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.kinematics import DifferentialDrive, TricycleStacker
from agvnav.odometry import DifferentialOdometer, TricycleOdometer
from agvnav.sensors.encoders import SteeringEncoder, WheelEncoder


def test_differential_odometer_tracks_an_arc():
    dd = DifferentialDrive(track=0.5, wheel_radius=0.1)
    enc = WheelEncoder(4096, 0.1)
    odo = DifferentialOdometer(enc, enc, 0.5)
    u, dt = np.array([0.5, 0.3]), 0.02
    x, phi = np.zeros(3), np.zeros(2)
    odo.update(0, 0)
    traces = []
    for _ in range(500):
        x = dd.step(x, u, dt)
        phi += dd.wheel_rates(u) * dt
        odo.update(*enc.counts(phi))
        traces.append(np.trace(odo.covariance))
    assert np.hypot(*(odo.pose[:2] - x[:2])) < 5 * enc.distance_resolution
    assert abs(np.angle(np.exp(1j * (odo.pose[2] - x[2])))) < 4 * enc.distance_resolution / 0.5
    assert np.all(np.diff(traces) > 0)


def test_tricycle_odometer_tracks_a_steering_manoeuvre():
    tri = TricycleStacker(wheelbase=1.3)
    traction, steering = WheelEncoder(2048, 0.125, gear_ratio=10.0), SteeringEncoder(16384)
    odo = TricycleOdometer(traction, steering, 1.3)
    x, s_c, dt = np.array([0.0, 0.0, 0.0, 0.0]), 0.0, 0.02
    odo.update(traction.counts_for_distance(s_c), steering.counts(x[3]))
    for k in range(1000):
        u = np.array([0.4, 0.3 * np.cos(0.01 * k)])
        x = tri.step(x, u, dt)
        s_c += u[0] * dt
        odo.update(traction.counts_for_distance(s_c), steering.counts(x[3]))
    assert np.hypot(*(odo.pose[:2] - x[:2])) < 0.005


def test_odometer_rejects_bad_arguments():
    enc = WheelEncoder(100, 0.1)
    with pytest.raises(ValueError, match="rule"):
        DifferentialOdometer(enc, enc, 0.5, rule="rk4")
    with pytest.raises(ValueError, match="track"):
        DifferentialOdometer(enc, enc, 0.0)
    with pytest.raises(ValueError, match="pose"):
        DifferentialOdometer(enc, enc, 0.5, pose=[np.nan, 0, 0])
