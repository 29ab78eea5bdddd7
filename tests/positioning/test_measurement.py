"""Measurement models: analytic Jacobians against central finite differences, models against their oracles."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from agvnav.geometry import angle_diff
from agvnav.positioning.edge_bearing import bearing_model
from agvnav.positioning.measurement import BearingMeasurement, MeasurementModel, WallRangeMeasurement

coord = st.floats(-20.0, 20.0, allow_nan=False)
angle = st.floats(-math.pi, math.pi, allow_nan=False)


def _fd(model: MeasurementModel, x: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """Central differences of ``h`` (residuals wrapped for angles)."""
    out = np.empty(3)
    for i in range(3):
        d = np.zeros(3)
        d[i] = eps
        out[i] = model.residual(model.h(tuple(x + d)), model.h(tuple(x - d))) / (2 * eps)
    return out


@settings(max_examples=60, deadline=None)
@given(coord, coord, angle, coord, coord, st.floats(0.0, 0.1), st.floats(-0.8, 0.8), st.floats(-0.5, 0.5), angle)
def test_bearing_jacobian_against_finite_differences(
    x: float, y: float, psi: float, rx: float, ry: float, r: float, mx: float, my: float, mth: float
) -> None:
    pose = np.array([x, y, psi])
    model = BearingMeasurement((rx, ry, r), (mx, my, mth), 1e-6)
    head = pose[:2] + np.array([[math.cos(psi), -math.sin(psi)], [math.sin(psi), math.cos(psi)]]) @ [mx, my]
    d = math.hypot(rx - head[0], ry - head[1])
    if d < max(1.0, 3 * r):  # away from the reflector (h is singular on it)
        return
    np.testing.assert_allclose(model.jacobian(tuple(pose)), _fd(model, pose), rtol=1e-5, atol=1e-7)


@settings(max_examples=40, deadline=None)
@given(coord, coord, angle, coord, coord, st.floats(0.0, 0.1))
def test_bearing_consider_jacobian_against_finite_differences(
    x: float, y: float, psi: float, rx: float, ry: float, r: float
) -> None:
    pose = (x, y, psi)
    model = BearingMeasurement((rx, ry, r), (0.6, 0.0, 0.0), 1e-6)
    head = (x + 0.6 * math.cos(psi), y + 0.6 * math.sin(psi))
    if math.hypot(rx - head[0], ry - head[1]) < max(1.0, 3 * r):
        return
    eps = 1e-6
    fd = []
    for dx, dy in ((eps, 0.0), (0.0, eps)):
        plus = BearingMeasurement((rx + dx, ry + dy, r), (0.6, 0.0, 0.0), 1e-6).h(pose)
        minus = BearingMeasurement((rx - dx, ry - dy, r), (0.6, 0.0, 0.0), 1e-6).h(pose)
        fd.append(angle_diff(plus, minus) / (2 * eps))
    np.testing.assert_allclose(model.consider_jacobian(pose), fd, rtol=1e-5, atol=1e-7)


@given(coord, coord, angle, coord, coord, st.floats(0.0, 0.1))
def test_bearing_model_is_the_vectorised_oracle(x: float, y: float, psi: float, rx: float, ry: float, r: float) -> None:
    mount = (0.6, 0.1, 0.2)
    model = BearingMeasurement((rx, ry, r), mount, 1e-6)
    if math.hypot(rx - x, ry - y) < 1.5:
        return
    h, H, _ = bearing_model(np.array([x, y, psi]), np.array(mount), np.array([[rx, ry]]), np.array([r]))
    assert abs(angle_diff(model.h((x, y, psi)), float(h[0]))) < 1e-12
    np.testing.assert_allclose(model.jacobian((x, y, psi)), H[0], rtol=1e-10, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(coord, coord, angle, st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), angle, angle, st.sampled_from(["cone", "ray"]))
def test_wall_range_jacobian_against_finite_differences(
    x: float, y: float, psi: float, xs: float, ys: float, phi: float, wall_dir: float, beam: str
) -> None:
    n = (math.cos(wall_dir), math.sin(wall_dir))
    pose = np.array([x, y, psi])
    c = -30.0  # the line n . q = -30, far behind every pose: the normal points to the sensor
    model = WallRangeMeasurement((xs, ys, phi), n, c, 1e-4, beam)
    if beam == "ray":  # the ray model needs the axis to face the wall (g = -n . b well away from 0)
        g = -(n[0] * math.cos(psi + phi) + n[1] * math.sin(psi + phi))
        if g < 0.2:
            return
    assert model.residual(1.0, 0.25) == 0.75
    np.testing.assert_allclose(model.jacobian(tuple(pose)), _fd(model, pose), rtol=1e-5, atol=1e-6)
    assert model.consider_jacobian(tuple(pose)) == (0.0, 0.0) and model.consider_index == -1
