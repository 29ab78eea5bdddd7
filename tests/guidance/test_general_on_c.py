"""General law (seed 000 eqs 11-13) guiding point C forward: pole pattern, overshoot, no saturation.

Ground truth: the transfer function eps_c(s)/eps0 = N(s)/chi(s) derived in
:mod:`agvnav.guidance.gains`, the second-order free response of eq. 23, and
the nonlinear tricycle (seed 000 eq. 8) with a rate-limited steering wheel.
"""

import math

import numpy as np
import pytest
from _guidance_sim import rk4_step, run
from hypothesis import given
from hypothesis import strategies as st
from scipy import signal

from agvnav.guidance import LineSegment, Path, SeedGeneralController, SeedSimpleController, path_from_moves
from agvnav.guidance.gains import (
    BAND_DAMPING,
    arc_linear_model,
    characteristic_coefficients,
    check_routh_hurwitz,
    general_gains,
    general_gains_on_arc,
    hidden_real_pole,
    modal_response,
    seed_loop_matrix,
    seed_poles_for_distance,
)
from agvnav.guidance.laws import general_law, simple_law

L = 1.0
EPS0 = 0.11


def eps_c_response(poles, s):
    """Linearised eps_c(s) (per metre travelled) after a unit offset of C, from the modal form."""
    lam, res = modal_response(seed_loop_matrix(poles, L, "general", "C"), [1, 0, 0], [1, 0, 0])
    return (res[None, :] * np.exp(np.outer(s, lam))).sum(axis=1).real


def test_offset_response_is_n_over_chi():
    """eps_c(s)/eps0 = N/chi with N = s^2 + c s + (v b/L - v a); chi = s N + (v^2 a/L)(L s / v + 1)."""
    v = 0.2
    poles = seed_poles_for_distance(1.5, L, real_ratio=1.0)  # the old, seed-like pattern
    g = general_gains(poles, v, L)
    chi = np.array([1.0, g.c, v * g.b / L, v * v * g.a / L])
    n = np.array([1.0, g.c, v * g.b / L - v * g.a])
    assert np.allclose(np.polyadd(np.polymul([1.0, 0.0], n), chi[3] * np.array([L / v, 1.0])), chi)
    t = np.linspace(0.0, 30.0, 1501)
    _, y = signal.impulse((n, chi), T=t)
    assert np.allclose(y, eps_c_response(poles, v * t), atol=1e-9)
    assert y[0] == pytest.approx(1.0)
    # eps_c''(0) = -v a eps0 (per unit offset): second derivative of the modal sum at t = 0
    lam, res = modal_response(seed_loop_matrix(poles, L, "general", "C"), [1, 0, 0], [1, 0, 0])
    assert float(np.sum(res * (v * lam) ** 2).real) == pytest.approx(-v * g.a, rel=1e-9)


def test_old_pattern_overshoots_and_new_pattern_does_not():
    s = np.linspace(0.0, 12.0, 12001)
    old = eps_c_response(seed_poles_for_distance(1.5, L, real_ratio=1.0), s)
    assert old.min() < -1.0  # the bench symptom: eps_c swings past -100 % of the offset
    for damping in (1.0 / math.sqrt(2.0), BAND_DAMPING, 0.9):
        new = eps_c_response(seed_poles_for_distance(1.5, L, damping=damping), s)
        bound = math.exp(-math.pi * damping / math.sqrt(1.0 - damping**2))  # second-order undershoot
        assert -new.min() == pytest.approx(bound, rel=1e-3)
    assert -eps_c_response(seed_poles_for_distance(1.5, L, damping=BAND_DAMPING), s).min() <= 0.02 + 1e-6


@pytest.mark.parametrize("distance", [0.5, 1.5, 4.0])
def test_designed_pattern_is_the_simple_law(distance):
    """Real pole at -1/L; the pair equals the simple law's pair for the same distance."""
    p = seed_poles_for_distance(distance, L)
    real = p[np.abs(p.imag) < 1e-12]
    assert real.size == 1 and real[0].real == pytest.approx(-1.0 / L)
    pair = np.sort_complex(p[np.abs(p.imag) > 0])
    assert np.allclose(pair, np.sort_complex(seed_poles_for_distance(distance, L, "simple")), rtol=1e-6)
    for v in (0.2, 1.0):
        g = general_gains(p, v, L)
        check_routh_hurwitz(g.a, g.b, g.c, v)  # eq. 18 holds
        assert g.c - g.b + g.a * L == pytest.approx(v / L)  # eq. 13 -> eq. 20


@given(
    kappa=st.floats(-0.95, 0.95),
    scale=st.floats(0.3, 5.0),
    x0=st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(lambda x: max(map(abs, x)) > 0.1),
)
def test_hidden_real_pole_never_shows_in_eps_c_or_xi_r(kappa, scale, x0):
    """On the arc-linearised model, the real pole -cos(gamma_ss)/L has zero residue in eps_c and xi_r."""
    pair = scale * np.array([-1 + 1j, -1 - 1j])
    p_r = hidden_real_pole(L, kappa)
    g = general_gains_on_arc(np.array([p_r, *pair]), 1.0, L, kappa, "C")
    a0, bvec, rows = arc_linear_model("C", kappa, 1.0, L)
    a_cl = a0 - np.outer(bvec, np.array([g.a, g.b, g.c]) @ rows)
    for out in ([1, 0, 0], [0, 1, 0]):
        lam, res = modal_response(a_cl, out, x0)
        j = int(np.argmin(np.abs(lam - p_r)))
        assert abs(lam[j] - p_r) < 1e-6
        assert abs(res[j]) < 1e-8 * (1.0 + np.max(np.abs(res)))


