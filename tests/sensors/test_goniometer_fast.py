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


def test_seen_in_order_is_the_stable_argsort_of_the_seen_crossings() -> None:
    """The scan's last step: the seen crossings in time order, equal instants in their order (as argsort stable)."""
    from agvnav.sensors.beam import seen_in_order

    rng = np.random.default_rng(4)
    for n in (0, 1, 2, 5, 40):
        t = np.round(rng.uniform(0.0, 0.05, n), 3)  # rounded: ties
        refl, seen = rng.integers(0, 9, n).astype(np.int64), rng.uniform(size=n) < 0.7
        order = np.argsort(t[seen], kind="stable")
        ts, rs = seen_in_order(t, refl, seen)
        np.testing.assert_array_equal(ts, t[seen][order])
        np.testing.assert_array_equal(rs, refl[seen][order])


def test_chord_step_clips_to_the_bracket_and_stops_within_tolerance() -> None:
    """One chord iteration: converged instants come back unchanged, the others move by -f/slope inside [lo, hi]."""
    from agvnav.sensors.beam import chord_step, offsets_at

    t = np.array([0.01, 0.02, 0.03])
    pose = np.zeros((3, 3))
    rx, ry, r = np.array([3.0, 0.0, -2.0]), np.array([0.5, 4.0, -1.0]), np.full(3, 0.04)
    head = (0.0, 0.0, 0.0, 2.0 * np.pi * 8.0)
    lo, hi, slope = t - 0.005, t + 0.005, np.full(3, 2.0 * np.pi * 8.0)
    raw = offsets_at(t, pose, rx, ry, r, *head, 1)[0]
    f = wrap_angle(raw)
    done, nxt, *_ = chord_step(t, pose, rx, ry, r, *head, 1, slope, lo, hi, 1e-10)
    assert not done
    np.testing.assert_array_equal(nxt, np.minimum(np.maximum(t - f / slope, lo), hi))
    done, same, *_ = chord_step(t, pose, rx, ry, r, *head, 1, slope, lo, hi, 10.0)
    assert done and np.array_equal(same, t)


@pytest.mark.parametrize("mount, direction", [((0.3, 0.0, 0.0), 1), ((0.2, -0.1, 0.4), -1)])
def test_the_fused_twist_scan_equals_the_generic_scan(mount: tuple, direction: int) -> None:
    """scan_motion on a plant's constant-twist sub-steps gives the generic path's reflections bit for bit."""
    from agvnav import _jit
    from agvnav.kinematics.twist import TwistPoses, twist_pose

    world = load_builtin_map("lab")
    g = Goniometer(mount=mount, direction=direction, p_miss=0.1, spurious_rate=0.5, jitter_std=1e-4)
    rng = np.random.default_rng(5)
    before = _jit.compiled()
    _jit.set_compiled(True)
    try:
        pose = (10.0, 6.0, 0.3)
        for k in range(120):  # a wandering drive through the lab, 0.05 s steps of five sub-steps
            t0 = 0.05 * k
            twists = np.column_stack([rng.uniform(0.2, 1.0, 5), np.zeros(5), rng.uniform(-1.0, 1.0, 5)])
            states = [pose]
            for tw in twists:
                states.append(twist_pose(*states[-1], *tw, 0.01))
            poses = TwistPoses(np.array(states), twists, t0, 0.01)
            pose = states[-1]
            fused = g.scan(world, poses, t0, t0 + 0.05, np.random.default_rng(k))
            generic = g.scan(world, lambda t, p=poses: p(t), t0, t0 + 0.05, np.random.default_rng(k))
            assert fused == generic
    finally:
        _jit.set_compiled(before)


@pytest.mark.parametrize("mount, direction", [((0.3, 0.0, 0.0), 1), ((0.2, -0.1, 0.4), -1)])
def test_the_fused_hermite_scan_equals_the_generic_scan(mount: tuple, direction: int) -> None:
    """scan_motion (one compiled call) gives the generic path's reflections bit for bit, and its errors."""
    from agvnav import _jit
    from agvnav.geometry.hermite import HermitePoses

    world = load_builtin_map("lab")
    g = Goniometer(mount=mount, direction=direction, p_miss=0.1, spurious_rate=0.5, jitter_std=1e-4)
    rng = np.random.default_rng(2)
    before = _jit.compiled()
    _jit.set_compiled(True)
    try:
        for k in range(120):  # a wandering drive through the lab, 0.05 s steps
            t0 = 0.05 * k
            p0 = np.array([10.0 + np.cos(0.1 * k), 6.0 + np.sin(0.13 * k), 0.2 * k])
            table = np.array([p0, rng.normal(0.0, 0.05, 3), p0 + rng.normal(0.0, 0.04, 3), rng.normal(0.0, 0.05, 3)])
            poses = HermitePoses(table, t0, 0.05)
            fused = g.scan(world, poses, t0, t0 + 0.05, np.random.default_rng(k))
            generic = g.scan(world, lambda t, p=poses: p(t), t0, t0 + 0.05, np.random.default_rng(k))
            assert fused == generic
        bad = HermitePoses(np.full((4, 3), np.nan), 0.0, 0.05)
        with pytest.raises(ValueError, match="NaN or inf"):
            g.scan(world, bad, 0.0, 0.05, rng)
    finally:
        _jit.set_compiled(before)
