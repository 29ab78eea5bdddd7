"""Shared pieces of the three-reflector kernels (absolute angles, relative angles, ToTal).

Batch-internal helpers on component arrays: ``x``/``y``/``theta`` are tuples of three
arrays (reflectors 1, 2, 3) that broadcast against each other. Nothing here raises;
singular elements come out as inf/NaN and are flagged by the callers.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agvnav.geometry.angles import wrap_angle, wrap_angle_scalar

#: A kernel value: an ``NDArray[float64]`` (or a bool flag array) of a batch when ``xp`` is NumPy, a
#: Python float (or bool) for one fix when ``xp`` is :class:`ScalarMath`. One formulation serves both
#: (issue 11), and NumPy's stubs cannot type a value whose type follows the namespace argument, so the
#: kernels' values are typed ``Any``; the namespace-free helpers keep their NumPy types.
Arr = Any
Three = tuple[Arr, Arr, Arr]

#: Relative distance of the head from the critical circle (|C_12 C_23| over the layout
#: scale) below which the heading is unobservable from the three bearings. With the seed's
#: 65535-pulse head the heading error grows like sigma * d / |C_12 C_23|: at 1e-2 it is
#: about 50 bearing stds, so inside this band the odometric heading is better (seed 000, §2.3).
CRITICAL_TOL = 1e-2

TWO_PI = 2.0 * np.pi

#: |tan| of a relative angle below which a fix is reordered (about 14 degrees from aligned).
REORDER_TOL = 0.25


class ScalarMath:
    """The NumPy functions the kernels use, on plain Python floats (the single-fix fast path).

    NumPy costs about 1 µs per call on a one-element array; ``math`` about 50 ns. The
    kernels take ``xp=np`` for batches and ``xp=ScalarMath`` for one fix. Python floats
    raise on division by zero or overflow where NumPy returns inf/NaN, so the caller
    falls back to the NumPy path on ``ArithmeticError``/``ValueError``.
    """

    tan = staticmethod(math.tan)
    cos = staticmethod(math.cos)
    sin = staticmethod(math.sin)
    arctan2 = staticmethod(math.atan2)
    sqrt = staticmethod(math.sqrt)
    copysign = staticmethod(math.copysign)
    sign = staticmethod(lambda a: float((a > 0) - (a < 0)))
    isfinite = staticmethod(math.isfinite)
    abs = staticmethod(abs)
    any = staticmethod(bool)
    rint = staticmethod(round)
    maximum = staticmethod(max)
    logical_not = staticmethod(lambda a: not a)

    @staticmethod
    def where(cond: bool, a: Any, b: Any) -> Any:
        return a if cond else b

    @staticmethod
    def clip(v: float, lo: float, hi: float) -> float:
        return min(max(v, lo), hi)


def wrap(a: Arr, xp: Any = np) -> Arr:
    """``geometry.wrap_angle`` to ``[-pi, pi)`` for either namespace (NumPy arrays or ``ScalarMath`` floats)."""
    if xp is np:
        return wrap_angle(a)
    return wrap_angle_scalar(a)  # xp=ScalarMath: a is a float, as the result


def order_pairs(x: Three, y: Three, theta: Three, xp: Any = np) -> tuple[Three, Three, Three, Three]:
    """Cyclically reorder a fix whose pair (1, 2) or (2, 3) is nearly aligned with P, so that pair is (3, 1).

    Returns ``x, y, theta`` reordered and ``tan_ab = (tan(theta2-theta1), tan(theta3-theta2),
    tan(theta1-theta3))`` in the new order. ``|tan|`` is monotone in ``|sin|`` of the
    relative angle, so the pair with the smallest ``|tan|`` is the one whose circle
    centre is nearest infinity (P aligned with both reflectors, the [seed000 eq5] case).
    A cyclic shift keeps the orientation, so all later formulas hold unchanged; pairs
    (1, 2) and (2, 3) then have ``|tan| >= REORDER_TOL`` or are the better conditioned
    ones. Only fixes near alignment are reordered; a chunk without any is left untouched.
    """
    t12 = xp.tan(theta[1] - theta[0])
    t23 = xp.tan(theta[2] - theta[1])
    t31 = xp.tan(theta[0] - theta[2])
    a12, a23, a31 = xp.abs(t12), xp.abs(t23), xp.abs(t31)
    roll1 = (a12 < REORDER_TOL) & (a12 < a23) & (a12 < a31)  # order (2, 3, 1): pair (1, 2) -> (3', 1')
    roll2 = (a23 < REORDER_TOL) & (a23 <= a12) & (a23 < a31)  # order (3, 1, 2): pair (2, 3) -> (3', 1')
    tans = (t12, t23, t31)
    if xp is ScalarMath or np.ndim(roll1) == 0:  # one fix
        if roll1:
            return (x[1], x[2], x[0]), (y[1], y[2], y[0]), (theta[1], theta[2], theta[0]), (t23, t31, t12)
        if roll2:
            return (x[2], x[0], x[1]), (y[2], y[0], y[1]), (theta[2], theta[0], theta[1]), (t31, t12, t23)
        return x, y, theta, tans
    if not (np.any(roll1) or np.any(roll2)):
        return x, y, theta, tans

    def pick(v: Three) -> Three:
        v0, v1, v2 = v
        return (
            np.where(roll1, v1, np.where(roll2, v2, v0)),
            np.where(roll1, v2, np.where(roll2, v0, v1)),
            np.where(roll1, v0, np.where(roll2, v1, v2)),
        )

    return pick(x), pick(y), pick(theta), pick(tans)


def centres(x: Three, y: Three, tan_ab: Three) -> tuple[Three, Three]:
    """Centres ``C_12, C_23, C_31`` of the circles through P and each reflector pair (seed 000, Fig. 3).

    The chord ``R_i R_j`` subtends the inscribed angle ``alpha_ij = theta_j - theta_i`` at P, so
    ``C_ij = (R_i + R_j)/2 + cot(alpha_ij)/2 * rot90(R_j - R_i)`` with ``rot90(u, v) = (-v, u)``.
    Returns ``(cx, cy)`` tuples in pair order (12, 23, 31).
    """
    cx: list[Arr] = []
    cy: list[Arr] = []
    for i, j, t in ((0, 1, tan_ab[0]), (1, 2, tan_ab[1]), (2, 0, tan_ab[2])):
        k = 0.5 / t
        cx.append(0.5 * (x[i] + x[j]) - k * (y[j] - y[i]))
        cy.append(0.5 * (y[i] + y[j]) + k * (x[j] - x[i]))
    return (cx[0], cx[1], cx[2]), (cy[0], cy[1], cy[2])


def line_directions_and_turns(heading: Arr, theta: Three, xp: Any = np) -> tuple[Three, Three, Three]:
    """Unnormalised directions of the lines at absolute angles ``heading + theta_i``, and their half-turns.

    Lines are undirected, so each angle is reduced modulo pi to [-pi/2, pi/2] (removing
    ``k_i`` half-turns) and the direction written with the half-angle tangent ``t``:
    ``(1 - t², 2t)``. This needs one ``tan`` per line instead of a ``sin`` and a ``cos``
    (several times faster in NumPy). The ray from P towards reflector i points along
    ``(-1)**k_i * (ux_i, uy_i)``. Returns ``(ux, uy, k)``.
    """
    ux: list[Arr] = []
    uy: list[Arr] = []
    turns: list[Arr] = []
    for th in theta:
        phi = heading + th
        k = xp.rint(phi / np.pi)
        t = xp.tan(0.5 * (phi - np.pi * k))
        ux.append(1.0 - t * t)
        uy.append(2.0 * t)
        turns.append(k)
    return (ux[0], ux[1], ux[2]), (uy[0], uy[1], uy[2]), (turns[0], turns[1], turns[2])


def intersect(
    xi: Arr, yi: Arr, ui: Arr, vi: Arr, xj: Arr, yj: Arr, uj: Arr, vj: Arr
) -> tuple[Arr, Arr]:
    """Intersection of the line through ``(xi, yi)`` along ``(ui, vi)`` with the one through ``(xj, yj)``.

    Parallel lines give inf/NaN (callers weight or flag them).
    """
    den = ui * vj - vi * uj
    s = ((xj - xi) * vj - (yj - yi) * uj) / den
    return xi + s * ui, yi + s * vi


def norm(u: Arr, v: Arr, xp: Any = np) -> Arr:
    """Length of ``(u, v)``: ``sqrt(u² + v²)`` (NumPy's ``hypot`` is ~10x slower; no overflow at these scales)."""
    return xp.sqrt(u * u + v * v)


def layout_scale2(x: Three, y: Three) -> Arr:
    """Mean squared reflector spacing (m²): the length scale of relative tolerances."""
    d12 = (x[1] - x[0]) ** 2 + (y[1] - y[0]) ** 2
    d23 = (x[2] - x[1]) ** 2 + (y[2] - y[1]) ** 2
    d31 = (x[0] - x[2]) ** 2 + (y[0] - y[2]) ** 2
    return (d12 + d23 + d31) / 3.0


def heading_from_position(px: Arr, py: Arr, x: Three, y: Three, theta: Three, xp: Any = np) -> Arr:
    """Heading (rad) as the circular mean of ``atan2(R_i - P) - theta_i`` over the three reflectors."""
    h0 = xp.arctan2(y[0] - py, x[0] - px) - theta[0]
    h1 = xp.arctan2(y[1] - py, x[1] - px) - theta[1]
    h2 = xp.arctan2(y[2] - py, x[2] - px) - theta[2]
    return wrap(h0 + (wrap(h1 - h0, xp) + wrap(h2 - h0, xp)) / 3.0, xp)
