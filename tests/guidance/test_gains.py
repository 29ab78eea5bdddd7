"""Gain design (poles per metre -> a, b, c), eq. 17 and Routh-Hurwitz (eqs 18-19)."""

import math

import numpy as np
import pytest
from _guidance_sim import assert_same_roots
from hypothesis import given
from hypothesis import strategies as st

from agvnav.guidance import (
    check_routh_hurwitz,
    check_simple_stability,
    convergence_distance,
    general_characteristic,
    general_gains,
    poles_for_convergence,
    routh_hurwitz_ok,
    simple_characteristic,
    simple_gains,
)

L = 1.3


@pytest.mark.parametrize("v", [0.2, 1.5, -0.2, -0.8])
@pytest.mark.parametrize("d", [0.8, 2.0, 5.0])
def test_pole_placement_round_trip(v, d):
    poles = poles_for_convergence(d, damping=0.6, real_ratio=1.4)
    g = general_gains(poles, v, L)
    roots = np.roots(general_characteristic(g.a, g.b, g.c, v, L))
    assert_same_roots(roots, poles * abs(v), atol=1e-9)
    assert g.a > 0 and g.c > 0 and math.copysign(1, g.b) == math.copysign(1, v)
    check_routh_hurwitz(g.a, g.b, g.c, v)  # designed gains are stable


def test_gains_scale_with_speed_and_b_follows_direction():
    poles = poles_for_convergence(2.0)
    g1, g2, gr = (general_gains(poles, v, L) for v in (0.3, 0.6, -0.3))
    assert (g2.a, g2.b, g2.c) == pytest.approx((2 * g1.a, 2 * g1.b, 2 * g1.c))
    assert (gr.a, gr.b, gr.c) == pytest.approx((g1.a, -g1.b, g1.c))
    assert general_gains(poles, 0.0, L) == type(g1)(0.0, 0.0, 0.0)


def test_convergence_distance_of_designed_poles():
    for d in (0.5, 2.0, 7.0):
        assert convergence_distance(poles_for_convergence(d)) == pytest.approx(d)
        assert convergence_distance(poles_for_convergence(d, order=2)) == pytest.approx(d)
    assert convergence_distance([0.1, -1.0]) == math.inf


@pytest.mark.parametrize(
    "a, b, c, v, ok",
    [
        (1.0, 2.0, 3.0, 0.5, True),  # bc/a = 6 > 0.5
        (1.0, 2.0, 3.0, 7.0, False),  # bc/a = 6 < 7
        (1.0, -2.0, 3.0, -0.5, True),  # eq. 19
        (1.0, 2.0, 3.0, -0.5, False),  # b must be < 0 in reverse
        (1.0, -2.0, 3.0, -7.0, False),  # |b|c/a < |v|
        (-1.0, 2.0, 3.0, 0.5, False),
        (1.0, 2.0, -3.0, 0.5, False),
    ],
)
def test_routh_hurwitz_accept_refuse(a, b, c, v, ok):
    assert bool(routh_hurwitz_ok(a, b, c, v)) is ok
    if ok:
        check_routh_hurwitz(a, b, c, v)
    else:
        with pytest.raises(ValueError, match=r"unstable guidance gains.*eq\. (18|19)"):
            check_routh_hurwitz(a, b, c, v)


@given(
    a=st.floats(-3, 3),
    b=st.floats(-3, 3),
    c=st.floats(-3, 3),
    v=st.floats(0.05, 3).flatmap(lambda x: st.sampled_from([x, -x])),
)
def test_routh_hurwitz_agrees_with_roots(a, b, c, v):
    roots = np.roots(general_characteristic(a, b, c, v, L))
    stable = bool(np.all(roots.real < -1e-9))
    marginal = np.any(np.abs(roots.real) <= 1e-6)
    if not marginal:
        assert bool(routh_hurwitz_ok(a, b, c, v)) == stable


def test_bad_poles_are_refused():
    with pytest.raises(ValueError, match="conjugate"):
        general_gains([-1.0, -1 + 1j, -1 + 2j], 0.5, L)
    with pytest.raises(ValueError, match="negative real"):
        general_gains([0.5, -1 + 1j, -1 - 1j], 0.5, L)
    with pytest.raises(ValueError, match="3 poles"):
        general_gains([-1.0, -2.0], 0.5, L)
    with pytest.raises(ValueError, match="damping"):
        poles_for_convergence(1.0, damping=1.5)


def test_simple_gains_round_trip_and_stability():
    poles = poles_for_convergence(1.5, order=2)
    g = simple_gains(poles, 0.4)
    assert_same_roots(np.roots(simple_characteristic(g.a, g.b, 0.4)), 0.4 * poles, atol=1e-9)
    check_simple_stability(g.a, g.b, 0.4)
    with pytest.raises(ValueError, match="v > 0"):
        simple_gains(poles, -0.4)
    with pytest.raises(ValueError, match="v > 0"):
        check_simple_stability(g.a, g.b, -0.4)
    with pytest.raises(ValueError, match="a > 0 and b > 0"):
        check_simple_stability(-1.0, 1.0, 0.4)
