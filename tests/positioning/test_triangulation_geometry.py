"""Seed 000 §2.3 geometry: error triangle vs centres triangle (eqs 1, 2, 4, 6), C_ij as circumcentre."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from agvnav.geometry import bearing_to, circumcentre, triangle_signed_area
from agvnav.positioning._three import centres, order_pairs
from agvnav.positioning.absolute_angles import _error_triangle, heading_error

coord = st.floats(-15.0, 15.0, allow_nan=False)
point = st.tuples(coord, coord)


def _setup(refl, p, psi, delta):
    r = np.array(refl)
    pose = np.array([p[0], p[1], psi])
    th = bearing_to(pose, r)
    x, y, t = tuple(r[:, 0]), tuple(r[:, 1]), tuple(th)
    x, y, t, tan_ab = order_pairs(x, y, t)
    cx, cy = centres(x, y, tan_ab)
    (tx, ty), _ = _error_triangle(x, y, t, psi + delta, np)
    return np.array(pose[:2]), x, y, t, cx, cy, tx, ty


def _generic(refl, p) -> bool:
    r = np.array(refl)
    q = np.array(p)
    area = abs(triangle_signed_area(r[0], r[1], r[2]))
    if area < 5.0 or np.min(np.linalg.norm(r - q, axis=1)) < 0.5:
        return False
    c, _ = circumcentre(r[0], r[1], r[2])
    rad = np.linalg.norm(r[0] - c)
    bearings = bearing_to(np.array([q[0], q[1], 0.0]), r)
    sines = [abs(math.sin(bearings[j] - bearings[i])) for i, j in ((0, 1), (1, 2), (2, 0))]
    return abs(np.linalg.norm(q - c) - rad) > 0.1 * rad and min(sines) > 0.05 and rad < 200.0


delta_st = st.floats(-1.5, 1.5).filter(lambda d: abs(d) > 1e-3)


@given(st.tuples(point, point, point), point, st.floats(-3.0, 3.0), delta_st)
def test_error_triangle_is_the_centres_triangle_scaled_by_2_sin_delta(refl, p, psi, delta):
    assume(_generic(refl, p))
    _, _, _, _, cx, cy, tx, ty = _setup(refl, p, psi, delta)
    area_e = triangle_signed_area((tx[0], ty[0]), (tx[1], ty[1]), (tx[2], ty[2]))
    area_c = triangle_signed_area((cx[0], cy[0]), (cx[1], cy[1]), (cx[2], cy[2]))
    r = 2.0 * abs(math.sin(delta))  # eq. 1
    assert math.sqrt(abs(area_e / area_c)) == pytest.approx(r, rel=1e-7)  # eq. 2
    side_t = np.array([tx[1] - tx[0], ty[1] - ty[0]])
    side_c = np.array([cx[1] - cx[0], cy[1] - cy[0]])
    assert np.linalg.norm(side_t) / np.linalg.norm(side_c) == pytest.approx(r, rel=1e-7)  # eq. 3
    cross = side_t[0] * side_c[1] - side_t[1] * side_c[0]
    assert math.copysign(1.0, cross) == math.copysign(1.0, delta)  # eq. 6
    # turned by 90 - |delta|: clockwise for delta > 0 (seed 000, Fig. 3)
    turn = math.atan2(side_t[0] * side_c[1] - side_t[1] * side_c[0], side_t @ side_c)
    assert abs(abs(turn) - (math.pi / 2 - abs(delta))) < 1e-6


@given(st.tuples(point, point, point), point, st.floats(-3.0, 3.0), delta_st)
def test_centre_is_circumcentre_of_both_reflectors_and_the_error_vertex(refl, p, psi, delta):
    assume(_generic(refl, p))
    pos, x, y, _, cx, cy, tx, ty = _setup(refl, p, psi, delta)
    for k, (i, j) in enumerate(((0, 1), (1, 2), (2, 0))):
        c_from_p, _ = circumcentre((x[i], y[i]), (x[j], y[j]), pos)
        c_from_t, ok = circumcentre((x[i], y[i]), (x[j], y[j]), (tx[k], ty[k]))
        scale = math.hypot(x[j] - x[i], y[j] - y[i]) + np.linalg.norm(c_from_p - (x[i], y[i]))
        assert ok
        np.testing.assert_allclose(c_from_t, c_from_p, atol=1e-7 * scale)
        np.testing.assert_allclose((cx[k], cy[k]), c_from_p, atol=1e-7 * scale)


@given(st.tuples(point, point, point), point, st.floats(-3.0, 3.0), delta_st)
def test_eqs_4_to_6_give_delta(refl, p, psi, delta):
    assume(_generic(refl, p))
    _, x, y, t, cx, cy, _, _ = _setup(refl, p, psi, delta)
    for aligned in (False, True):  # eq. 4 (areas) and eq. 5 (finite sides) agree
        est = heading_error(x, y, t, psi + delta, cx, cy, aligned)
        assert abs(est - delta) < 1e-6
