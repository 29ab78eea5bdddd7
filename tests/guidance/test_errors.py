"""Errors of seed 000 Fig. 5 (eqs 9-10) and the curvature feed-forward, against hand values."""

import math

import numpy as np
import pytest
from _guidance_sim import rk4_step, tricycle_derivative

from agvnav.guidance import (
    LineSegment,
    Path,
    feedforward_steering,
    path_from_moves,
    point_c,
    tracking_errors,
    tracking_errors_scalar,
)
from agvnav.kinematics.tricycle import TricycleStacker

L = 1.1


def line(direction=1):
    return Path([LineSegment(np.array([-10.0, 0.0]), 0.0, 30.0, direction)])


@pytest.mark.parametrize("point", ["O", "C"])
def test_line_errors_hand_values(point):
    pose, gamma = np.array([1.0, 0.1, 0.2]), 0.15
    e = tracking_errors(line(), pose, gamma, L, point=point)
    # on a line both points share the path: the derived error is the true one
    assert e.eps_o == pytest.approx(0.1)
    assert e.eps_c == pytest.approx(0.1 + L * math.sin(0.2))  # y of C
    assert e.xi == pytest.approx(0.2)
    assert e.xi_r == pytest.approx(0.35)  # eq. 9
    assert e.gamma_ss == 0.0
    expected_s = 11.0 if point == "O" else 11.0 + L * math.cos(0.2)
    assert e.s == pytest.approx(expected_s)


def test_reverse_line_errors_are_in_the_reference_body_frame():
    # reverse: the body points against the tangent (psi_ref = pi); left of the body = -y
    pose = np.array([1.0, 0.1, math.pi + 0.2])
    e = tracking_errors(line(-1), pose, 0.05, L, point="O")
    assert e.eps_o == pytest.approx(-0.1)
    assert e.xi == pytest.approx(0.2)
    assert e.xi_r == pytest.approx(0.25)
    # eq. 10 gives the true lateral position of C, measured the same way
    c = point_c(pose, L)
    assert e.eps_c == pytest.approx(-c[1])


def test_arc_errors_for_point_o_hand_values():
    R, d_off, theta = 2.0, 0.05, 0.4  # left arc, centre (0, R), O outside by d_off
    p = path_from_moves([0.0, 0.0, 0.0], [("arc", R, math.pi)])
    rho = R + d_off
    pos = np.array([rho * math.sin(theta), R - rho * math.cos(theta)])
    psi = theta + 0.03
    e = tracking_errors(p, np.array([*pos, psi]), 0.3, L, point="O")
    assert e.s == pytest.approx(R * theta)
    assert e.eps_o == pytest.approx(-d_off)  # outside a left turn = right
    assert e.xi == pytest.approx(0.03)
    assert e.gamma_ss == pytest.approx(math.atan(L / R))
    assert e.xi_r == pytest.approx(0.03 + 0.3 - math.atan(L / R))
    assert e.eps_c == pytest.approx(-d_off + L * math.sin(0.03))


@pytest.mark.parametrize("direction", [1, -1])
def test_steady_turn_of_c_has_zero_errors(direction):
    R_c = 1.24
    p = path_from_moves([0.0, 0.0, 0.0], [("arc", R_c, -math.pi / 2, direction)])  # right turn for C
    gamma_ss = math.asin(direction * L * (-1 / R_c))
    # put C on the arc at 30 deg with the wheel along the body's reference direction
    th = math.radians(30)
    c = np.array([R_c * math.sin(th), -R_c + R_c * math.cos(th)])
    tangent = -th
    psi = tangent + (0.0 if direction > 0 else math.pi) - gamma_ss
    o = c - L * np.array([math.cos(psi), math.sin(psi)])
    e = tracking_errors(p, np.array([*o, psi]), gamma_ss, L, point="C")
    assert e.gamma_ss == pytest.approx(gamma_ss)
    for name in ("eps_c", "eps_o", "xi", "xi_r"):
        assert getattr(e, name) == pytest.approx(0.0, abs=1e-12), name
    # O lies on the concentric circle of radius sqrt(R_c^2 - L^2)
    assert np.hypot(o[0], o[1] + R_c) == pytest.approx(math.sqrt(R_c**2 - L**2))


