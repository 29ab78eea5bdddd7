"""The goniometer scan's grid and encoder fast path, and the compiled crossing kernels against ground truth."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.geometry import wrap_angle
from agvnav.sensors import Goniometer
from agvnav.sensors.goniometer import Reflections, _bracket_grid, leading_edge_bearing
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


def test_compiled_crossings_solve_the_crossing_equation() -> None:
    """Every reported instant is where the head angle meets the leading edge (public NumPy form).

    The compiled kernels of :mod:`agvnav.sensors.beam` find the instants; the check uses
    :func:`leading_edge_bearing` and :meth:`Goniometer.head_angle`, another formulation.
    """
    world = load_builtin_map("lab")
    g = Goniometer(mount=(0.3, 0.05, 0.02))

    def pose_at(t):
        t = np.asarray(t, dtype=np.float64)
        return np.stack([4.0 + 0.8 * t, 3.0 + 0.5 * np.sin(t), 0.3 + 0.4 * t], axis=-1)

    parts = [g.scan(world, pose_at, 0.05 * k, 0.05 * (k + 1)) for k in range(60)]
    out = Reflections.concatenate(parts)
    assert len(out) > 100
    head = g.head_pose(pose_at(out.t))
    edge, _, valid = leading_edge_bearing(head, world.reflector_xy[out.reflector_index],
                                          world.reflector_radius[out.reflector_index])
    assert valid.all()
    beam = wrap_angle(g.head_angle(out.t))  # head angle in the head frame
    np.testing.assert_allclose(wrap_angle(beam - edge), 0.0, atol=1e-9)
    # the quantised bearing is the encoder reading at that instant, one step below the beam
    assert np.all(wrap_angle(beam - out.bearing) < g.resolution + 1e-12)
