"""Prediction: the accumulated Fisher information gives the CRLB of positioning.crlb; degeneracy figures."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from agvnav.layout.prediction import critical_distance, information, moments, sigmas, sigmas_rms, spread
from agvnav.positioning import crlb

xy = st.tuples(st.floats(-20, 20), st.floats(-20, 20))


@settings(max_examples=60, deadline=None)
@given(st.lists(xy, min_size=3, max_size=7), xy)
def test_sigmas_match_positioning_crlb(refl_list: list[tuple[float, float]], head_xy: tuple[float, float]) -> None:
    refl = np.array(refl_list)
    head = np.array([head_xy])
    if np.min(np.hypot(*(refl - head).T)) < 0.5:
        return
    std = 2.77e-5
    cov = crlb(refl, np.array([head_xy[0], head_xy[1], 0.3]), std)
    sp, sh, rms = sigmas_rms(information(head, refl, np.ones((1, len(refl)), dtype=bool), std))
    if not np.all(np.isfinite(cov)) or np.linalg.cond(cov) > 1e10:
        return
    assert math.isclose(sp[0], math.sqrt(np.linalg.eigvalsh(cov[:2, :2]).max()), rel_tol=1e-6)
    assert math.isclose(sh[0], math.sqrt(cov[2, 2]), rel_tol=1e-6)
    assert math.isclose(rms[0], math.sqrt(cov[0, 0] + cov[1, 1]), rel_tol=1e-6)


def test_invisible_reflectors_add_nothing_and_two_are_unobservable() -> None:
    refl = np.array([[10.0, 0.0], [0.0, 10.0], [-10.0, 0.0]])
    head = np.zeros((2, 2))
    vis = np.array([[True, True, True], [True, True, False]])
    sp, sh = sigmas(information(head, refl, vis, 1e-4))
    assert np.isfinite(sp[0]) and np.isfinite(sh[0])
    assert sp[1] == math.inf and sh[1] == math.inf


def test_critical_distance_zero_on_the_circle_and_radius_at_centre() -> None:
    refl = np.array([[5.0, 0.0], [0.0, 5.0], [-5.0, 0.0]])
    head = np.array([[0.0, -5.0], [0.0, 0.0], [0.0, -8.0]])
    d = critical_distance(head, refl, np.ones((3, 3), dtype=bool))
    np.testing.assert_allclose(d, [0.0, 5.0, 3.0], atol=1e-12)
    # on the critical circle the bearing-only information is singular
    sp, _ = sigmas(information(head[:1], refl, np.ones((1, 3), dtype=bool), 1e-4))
    assert sp[0] == math.inf or sp[0] > 1e3


def test_spread_is_zero_for_aligned_reflectors() -> None:
    line = np.array([[0.0, 0.0], [5.0, 5.0], [10.0, 10.0]])
    tri = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    vis = np.ones((1, 3), dtype=bool)
    assert spread(moments(line, vis))[0] < 1e-6
    assert spread(moments(tri, vis))[0] > 1.0
