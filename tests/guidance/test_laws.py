"""Seed-000 laws in closed loop with the nonlinear tricycle (eq. 8): eq. 17 / eq. 23 and feed-forward."""

import math

import numpy as np
import pytest
from _guidance_sim import assert_same_roots, run
from scipy.linalg import expm

from agvnav.guidance import (
    LineSegment,
    Path,
    SeedGeneralController,
    SeedSimpleController,
    arc_linear_model,
    envelope_distance,
    general_gains,
    general_gains_on_arc,
    general_law,
    linearised_loop,
    linearised_poles_per_metre,
    modal_response,
    path_from_moves,
    poles_for_convergence,
    simple_law,
)
from agvnav.kinematics.tricycle import TricycleStacker

L = 1.1


def straight(direction=1, length=40.0):
    return Path([LineSegment(np.array([-1.0, 0.0]), 0.0, length, direction)])


def test_forms_11_12_13_are_one_law_when_errors_obey_linear_eqs_9_10():
    rng = np.random.default_rng(0)
    eps_o, xi, dgamma = rng.normal(size=(3, 50))
    eps_c, xi_r = eps_o + L * xi, xi + dgamma
    a, b, c = 0.7, -1.3, 2.1
    u = [general_law(f, eps_c, eps_o, xi, xi_r, dgamma, a, b, c, L) for f in (11, 12, 13)]
    np.testing.assert_allclose(u[1], u[0], atol=1e-12)
    np.testing.assert_allclose(u[2], u[0], atol=1e-12)
    gamma = dgamma  # on a line, with sin(gamma) ~ gamma the simple forms agree to first order
    s = [simple_law(f, eps_c, eps_o, xi, xi_r, 1e-4 * gamma, 0.0, a, 1.3, 0.5, L) for f in (20, 21, 22)]
    small = [simple_law(f, *(1e-4 * np.array([eps_c, eps_o, xi, xi_r])), 1e-4 * gamma, 0.0, a, 1.3, 0.5, L)
             for f in (20, 21, 22)]
    np.testing.assert_allclose(small[1], small[0], rtol=1e-6, atol=1e-14)
    np.testing.assert_allclose(small[2], small[0], rtol=1e-6, atol=1e-14)
    assert len(s) == 3


@pytest.mark.parametrize("point, form", [("O", 11), ("C", 12), ("C", 13), ("O", 12)])
@pytest.mark.parametrize("v", [0.4, -0.4])
def test_numerical_linearisation_gives_the_designed_poles(point, form, v):
    poles = poles_for_convergence(1.5, damping=0.8, real_ratio=1.3)
    ctrl = SeedGeneralController(straight(), L, poles_per_m=poles, point=point, form=form)
    got = linearised_poles_per_metre(ctrl, v, L)
    assert_same_roots(got, poles, atol=1e-5)


def test_simple_law_linearisation_is_eq_23_and_24():
    poles = poles_for_convergence(1.5, order=2)
    ctrl = SeedSimpleController(straight(), L, poles_per_m=poles)
    got = linearised_poles_per_metre(ctrl, 0.4, L)
    # eq. 24 adds the pole -v/L (i.e. -1/L per metre) seen by eps_o, xi, gamma only
    assert_same_roots(got, np.append(poles, -1 / L), atol=1e-5)
    lam, res = linearised_loop(ctrl, 0.4, L)
    hidden = np.argmin(np.abs(lam + 1 / L))
    assert abs(res[hidden]) < 1e-6  # the eq.-24 pole does not show in eps_c
    assert_same_roots(lam[np.abs(res) > 1e-6], poles, atol=1e-5)


def _linear_general(point, a, b, c, v):
    """State matrix of eqs 14-16 with the law, state (eps, heading error, gamma)."""
    if point == "O":  # (eps_o, xi, gamma), eq. 11
        return np.array([[0, v, 0], [0, 0, v / L], [-a, -b, -c]])
    # (eps_c, xi_r, gamma), eq. 13: xi_r' = xi' + gamma' = (v/L) gamma + gamma'
    row = np.array([-a, -(b - a * L), -(c - b + a * L)])
    return np.array([[0, v, 0], row + np.array([0, 0, v / L]), row])


