"""Clothoids against Fresnel values and quadrature; arc chains stay close and G1."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from agvnav.guidance.clothoid import Clothoid, arc_chain


def test_unit_clothoid_is_the_fresnel_pair() -> None:
    # kappa = pi s: x(s) = C(s), y(s) = S(s) (tabulated: C(1) = 0.7798934, S(1) = 0.4382591)
    c = Clothoid(0.0, 0.0, 0.0, 0.0, math.pi, 2.0)
    p = c.point_at([1.0, 2.0])
    assert p[0] == pytest.approx([0.7798934004, 0.4382591474], abs=1e-9)
    assert p[1] == pytest.approx([0.4882534061, 0.3434156784], abs=1e-9)


@settings(max_examples=40, deadline=None)
@given(
    k0=st.floats(-1.0, 1.0), c=st.floats(-0.8, 0.8), length=st.floats(0.2, 4.0),
    th=st.floats(-math.pi, math.pi), frac=st.floats(0.0, 1.0),
)
def test_point_matches_quadrature(k0: float, c: float, length: float, th: float, frac: float) -> None:
    cl = Clothoid(1.0, -2.0, th, k0, c, length)
    s = frac * length
    theta = lambda u: th + k0 * u + 0.5 * c * u * u  # noqa: E731
    x = 1.0 + quad(lambda u: math.cos(theta(u)), 0.0, s, epsabs=1e-13, limit=200)[0]
    y = -2.0 + quad(lambda u: math.sin(theta(u)), 0.0, s, epsabs=1e-13, limit=200)[0]
    assert cl.point_at(s) == pytest.approx([x, y], abs=1e-8)
    assert float(cl.heading_at(s)) == pytest.approx(math.remainder(theta(s), 2 * math.pi), abs=1e-12)


def test_bad_clothoid_is_refused() -> None:
    with pytest.raises(ValueError, match="length"):
        Clothoid(0.0, 0.0, 0.0, 0.0, 0.1, 0.0)
    with pytest.raises(ValueError, match="kappa0"):
        Clothoid(0.0, 0.0, 0.0, math.nan, 0.1, 1.0)


def test_arc_chain_follows_a_clothoid_g1_with_its_stated_error() -> None:
    cl = Clothoid.from_curvatures(0.0, 0.0, 0.3, 0.0, 0.5, 1.2)
    pts, hd = cl.sample(0.05)
    chain = arc_chain(pts, hd)
    # stated error: about |c| L h^2 / 12 = 0.417 * 1.2 * 0.0025 / 12 ~ 1e-4 m
    assert chain.max_error_m < 2e-4
    for a, b in zip(chain.segments[:-1], chain.segments[1:], strict=True):
        assert np.hypot(*(a.end - b.start)) < 1e-12
        assert math.remainder(a.end_heading - b.heading, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)
    assert chain.segments[-1].end_heading == pytest.approx(float(cl.heading_at(1.2)), abs=1e-12)
    # the curvature of each piece is the mean curvature over it
    k = [s.curvature for s in chain.segments]
    assert k[0] == pytest.approx(0.5 / 1.2 * 0.025, rel=1e-3)
    assert np.all(np.diff(k) > 0)
