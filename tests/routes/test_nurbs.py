"""NURBS evaluation against an exact quarter circle; invalid definitions are named."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.routes.nurbs import Nurbs, nurbs_problem


def quarter_circle() -> Nurbs:
    w = math.sqrt(0.5)
    return Nurbs(2, (0.0, 0.0, 0.0, 1.0, 1.0, 1.0), np.array([[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
                 np.array([1.0, w, 1.0]))


def test_rational_quadratic_is_an_exact_circle() -> None:
    n = quarter_circle()
    u = np.linspace(0.0, 1.0, 101)
    p = n.point_at(u)
    assert np.hypot(p[:, 0], p[:, 1]) == pytest.approx(np.ones(101), abs=1e-14)
    # tangent perpendicular to the radius, turning counter-clockwise
    h = n.heading_at(u)
    phi = np.arctan2(p[:, 1], p[:, 0])
    residual = np.remainder(h - phi - math.pi / 2 + math.pi, 2 * math.pi) - math.pi
    assert residual == pytest.approx(np.zeros(101), abs=1e-12)
    pts, _, length = n.sample(0.01)
    assert length == pytest.approx(math.pi / 2, rel=1e-5)
    assert pts[0] == pytest.approx([1.0, 0.0]) and pts[-1] == pytest.approx([0.0, 1.0])


@pytest.mark.parametrize(
    ("degree", "knots", "weights", "match"),
    [
        (2, [0, 0, 0, 1, 1], [1, 1, 1], "knotVector must have 6"),
        (2, [0, 0, 1, 0.5, 1, 1], [1, 1, 1], "non-decreasing"),
        (2, [0, 0, 0, 1, 1, 1], [1, 0.0, 1], r"controlPoints\[1\].weight must be positive"),
        (3, [0, 0, 0, 0, 1, 1, 1], [1, 1, 1], "at least 4 control points"),
    ],
)
def test_invalid_nurbs_is_named(degree: int, knots: list[float], weights: list[float], match: str) -> None:
    problem = nurbs_problem(degree, knots, weights, len(weights))
    assert problem is not None
    assert pytest.importorskip("re").search(match, problem)
    with pytest.raises(ValueError, match=match):
        Nurbs(degree, tuple(knots), np.zeros((len(weights), 2)), np.array(weights, dtype=float))