@pytest.mark.parametrize("point, v", [("C", 0.5), ("O", -0.5)])
def test_nonlinear_loop_matches_eq_17_for_small_errors(point, v):
    """Small offset on a line: the nonlinear closed loop follows the linear eq.-17 solution."""
    poles = poles_for_convergence(1.5)
    ctrl = SeedGeneralController(straight(1 if v > 0 else -1), L, poles_per_m=poles, point=point)
    y0 = 0.005
    psi0 = 0.0 if v > 0 else math.pi
    dt = 0.01
    _, errs, travelled = run(ctrl, [0.0, y0 if v > 0 else -y0, psi0, 0.0], v, L, distance=4.0, dt=dt)
    key = "eps_o" if point == "O" else "eps_c"
    eps = np.array([e[key] for e in errs])
    assert eps[0] == pytest.approx(y0)
    g = general_gains(poles, v, L)
    A = _linear_general(point, g.a, g.b, g.c, v)
    assert_same_roots(np.linalg.eigvals(A), abs(v) * poles, atol=1e-9)
    t = travelled / abs(v)
    lin = np.array([(expm(A * ti) @ np.array([y0, 0.0, 0.0]))[0] for ti in t[::40]])
    assert np.max(np.abs(eps[::40] - lin)) < 0.03 * y0
    # envelope: |eps| <= sum |residues| exp(-sigma s) with sigma the designed decay per metre
    lam, vecs = np.linalg.eig(A)
    residues = vecs[0] * np.linalg.solve(vecs, np.array([y0, 0.0, 0.0]))
    modal = np.real(np.exp(np.outer(t, lam)) @ residues)
    assert np.max(np.abs(eps - modal)) < 0.03 * y0
    sigma = -np.max(poles.real)
    assert np.all(np.abs(eps) <= 1.03 * np.sum(np.abs(residues)) * np.exp(-sigma * travelled) + 1e-9)
    # and not faster: the last metre still carries the designed mode
    tail = travelled > 3.0
    assert np.max(np.abs(eps[tail]) * np.exp(sigma * travelled[tail])) > 0.05 * y0


def _arc_path():
    return path_from_moves([0.0, 0.0, 0.0], [("arc", 3.0, 1.5 * math.pi)])


@pytest.mark.parametrize("make", [
    lambda ff: SeedGeneralController(_arc_path(), L, convergence_distance=3.0, point="C", feedforward=ff),
    lambda ff: SeedGeneralController(_arc_path(), L, convergence_distance=1.5, point="O", feedforward=ff),
    lambda ff: SeedSimpleController(_arc_path(), L, convergence_distance=1.5, feedforward=ff),
], ids=["general_C", "general_O", "simple"])
def test_feedforward_gives_zero_steady_state_error_on_an_arc(make):
    results = {}
    for ff in (True, False):
        ctrl = make(ff)
        # tracked point 20 mm off the start of the arc (left turn, radius 3 m), steered for the turn
        g_ss = math.atan(L / 3.0) if ctrl.point == "O" else math.asin(L / 3.0)
        psi = 0.0 if ctrl.point == "O" else -g_ss
        o = np.array([0.0, 0.02]) - (0.0 if ctrl.point == "O" else L) * np.array([math.cos(psi), math.sin(psi)])
        _, errs, _ = run(ctrl, [*o, psi, g_ss], 1.0, L, distance=12.0, dt=0.01)
        key = "eps_o" if ctrl.point == "O" else "eps_c"
        results[ff] = np.array([e[key] for e in errs])
        assert results[ff][0] == pytest.approx(0.02, abs=1e-9)
    tail = slice(-100, None)
    assert np.max(np.abs(results[True][tail])) < 1e-5
    assert np.min(np.abs(results[False][tail])) > 5e-3
    # without feed-forward the error settles (no drift): the law balances gamma_ss with a lateral offset
    assert np.ptp(results[False][tail]) < 1e-4


def test_offset_without_feedforward_matches_the_linear_prediction():
    """General law on O without feed-forward: eps_o -> -c gamma_ss / a (first order in kappa)."""
    R = 20.0
    p = path_from_moves([0.0, 0.0, 0.0], [("arc", R, 1.5)])
    ctrl = SeedGeneralController(p, L, convergence_distance=1.5, point="O", feedforward=False)
    _, errs, _ = run(ctrl, [0.0, 0.0, 0.0, 0.0], 1.0, L, distance=20.0, dt=0.01)
    g = general_gains(ctrl.poles_per_m, 1.0, L)
    predicted = -g.c * math.atan(L / R) / g.a
    assert errs[-1]["eps_o"] == pytest.approx(predicted, rel=0.05)


