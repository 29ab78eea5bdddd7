"""Kanayama's tracking controller on lines, arcs and reverse segments."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.guidance.kanayama import KanayamaController, KanayamaGains, kanayama_law, tracking_error
from agvnav.guidance.paths import LineSegment, Path, path_from_moves


def _unicycle(pose, v, omega, dt):
    """Exact unicycle step (constant v, omega over dt)."""
    x, y, th = pose
    if abs(omega) < 1e-12:
        return np.array([x + v * dt * math.cos(th), y + v * dt * math.sin(th), th])
    th1 = th + omega * dt
    return np.array(
        [x + v / omega * (math.sin(th1) - math.sin(th)), y - v / omega * (math.cos(th1) - math.cos(th)), th1]
    )


def _drive(ctrl, pose, duration, dt=0.02):
    poses, cmds = [], []
    for k in range(round(duration / dt)):
        cmd = ctrl.command(k * dt, pose)
        pose = _unicycle(pose, cmd.v, cmd.omega, dt)
        poses.append(pose)
        cmds.append(cmd)
    return np.array(poses), cmds


@given(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), st.floats(-1.2, 1.2), st.floats(-0.4, 0.4), st.floats(-1, 1))
def test_lyapunov_derivative_matches_kanayama_formula(ex, ey, eth, vr, wr):
    g = KanayamaGains(k_x=1.3, k_y=5.0, k_theta=3.0)
    v, w = kanayama_law(np.array([ex, ey, eth]), vr, wr, g)
    dex = w * ey - v + vr * math.cos(eth)
    dey = -w * ex + vr * math.sin(eth)
    deth = wr - w
    vdot = 2 * ex * dex + 2 * ey * dey + 2 * math.sin(eth) * deth / g.k_y
    expected = -2 * g.k_x * ex**2 - 2 * abs(vr) * g.k_theta * math.sin(eth) ** 2 / g.k_y
    assert vdot == pytest.approx(expected, abs=1e-12)
    assert vdot <= 1e-12


def test_tracking_error_frame():
    e = tracking_error([1.0, 1.0, math.pi / 2], [1.0, 2.0, math.pi / 2 + 0.1])
    assert e == pytest.approx([1.0, 0.0, 0.1])


def test_line_from_lateral_offset_converges_over_design_distance():
    path = path_from_moves([0, 0, 0], [("line", 4.0)])
    ctrl = KanayamaController(KanayamaGains.from_distance(0.4), cruise_speed=0.15)
    ctrl.set_path(path)
    poses, cmds = _drive(ctrl, np.array([0.0, 0.15, 0.1]), 40.0)
    x, y = poses[:, 0], poses[:, 1]
    assert abs(y[x > 3.0]).max() < 1e-3  # (1 + s/D) exp(-s/D) 0.15 m = 7e-4 m at s = 3 m
    assert abs(y[-1]) < 1e-4 and x[-1] == pytest.approx(4.0, abs=5e-3)  # stopped at the end
    assert ctrl.finished and cmds[-1].v == pytest.approx(0.0, abs=1e-3)
    wheels = cmds[200].wheel_speeds
    assert (wheels[0] + wheels[1]) / 2 * ctrl.geometry.wheel_radius == pytest.approx(cmds[200].v)


def test_arc_is_followed_with_zero_steady_state_error():
    radius = 1.2
    path = path_from_moves([0, 0, 0], [("arc", radius, math.pi)])
    ctrl = KanayamaController(cruise_speed=0.2)
    ctrl.set_path(path)
    poses, _ = _drive(ctrl, np.array([0.0, -0.1, 0.0]), 25.0)
    centre = np.array([0.0, radius])
    r = np.hypot(poses[:, 0] - centre[0], poses[:, 1] - centre[1])
    late = np.arange(len(r)) > len(r) * 0.6
    assert np.max(np.abs(r[late] - radius)) < 1e-3


def test_reverse_segment_is_tracked_backwards():
    # forward 1.5 m, then back up 1.0 m along the same line (a cusp): the
    # second tangent points back (heading pi) and the body keeps facing +x
    path = Path([LineSegment(np.zeros(2), 0.0, 1.5, 1), LineSegment(np.array([1.5, 0.0]), math.pi, 1.0, -1)])
    ctrl = KanayamaController(cruise_speed=0.15)
    ctrl.set_path(path)
    poses, cmds = _drive(ctrl, np.array([0.0, 0.05, 0.0]), 40.0)
    vs = np.array([c.v for c in cmds])
    assert np.any(vs < -0.1)  # it really reverses
    assert np.max(np.abs(poses[vs < -0.1, 1])) < 0.02
    assert poses[-1, :2] == pytest.approx([0.5, 0.0], abs=0.01)
    assert abs(math.remainder(poses[-1, 2], 2 * math.pi)) < 0.02  # body still faces +x


def test_controller_input_checks():
    ctrl = KanayamaController()
    with pytest.raises(ValueError, match="no path"):
        ctrl.command(0.0, [0, 0, 0])
    with pytest.raises(ValueError, match="k_y"):
        KanayamaGains(k_y=-1.0)
    with pytest.raises(ValueError, match="Path"):
        ctrl.set_path("square")
