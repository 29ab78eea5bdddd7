"""Visibility: range, occlusion by segments (against shapely), reflectors hiding each other."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString

from agvnav.layout import parse_layout
from agvnav.layout.hall import build_hall
from agvnav.layout.visibility import line_of_sight, mutual_hiding, visibility

coord = st.floats(-10.0, 10.0, allow_nan=False)


def test_wall_between_blocks_and_wall_beside_does_not() -> None:
    wall = np.array([[[5.0, -1.0], [5.0, 1.0]]])
    head = np.array([[0.0, 0.0]])
    refl = np.array([[10.0, 0.0], [10.0, 5.0], [3.0, 0.0]])
    vis = visibility(head, refl, wall, 0.3, 30.0)
    assert vis.tolist() == [[False, True, True]]


def test_range_limits() -> None:
    head = np.array([[0.0, 0.0]])
    refl = np.array([[0.2, 0.0], [5.0, 0.0], [31.0, 0.0]])
    assert visibility(head, refl, np.zeros((0, 2, 2)), 0.3, 30.0).tolist() == [[False, True, False]]


@settings(max_examples=200, deadline=None)
@given(st.lists(coord, min_size=8, max_size=8))
def test_line_of_sight_agrees_with_shapely(c: list[float]) -> None:
    p, r = np.array([c[0:2]]), np.array([c[2:4]])
    seg = np.array([[c[4:6], c[6:8]]])
    a, b = LineString([c[0:2], c[2:4]]), LineString([c[4:6], c[6:8]])
    if a.length < 1e-6 or b.length < 1e-6 or a.distance(b.boundary) < 1e-6 or b.distance(a.boundary) < 1e-6:
        return  # touching configurations are measure-zero; proper crossing only
    assert bool(line_of_sight(p, r, seg)[0]) == (not a.intersects(b))


def test_nearer_reflector_hides_the_one_behind() -> None:
    head = np.array([[0.0, 0.0]])
    refl = np.array([[10.0, 0.0], [5.0, 0.01], [5.0, 3.0]])
    vis = np.ones((1, 3), dtype=bool)
    assert mutual_hiding(head, refl, 0.04, vis).tolist() == [[False, True, True]]
    # point reflectors hide nothing; a hidden-by-invisible reflector stays visible
    assert mutual_hiding(head, refl, 0.0, vis).all()
    vis2 = np.array([[True, False, True]])
    assert mutual_hiding(head, refl, 0.04, vis2).tolist() == [[True, False, True]]


def test_hiding_across_the_pi_cut() -> None:
    head = np.array([[0.0, 0.0]])
    refl = np.array([[-10.0, 0.001], [-5.0, -0.001]])  # bearings +pi and -pi, same direction
    assert mutual_hiding(head, refl, 0.04, np.ones((1, 2), dtype=bool)).tolist() == [[False, True]]


def test_rack_diagonals_block_like_its_edges(small_text: str) -> None:
    hall = build_hall(parse_layout(small_text))
    assert hall.segments.shape == (2, 2, 2)  # one rack: two diagonals (the outer hall is convex)
    rng = np.random.default_rng(0)
    p = rng.uniform([0, 0], [20, 12], (3000, 2))
    r = rng.uniform([0, 0], [20, 12], (3000, 2))
    rack = hall.occluders["rack"]
    outside = np.array([not rack.intersects(LineString([a, a]).buffer(1e-9)) and
                        not rack.intersects(LineString([b, b]).buffer(1e-9)) for a, b in zip(p, r, strict=True)])
    expect = np.array([not rack.intersects(LineString([a, b])) for a, b in zip(p, r, strict=True)])
    got = line_of_sight(p, r, hall.segments)
    assert np.array_equal(got[outside], expect[outside])