@pytest.mark.parametrize("plant", ["local_rk4", "kinematics.TricycleStacker"])
def test_seed_guidance_experiment_corrects_110_mm(plant):
    """Seed 000 §4.3: C on an arc of radius 1.24 m then 3 m straight at 0.2 m/s, starting 110 mm off."""
    Lw = 1.0
    step = None
    if plant != "local_rk4":
        model = TricycleStacker(wheelbase=Lw)

        def step(s, v, u, dt):
            return model.step(s, np.array([v, u]), dt)

    p = path_from_moves([0.0, 0.0, 0.0], [("arc", 1.24, -math.pi / 2), ("line", 3.0)])
    ctrl = SeedSimpleController(p, Lw, convergence_distance=1.0)
    gamma0 = math.asin(-Lw / 1.24)
    psi0 = -gamma0  # wheel along the path at C, body turned inwards
    o = np.array([0.0, 0.11]) - Lw * np.array([math.cos(psi0), math.sin(psi0)])
    _, errs, travelled = run(ctrl, [*o, psi0, gamma0], 0.2, Lw, distance=p.length - 0.3, dt=0.02, step=step)
    eps = np.array([e["eps_c"] for e in errs])
    xi_r = np.array([e["xi_r"] for e in errs])
    assert eps[0] == pytest.approx(0.11, abs=1e-9)
    after = travelled > 1.3
    assert np.max(np.abs(eps[after])) < 0.0165  # the seed's real-vehicle bound
    assert np.max(np.abs(xi_r[after])) < math.radians(3.8)
    assert abs(eps[-1]) < 1e-3


@pytest.mark.parametrize("point", ["O", "C"])
@pytest.mark.parametrize("v", [0.5, -0.5])
def test_arc_compensated_gains_give_the_designed_poles_in_the_nonlinear_loop(point, v):
    """Small offset on a tight arc: the nonlinear loop follows the linear model with the designed poles."""
    d = 1 if v > 0 else -1
    R = 2.0
    p = path_from_moves([0.0, 0.0, 0.0], [("arc", R, 3.0, d)])
    poles = poles_for_convergence(2.0)
    errs_by = {}
    for comp in (True, False):
        ctrl = SeedGeneralController(p, L, poles_per_m=poles, point=point, curvature_compensation=comp)
        kref = d / R
        g_ss = math.atan(d * L / R) if point == "O" else math.asin(d * L / R)
        psi = (0.0 if d > 0 else math.pi) - (g_ss if point == "C" else 0.0)
        y0 = 0.002
        tracked = np.array([0.0, y0 * d])  # y0 to the left of the body's reference direction
        o = tracked - (L * np.array([math.cos(psi), math.sin(psi)]) if point == "C" else 0.0)
        _, errs, travelled = run(ctrl, [*o, psi, g_ss], v, L, distance=3.0, dt=0.005)
        errs_by[comp] = np.array([e["eps_o" if point == "O" else "eps_c"] for e in errs])
        assert errs_by[comp][0] == pytest.approx(y0, abs=1e-9)
    g = general_gains_on_arc(poles, v, L, kref, point)
    a0, bvec, rows = arc_linear_model(point, kref, v, L)
    A = a0 - np.outer(bvec, np.array([g.a, g.b, g.c]) @ rows)
    assert_same_roots(np.linalg.eigvals(A), abs(v) * poles, atol=1e-9)
    lam, res = modal_response(A, [1, 0, 0], [y0, 0, 0])
    lin = np.real(np.exp(np.outer(travelled / abs(v), lam)) @ res)
    assert np.max(np.abs(errs_by[True] - lin)) < 0.03 * y0
    assert np.max(np.abs(errs_by[False] - lin)) > 0.02 * y0  # the line gains do not place these poles


def test_envelope_distance_cases():
    assert envelope_distance([-2.0], [1.0]) == pytest.approx(math.log(50) / 2)
    assert envelope_distance([-2.0, -0.1], [1.0, 0.0]) == pytest.approx(math.log(50) / 2)  # hidden mode
    assert envelope_distance([-2.0, 0.1], [1.0, 0.5]) == math.inf
    assert envelope_distance([-1.0], [0.01]) == 0.0
    two = envelope_distance([-1.0, -1.0], [0.5, 0.5])
    assert two == pytest.approx(math.log(50))
