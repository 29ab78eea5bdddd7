"""The executor's collision kernel (``traffic._collide``) against shapely's brute force (issue 30).

Ground truth: shapely ``intersects`` of the placed polygons (touching counts), every pair; the kernel
must report the same first pair in the same order, on random convex footprints and poses packed so
that many bounding circles meet.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from shapely.geometry import Polygon

from agvnav.traffic._collide import first_overlap, is_convex, pad_footprints, place, polygons_overlap
from agvnav.traffic.zones import model_footprint

MODELS = ("differential", "tricycle", "mecanum", "tracked", "quad_steer", "tricycle_rear", "ackermann")


def _convex(rng: np.random.Generator) -> np.ndarray:
    """A random convex polygon (3 to 8 vertices, counter-clockwise or not) around the origin."""
    k = int(rng.integers(3, 9))
    ang = np.sort(rng.uniform(0.0, 2.0 * math.pi, k))
    r = rng.uniform(0.2, 1.0)
    pts = np.column_stack([r * np.cos(ang) * rng.uniform(0.5, 1.5), r * np.sin(ang)]) + rng.uniform(-0.2, 0.2, 2)
    hull = Polygon(pts).convex_hull
    out = np.array(hull.exterior.coords)[:-1]
    return out[::-1] if rng.uniform() < 0.5 else out


def _shapely_first(xs, ys, hs, feet) -> int:  # type: ignore[no-untyped-def]
    polys = []
    for x, y, h, fp in zip(xs, ys, hs, feet, strict=True):
        c, s = math.cos(h), math.sin(h)
        polys.append(Polygon(np.column_stack([x + c * fp[:, 0] - s * fp[:, 1], y + s * fp[:, 0] + c * fp[:, 1]])))
    n = len(polys)
    for a in range(n):
        for b in range(a + 1, n):
            if polys[a].intersects(polys[b]):
                return a * n + b
    return -1


def _kernel_first(xs, ys, hs, feet) -> int:  # type: ignore[no-untyped-def]
    fps, counts = pad_footprints(feet)
    radius = np.array([float(np.max(np.hypot(f[:, 0], f[:, 1]))) for f in feet])
    k = fps.shape[1]
    return int(first_overlap(np.asarray(xs, float), np.asarray(ys, float), np.asarray(hs, float), radius, fps, counts,
                             np.zeros((k, 2)), np.zeros((k, 2))))


@given(st.integers(0, 2**32 - 1), st.integers(2, 12), st.floats(1.0, 6.0))
def test_first_overlap_is_shapely_s_first_intersecting_pair(seed: int, n: int, side: float) -> None:
    """Random convex footprints at random poses in a square of ``side`` m: the same first pair as shapely."""
    rng = np.random.default_rng(seed)
    feet = [_convex(rng) for _ in range(n)]
    xs, ys, hs = rng.uniform(0, side, n), rng.uniform(0, side, n), rng.uniform(-math.pi, math.pi, n)
    assert _kernel_first(xs, ys, hs, feet) == _shapely_first(xs, ys, hs, feet)


@given(st.integers(0, 2**32 - 1))
def test_two_polygons_overlap_as_shapely_says_near_contact(seed: int) -> None:
    """Pairs placed at distances around first contact (the hard cases): overlap iff shapely intersects."""
    rng = np.random.default_rng(seed)
    p, q = _convex(rng), _convex(rng)
    h = rng.uniform(-math.pi, math.pi)
    pa, pb = np.zeros((len(p), 2)), np.zeros((len(q), 2))
    place(p, len(p), 0.0, 0.0, 0.0, pa)
    for d in np.linspace(0.0, 2.5, 40):
        place(q, len(q), d * math.cos(h), d * math.sin(h), h, pb)
        assert polygons_overlap(pa, len(p), pb, len(q)) == Polygon(pa).intersects(Polygon(pb))


def test_touching_rectangles_overlap_and_a_gap_separates() -> None:
    """Two 1 m squares side by side: touching counts (as shapely), 1 mm apart does not."""
    sq = np.array([[0.5, -0.5], [0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5]])
    feet = [sq, sq]
    assert _kernel_first([0.0, 1.0], [0.0, 0.0], [0.0, 0.0], feet) == 1
    assert _kernel_first([0.0, 1.001], [0.0, 0.0], [0.0, 0.0], feet) == -1
    assert _kernel_first([0.0, 0.999], [0.0, 0.0], [0.0, math.pi / 2], feet) == 1


@pytest.mark.parametrize("model", MODELS)
def test_the_shipped_footprints_are_convex_or_flagged(model: str) -> None:
    """Each shipped model's footprint: is_convex agrees with shapely (its convex hull has the same area)."""
    fp = model_footprint(model)
    poly = Polygon(fp)
    assert is_convex(fp) == (abs(poly.convex_hull.area - poly.area) < 1e-12)


def test_is_convex_refuses_a_dart_and_a_self_crossing_polygon() -> None:
    """A concave dart and a bow tie are not convex; a square either way round is."""
    sq = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    assert is_convex(sq) and is_convex(sq[::-1])
    assert not is_convex(np.array([[0.0, 0.0], [2.0, 1.0], [0.5, 0.0], [2.0, -1.0]]))
    assert not is_convex(np.array([[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]))
