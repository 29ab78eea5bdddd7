"""The safety scanner's compiled ray caster (sensors.scanner.ray_ranges) against a NumPy oracle."""

from __future__ import annotations

import math

import numpy as np

from agvnav.sensors.scanner import cast_rays


def _cast_oracle(p: np.ndarray, a: np.ndarray, seg: np.ndarray, circ: np.ndarray,
                 max_range: float) -> tuple[np.ndarray, np.ndarray]:
    """Every ray against every surface in NumPy (no broad phase), the module docstring's equations."""
    dx, dy = np.cos(a), np.sin(a)
    k, n = a.shape
    best, hit = np.full((k, n), np.inf), np.full((k, n), -1)
    if seg.shape[0]:
        ax, ay = seg[:, 0, 0], seg[:, 0, 1]
        ex, ey = seg[:, 1, 0] - ax, seg[:, 1, 1] - ay
        wx, wy = ax[None, :] - p[:, 0:1], ay[None, :] - p[:, 1:2]
        denom = dx[:, :, None] * ey - dy[:, :, None] * ex
        safe = np.where(denom != 0.0, denom, 1.0)
        r = (wx[:, None, :] * ey - wy[:, None, :] * ex) / safe
        u = (wx[:, None, :] * dy[:, :, None] - wy[:, None, :] * dx[:, :, None]) / safe
        r = np.where((denom != 0.0) & (r >= 0.0) & (u >= 0.0) & (u <= 1.0), r, np.inf)
        j = np.argmin(r, axis=-1)
        best = np.take_along_axis(r, j[..., None], axis=-1)[..., 0]
        hit = np.where(np.isfinite(best), j, -1)
    if circ.shape[0]:
        fx, fy = p[:, 0:1] - circ[None, :, 0], p[:, 1:2] - circ[None, :, 1]
        c0 = fx * fx + fy * fy - circ[None, :, 2] ** 2
        b = dx[:, :, None] * fx[:, None, :] + dy[:, :, None] * fy[:, None, :]
        disc = b * b - c0[:, None, :]
        sq = np.sqrt(np.maximum(disc, 0.0))
        r = np.where(-b - sq >= 0.0, -b - sq, np.where(-b + sq >= 0.0, 0.0, np.inf))
        r = np.where(disc >= 0.0, r, np.inf)
        j = np.argmin(r, axis=-1)
        rmin = np.take_along_axis(r, j[..., None], axis=-1)[..., 0]
        better = rmin < best
        best, hit = np.where(better, rmin, best), np.where(better, seg.shape[0] + j, hit)
    far = best > max_range
    return np.where(far, np.inf, best), np.where(far, -1, hit)


def test_the_kernel_equals_the_oracle_on_random_scenes_with_and_without_a_reach() -> None:
    rng = np.random.default_rng(8)
    for trial in range(30):
        m, c, k = int(rng.integers(0, 40)), int(rng.integers(0, 6)), int(rng.integers(1, 4))
        a0 = rng.uniform(-15, 15, (m, 2))
        seg = np.stack([a0, a0 + rng.uniform(-4, 4, (m, 2))], axis=1)
        if m > 3:
            seg[1, 1] = seg[1, 0]  # a degenerate segment
            seg[2, 1, 1] = seg[2, 0, 1]  # a horizontal one
        circ = np.column_stack([rng.uniform(-10, 10, (c, 2)), rng.uniform(0.1, 1.0, c)])
        origins = rng.uniform(-8, 8, (k, 2))
        angles = rng.uniform(-math.pi, math.pi, (k, 1))[:, :] + np.radians(np.arange(0.0, 360.0, 1.0))[None, :]
        angles[:, :4] = 0.0  # axis-parallel rays meet the horizontal segment edge-on
        reach = math.inf if trial % 3 == 0 else float(rng.uniform(2.0, 12.0))
        got_r, got_h = cast_rays(origins, angles, seg, circ, reach)
        want_r, want_h = _cast_oracle(origins, angles, seg.reshape(-1, 2, 2), circ, reach)
        np.testing.assert_array_equal(np.isfinite(got_r), np.isfinite(want_r))
        np.testing.assert_allclose(got_r[np.isfinite(got_r)], want_r[np.isfinite(want_r)], rtol=1e-12, atol=1e-12)
        same = got_h == want_h  # a tie between two surfaces within rounding may name either
        assert same.mean() > 0.999
        np.testing.assert_allclose(got_r[~same], want_r[~same], atol=1e-9)


def test_measure_equals_the_oracle_scan_with_the_same_noise() -> None:
    """The compiled scan (mount, rays, noise, echoes in base_link) against the oracle from the same draws."""
    from agvnav.geometry import compose
    from agvnav.sensors.scanner import SafetyScanner

    rng = np.random.default_rng(12)
    sc = SafetyScanner(mount=(0.4, 0.1, 0.2), max_range=6.0, noise_std=0.05)
    a0 = rng.uniform(-8, 8, (30, 2))
    seg = np.stack([a0, a0 + rng.uniform(-3, 3, (30, 2))], axis=1)
    circ = np.array([[1.0, 1.0, 0.3], [-2.0, 0.5, 0.6]])
    poses = np.column_stack([rng.uniform(-3, 3, (4, 2)), rng.uniform(-40, 40, 4)])
    ranges, hit, points = sc.measure(poses, seg, circ, np.random.default_rng(1))
    head = compose(poses, np.array(sc.mount))
    exact, want_hit = _cast_oracle(head[:, :2], head[:, 2:3] + sc.angles[None, :], seg, circ, sc.max_range)
    noisy = np.where(np.isfinite(exact), np.maximum(exact + np.random.default_rng(1).standard_normal(exact.shape)
                                                    * sc.noise_std, 0.0), np.inf)
    noisy = np.where(noisy > sc.max_range, np.inf, noisy)
    np.testing.assert_allclose(ranges[np.isfinite(noisy)], noisy[np.isfinite(noisy)], atol=1e-9)
    np.testing.assert_array_equal(np.isfinite(ranges), np.isfinite(noisy))
    np.testing.assert_array_equal(hit, np.where(np.isfinite(noisy), want_hit, -1))
    ang = sc.mount[2] + sc.angles
    want_points = np.stack([sc.mount[0] + noisy * np.cos(ang), sc.mount[1] + noisy * np.sin(ang)], axis=-1)
    fin = np.isfinite(noisy)
    np.testing.assert_allclose(points[fin], want_points[fin], atol=1e-9)
    assert np.isnan(points[~fin]).all()