def test_eqs_9_and_10_hold_on_random_batches():
    rng = np.random.default_rng(4)
    p = path_from_moves([0.0, 0.0, 0.3], [("line", 2.0), ("arc", 1.5, 1.0), ("line", 2.0), ("arc", 2.5, -1.3, -1)])
    for point in ("O", "C"):
        s = rng.uniform(0, p.length, 200)
        pos = p.point_at(s) + rng.normal(0, 0.05, (200, 2))
        psi = p.heading_at(s) + rng.normal(0, 0.1, 200) + np.where(p.direction_at(s) < 0, math.pi, 0)
        gamma = rng.uniform(-0.6, 0.6, 200)
        e = tracking_errors(p, np.column_stack([pos, psi]), gamma, L, point=point)
        np.testing.assert_allclose(np.angle(np.exp(1j * (e.xi_r - e.xi - (gamma - e.gamma_ss)))), 0.0, atol=1e-12)
        np.testing.assert_allclose(e.eps_c, e.eps_o + L * np.sin(e.xi), atol=1e-12)


@pytest.mark.parametrize("point", ["O", "C"])
@pytest.mark.parametrize("v", [0.7, -0.7])
@pytest.mark.parametrize("kappa", [0.5, -0.8])
def test_feedforward_holds_the_tracked_point_on_its_circle(point, v, kappa):
    """Open loop at gamma_ss: the tracked point moves on a circle of curvature kappa (eq. 8)."""
    d = 1 if v > 0 else -1
    gamma_ss, valid = feedforward_steering(kappa, L, point, d)
    assert valid
    state = np.array([0.0, 0.0, 0.0 if d > 0 else math.pi, float(gamma_ss)])
    pts = []
    for _ in range(400):
        state = rk4_step(state, v, 0.0, L, 0.01)
        q = state[:2] if point == "O" else point_c(state[:3], L)
        pts.append(q)
    pts = np.array(pts)
    # fit the circle through three points and compare its radius and turning sense
    a, b, c = pts[0], pts[200], pts[399]
    ab, ac = b - a, c - a
    den = 2 * (ab[0] * ac[1] - ab[1] * ac[0])
    ux = (ac[1] * (ab @ ab) - ab[1] * (ac @ ac)) / den
    uy = (ab[0] * (ac @ ac) - ac[0] * (ab @ ab)) / den
    assert math.hypot(ux, uy) == pytest.approx(1 / abs(kappa), rel=1e-6)
    # turning sense along the motion: sign of the cross product of successive chords
    turn = np.sign(ab[0] * (c - b)[1] - ab[1] * (c - b)[0])
    assert turn == np.sign(kappa)


def test_feedforward_for_c_needs_radius_above_wheelbase():
    g, valid = feedforward_steering(np.array([0.5, 1.0]), 1.5, "C")
    assert valid.tolist() == [True, False]
    assert g[1] == pytest.approx(math.pi / 2)
    with pytest.raises(ValueError, match="point"):
        feedforward_steering(0.1, 1.0, "X")


@pytest.mark.parametrize("point", ["O", "C"])
@pytest.mark.parametrize("feedforward", [True, False])
def test_scalar_fast_path_equals_the_vectorised_kernel(point, feedforward):
    rng = np.random.default_rng(7)
    p = path_from_moves([0.2, 0.1, -0.4], [("arc", 2.0, 1.2), ("line", 1.5, -1), ("arc", 1.6, -2.0), ("line", 2.0)])
    s = rng.uniform(0, p.length, 100)
    pos = p.point_at(s) + rng.normal(0, 0.1, (100, 2))
    pose = np.column_stack([pos, rng.uniform(-np.pi, np.pi, 100)])
    gamma = rng.uniform(-0.5, 0.5, 100)
    batch = tracking_errors(p, pose, gamma, L, point=point, feedforward=feedforward)
    for i in range(100):
        one = tracking_errors_scalar(p, tuple(pose[i]), float(gamma[i]), L, point, feedforward=feedforward)
        for name in ("eps_c", "eps_o", "xi", "xi_r", "s", "gamma_ss", "kappa"):
            a, b = getattr(one, name), float(getattr(batch, name)[i])
            if name.startswith("xi"):
                a, b = math.remainder(a - b, 2 * math.pi), 0.0
            assert a == pytest.approx(b, abs=1e-12), name
        assert one.direction == batch.direction[i]


def test_local_plant_matches_the_kinematics_package():
    """The tests' RK4 helper integrates the same eq. 8 as agvnav.kinematics.TricycleStacker."""
    model = TricycleStacker(wheelbase=L)
    rng = np.random.default_rng(3)
    for _ in range(20):
        state = np.append(rng.normal(size=3), rng.uniform(-1.4, 1.4))
        v, gd = rng.normal(), rng.normal()
        np.testing.assert_allclose(tricycle_derivative(state, v, gd, L), model.derivative(state, [v, gd]), atol=1e-12)