@given(
    st.floats(-0.2, 0.2), st.floats(-0.3, 0.3), st.floats(-0.6, 0.6), st.floats(-0.8, 0.8), st.floats(0.05, 2.0)
)
def test_eq13_with_hidden_pole_is_eq20_even_nonlinearly(eps_c, xi_r, gamma, kappa, v):
    p = seed_poles_for_distance(1.5, L)
    p[np.abs(p.imag) < 1e-12] = hidden_real_pole(L, kappa)
    g = general_gains_on_arc(p, 1.0, L, kappa, "C")
    a, b, c = g.a * v, g.b * v, g.c * v
    gss = math.asin(L * kappa)
    u13 = general_law(13, eps_c, 0.0, 0.0, xi_r, gamma - gss, a, b, c, L, v=v, gamma_ss=gss)
    u20 = simple_law(20, eps_c, 0.0, 0.0, xi_r, gamma, gss, a, b - a * L, v, L)
    assert u13 == pytest.approx(u20, abs=1e-9)
    # first-order identical to the seed's eq. 13
    u_seed = general_law(13, eps_c * 1e-4, 0, 0, xi_r * 1e-4, gamma * 1e-4, a, b, c, L)
    u_lin = general_law(13, eps_c * 1e-4, 0, 0, xi_r * 1e-4, gamma * 1e-4, a, b, c, L, v=v, gamma_ss=gss)
    assert u_lin == pytest.approx(u_seed, rel=1e-3, abs=1e-9)


def rate_limited(max_rate, max_angle=math.pi / 2):
    """Plant step with the steering rate and angle clipped (seed-like actuator), recording saturation."""
    hits = {"rate": 0, "angle": 0}

    def step(state, v, u, dt):
        if abs(u) > max_rate:
            hits["rate"] += 1
        nxt = rk4_step(state, v, float(np.clip(u, -max_rate, max_rate)), L, dt)
        if abs(nxt[3]) >= max_angle:
            hits["angle"] += 1
            nxt[3] = math.copysign(max_angle, nxt[3])
        return nxt

    return step, hits


def start_c(path, offset):
    x, y, h = path.start_pose
    p = np.array([x, y]) + offset * np.array([-math.sin(h), math.cos(h)]) - L * np.array([math.cos(h), math.sin(h)])
    return [p[0], p[1], h, 0.0]


@pytest.mark.parametrize(
    "moves, length",
    [([("line", 6.0)], 5.9), ([("arc", 1.24, math.pi / 2), ("line", 3.0)], 1.24 * math.pi / 2 + 2.9)],
    ids=["line", "seed_test"],
)
def test_110_mm_converges_without_saturation(moves, length):
    """Seed §4.3 conditions: 0.2 m/s, 110 mm off, wheel straight at the start, 60 deg/s rate limit."""
    path = path_from_moves([0.0, 0.0, 0.0], moves)
    ctrl = SeedGeneralController(path, L, convergence_distance=1.5, point="C")
    step, hits = rate_limited(math.radians(60.0))
    states, errs, travelled = run(ctrl, start_c(path, EPS0), 0.2, L, distance=length, dt=0.05, step=step)
    eps = np.array([e["eps_c"] for e in errs])
    dgamma = states[:-1, 3] - np.array([e["gamma_ss"] for e in errs])
    assert hits == {"rate": 0, "angle": 0}
    assert np.max(np.abs(states[:, 3])) < math.radians(70.0)
    k0 = int(np.argmax(np.abs(eps) <= 0.1 * EPS0))  # end of the transient as in agvnav.sim.metrics
    assert k0 > 0 and travelled[k0] < 1.5
    assert np.max(np.abs(eps[k0:])) <= 0.1 * EPS0  # no overshoot out of the band (the old design: -140 mm)
    assert np.min(eps) > -0.05 * EPS0
    assert abs(eps[-1]) < 1e-3
    # the wheel settles with the hidden mode exp(-s/L) (eq. 24): after the 54 deg curvature jump
    # of the seed path 2.9 m remain, 54 deg * exp(-2.9) = 3 deg
    assert abs(dgamma[-1]) < math.radians(4.0)


def test_general_on_c_matches_simple_law_in_the_nonlinear_loop():
    """With the hidden real pole, eq. 13 (exact rotation) drives C exactly as eq. 20 with the same pair."""
    path = path_from_moves([0.0, 0.0, 0.0], [("arc", 1.24, math.pi / 2), ("line", 3.0)])
    gen = SeedGeneralController(path, L, convergence_distance=1.5, point="C")
    simple = SeedSimpleController(path, L, convergence_distance=1.5)
    out = [run(c, start_c(path, EPS0), 0.2, L, distance=4.0, dt=0.05)[0] for c in (gen, simple)]
    assert np.max(np.abs(out[0][:, :2] - out[1][:, :2])) < 1e-6


def test_unstable_designs_are_still_refused():
    path = Path([LineSegment(np.array([0.0, 0.0]), 0.0, 10.0, 1)])
    with pytest.raises(ValueError, match="negative real parts"):
        SeedGeneralController(path, L, poles_per_m=[0.5, -1 + 1j, -1 - 1j], point="C")
    with pytest.raises(ValueError, match=r"eq\. 18"):
        SeedGeneralController(path, L, gains=(10.0, 1.0, 1.0), v_max=0.5, point="C")  # b c / a < v
    with pytest.raises(ValueError, match=r"eq\. 19"):
        check_routh_hurwitz(1.0, 1.0, 1.0, -0.2)  # b must follow the direction of travel
    p = seed_poles_for_distance(1.5, L)
    assert np.all(characteristic_coefficients(p, 3) > 0)
