"""The goniometer scan's scalar fast paths are bit-identical to the vectorised forms."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.sensors import Goniometer
from agvnav.sensors import goniometer as gmod
from agvnav.sensors.goniometer import _bracket_grid
from agvnav.world import load_builtin_map


@pytest.mark.parametrize("t0, t1", [(0.0, 0.05), (12.35, 12.4), (3599.95, 3600.0), (1.0, 1.7), (0.2, 0.2000001)])
def test_bracket_grid_equals_linspace(t0: float, t1: float) -> None:
    for n in (1, 2, 3, 7, 23):
        ref = np.array([t0, t1]) if n == 1 else np.linspace(t0, t1, n + 1)
        np.testing.assert_array_equal(_bracket_grid(t0, t1, n), ref)


@pytest.mark.parametrize("direction, phase", [(1, 0.0), (-1, 1.3), (1, -2.0)])
def test_encoder_bearing_few_equals_vectorised(direction: int, phase: float) -> None:
    g = Goniometer(rate_hz=8.0, pulses_per_rev=65535, direction=direction, phase=phase)
    t = np.random.default_rng(3).uniform(0.0, 3600.0, 8)
    t[:2] = [0.0, 1.0 / 8.0]
    np.testing.assert_array_equal(g._encoder_bearing_few(t), g.encoder_bearing(t))
    np.testing.assert_array_equal(g._encoder_bearing_few(t[:0]), g.encoder_bearing(t[:0]))


def _scan_drive(monkeypatch, few: int):
    """A moving, turning head scanned in 50 ms windows; ``few`` selects the root finder's branch."""
    monkeypatch.setattr(gmod, "_FEW", few)
    world = load_builtin_map("lab")
    g = Goniometer(mount=(0.3, 0.05, 0.02))

    def pose_at(t):
        t = np.asarray(t, dtype=np.float64)
        return np.stack([4.0 + 0.8 * t, 3.0 + 0.5 * np.sin(t), 0.3 + 0.4 * t], axis=-1)

    return [g.scan(world, pose_at, 0.05 * k, 0.05 * (k + 1)) for k in range(60)]


def test_scalar_root_finder_matches_the_vectorised_one(monkeypatch) -> None:
    few = _scan_drive(monkeypatch, 8)
    vec = _scan_drive(monkeypatch, 0)
    assert sum(len(p) for p in few) > 100
    for a, b in zip(few, vec, strict=True):
        np.testing.assert_array_equal(a.reflector_index, b.reflector_index)
        np.testing.assert_allclose(a.t, b.t, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(a.bearing, b.bearing)
