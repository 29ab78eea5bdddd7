"""Absolute-angle triangulation of Font-Llagunes & Batlle (seed 000 §2.3; seed 001 §3).

With a heading estimate ``psi_est = psi + delta``, the line through reflector ``R_i`` at the
absolute angle ``Phi_i,est = psi_est + theta_i`` is the true ray rotated by ``delta`` about
``R_i``. Two such lines meet at the vertex ``T_ij`` of the *error triangle*, which lies on the
circle through ``P, R_i, R_j`` (same inscribed angle), whose centre ``C_ij`` is therefore also
the circumcentre of ``R_i, R_j, T_ij``. ``T_ij`` is ``P`` rotated by ``2 delta`` about ``C_ij``, so

    T_ij - T_ik = (1 - e^{2 i delta}) (C_ij - C_ik) = 2 sin|delta| e^{∓i(90° - |delta|)} (C_ij - C_ik):

the error triangle is the *centres triangle* scaled by ``r = 2 sin|delta|`` [seed000 eq1] and
turned clockwise by ``90° - |delta|`` when ``delta > 0``. Hence ``|delta|`` from the area ratio
([seed000 eq2] [seed000 eq4]; both in one line in [seed001 eq1]) or, when P is aligned with two
reflectors and one vertex is at infinity, from the ratio of finite sides ([seed000 eq3]
[seed000 eq5]); the sign from the cross product of homologous sides [seed000 eq6]; the
corrected absolute angles give three pairwise intersections ``P_ij`` averaged with the
weights of [seed000 eq7].

Deviations, each for a stated reason:

* ``arcsin`` is evaluated as ``atan2(s, sqrt(1 - s²))`` (same value; cheaper and defined when
  noise pushes ``s`` slightly past 1, where it is clipped).
* Refinement: where the first pass finds ``|delta| > 45°``, the construction above
  ([seed000 eq2] [seed000 eq3] [seed000 eq4] [seed000 eq5] [seed000 eq6]) is applied a second
  time from the corrected heading. Near ``|delta| = 90°`` ``arcsin`` is flat, so one pass
  loses half the significant digits (error ~ sqrt(eps)); the second pass has ``delta ≈ 0``
  where ``arcsin`` is linear. This is the seed's own construction repeated, not a
  different estimator. Below 45° a second pass would only move the result at the level
  of the bearing noise (a noisy error triangle is not exactly similar to the centres
  triangle) and the single pass already attains the CRLB (Monte Carlo tests, bench), so
  it is skipped; a full maximum-likelihood refinement is what ``method="least_squares"``
  is for.
* ``delta`` is only known modulo 180° (lines are undirected): the half-turn is chosen so
  that reflector 1 lies ahead along its ray, which makes any heading estimate work away
  from the critical circle.
* The position is recomputed from the corrected lines, but without re-intersecting them:
  each vertex is turned about its centre ``C_ij`` by ``-2 delta`` (inscribed-angle theorem).
  ``C_ij`` comes from the *measured* relative angle, so this is exactly the intersection of
  the corrected noisy lines, with no trigonometry (speed).
* The distance ``rho_ij`` of [seed000 eq7] needs P; it is measured from the midpoint of the two
  intersections that are never nearly parallel (``P_12``, ``P_23`` after reordering).
* On or near the critical circle (``|C_12 C_23|`` below ``CRITICAL_TOL`` of the layout
  scale) the heading is unobservable: the heading estimate is kept, the position is the
  intersection of the lines it defines, and ``heading_from_estimate`` is set (seed 000, §2.3).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.positioning._three import (
    CRITICAL_TOL,
    Arr,
    ScalarMath,
    Three,
    centres,
    intersect,
    layout_scale2,
    line_directions_and_turns,
    norm,
    order_pairs,
    wrap,
)

#: |tan(alpha_31)| below which vertex T_31 is treated as at infinity and eq. 5 replaces eq. 4.
ALIGN_TOL = 1e-3
#: sin of the angle between two lines below which their intersection is not used (eq. 7 weight 0).
#: The turned vertex of such a pair carries a rounding error ~ eps L / sin², i.e. ~ eps / sin
#: after weighting; below 1e-3 its weight is under 0.1 % of the others anyway.
SIN_TOL = ALIGN_TOL
#: cos(delta) below which (|delta| > 45°) the refinement pass runs: arcsin's error there
#: grows like eps / cos(delta), up to sqrt(eps) at 90°.
REFINE_COS = math.sqrt(0.5)


def _parallel(ui: float, vi: float, uj: float, vj: float) -> bool:
    """Float path only: True when two line directions are exactly parallel (no intersection)."""
    return ui * vj - vi * uj == 0.0


def _tri_area(ax: Arr, ay: Arr, bx: Arr, by: Arr, cx: Arr, cy: Arr, xp: Any) -> Arr:
    """Unsigned area (m²) of triangle abc."""
    return 0.5 * xp.abs((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))


def _error_triangle(
    x: Three, y: Three, theta: Three, heading: Arr, xp: Any
) -> tuple[tuple[Three, Three], Three]:
    """Error-triangle vertices ``T_12, T_23, T_31`` for a heading estimate (seed 000, Fig. 2b).

    A vertex at infinity is the [seed000 eq3] [seed000 eq5] case (P aligned with two reflectors).

    Returns ``((tx, ty), (ux, uy, k))``: the vertices, the (unnormalised) directions of the
    three lines and the half-turns ``k`` that orient them as rays (see ``line_directions_and_turns``).
    """
    ux, uy, turns = line_directions_and_turns(heading, theta, xp)
    t12 = intersect(x[0], y[0], ux[0], uy[0], x[1], y[1], ux[1], uy[1])
    t23 = intersect(x[1], y[1], ux[1], uy[1], x[2], y[2], ux[2], uy[2])
    if xp is ScalarMath and _parallel(ux[2], uy[2], ux[0], uy[0]):
        t31 = (math.inf, math.inf)  # eq. 5 case: this vertex is not used
    else:
        t31 = intersect(x[2], y[2], ux[2], uy[2], x[0], y[0], ux[0], uy[0])
    return ((t12[0], t23[0], t31[0]), (t12[1], t23[1], t31[1])), (ux, uy, turns)


def _similarity(tx: Three, ty: Three, cx: Three, cy: Three, aligned: Arr, xp: Any) -> tuple[Arr, Arr]:
    """``(sin delta, cos delta)`` from the error and centres triangles.

    ``sin²|delta| = A_e / (4 A_c)`` ([seed000 eq1] [seed000 eq2] [seed000 eq4], told in one line as
    [seed001 eq1]) or ``|T_12 T_23|² / (4 |C_12 C_23|²)`` where ``aligned`` ([seed000 eq3]
    [seed000 eq5]); the sign of ``[T_12T_23 ∧ C_12C_23]_z`` [seed000 eq6]; ``cos delta >= 0``.
    """
    sx, sy = tx[1] - tx[0], ty[1] - ty[0]  # side T_12 -> T_23
    kx, ky = cx[1] - cx[0], cy[1] - cy[0]  # homologous side C_12 -> C_23
    ratio_side = (sx * sx + sy * sy) / (kx * kx + ky * ky)
    if xp is ScalarMath and aligned:
        ratio = ratio_side
    else:
        area_e = _tri_area(tx[0], ty[0], tx[1], ty[1], tx[2], ty[2], xp)
        ratio = xp.where(aligned, ratio_side, area_e / _tri_area(cx[0], cy[0], cx[1], cy[1], cx[2], cy[2], xp))
    q = xp.clip(0.25 * ratio, 0.0, 1.0)  # sin²|delta| (eq. 1)
    return xp.copysign(xp.sqrt(q), sx * ky - sy * kx), xp.sqrt(1.0 - q)


def heading_error(
    x: Three, y: Three, theta: Three, heading: Arr, cx: Three, cy: Three, aligned: Arr, xp: Any = np
) -> Arr:
    """Signed heading error ``delta = psi_est - psi`` (rad, in [-90°, 90°]) of a heading estimate.

    The error triangle of the lines at ``heading`` (seed 000, Fig. 2b), then [seed000 eq4]
    [seed000 eq5] [seed000 eq6]: ``|delta| = arcsin(sqrt(A_e / A_c) / 2)``, evaluated as
    ``atan2(sin, cos)``.
    """
    (tx, ty), _ = _error_triangle(x, y, theta, heading, xp)
    sin_d, cos_d = _similarity(tx, ty, cx, cy, aligned, xp)
    return xp.arctan2(sin_d, cos_d)


def _turn(tx: Three, ty: Three, cx: Three, cy: Three, sin_d: Arr, cos_d: Arr) -> tuple[Three, Three]:
    """Error-triangle vertices after correcting the heading by ``-delta``.

    Turning every line by ``-delta`` about its reflector moves ``T_ij`` along its circle by
    ``-2 delta`` about ``C_ij`` (inscribed-angle theorem; exact for noisy bearings too, since
    ``C_ij`` comes from the measured relative angle). No trigonometry: ``cos 2d = c² - s²``,
    ``sin 2d = 2 s c``.
    """
    c2 = cos_d * cos_d - sin_d * sin_d
    s2 = 2.0 * sin_d * cos_d
    ox: list[Arr] = []
    oy: list[Arr] = []
    for k in range(3):
        vx, vy = tx[k] - cx[k], ty[k] - cy[k]
        ox.append(cx[k] + c2 * vx + s2 * vy)
        oy.append(cy[k] - s2 * vx + c2 * vy)
    return (ox[0], ox[1], ox[2]), (oy[0], oy[1], oy[2])


def weighted_position(x: Three, y: Three, tx: Three, ty: Three, sin_a: Three, xp: Any = np) -> tuple[Arr, Arr]:
    """Mean of the pairwise intersections ``P_ij`` weighted ``W_ij = sin a_ij / max(L_ij, 2 rho_ij)`` [seed000 eq7].

    ``tx, ty`` are the intersections of the corrected lines, in pair order (12, 23, 31);
    after ``order_pairs`` only pair (3, 1) can be nearly parallel, and below ``SIN_TOL`` it
    drops out. ``rho_ij`` is measured from the midpoint of ``P_12`` and ``P_23``.
    """
    tx2, ty2, s31 = tx[2], ty[2], sin_a[2]
    if xp is ScalarMath:
        if not s31 > SIN_TOL:
            tx2, ty2, s31 = 0.0, 0.0, 0.0
    elif xp.any(xp.logical_not(s31 > SIN_TOL)):
        keep = s31 > SIN_TOL
        tx2, ty2, s31 = xp.where(keep, tx2, 0.0), xp.where(keep, ty2, 0.0), xp.where(keep, s31, 0.0)
    x0 = 0.5 * (tx[0] + tx[1])
    y0 = 0.5 * (ty[0] + ty[1])
    w = []
    for (i, j), s in zip(((0, 1), (1, 2), (2, 0)), (sin_a[0], sin_a[1], s31), strict=True):
        length = norm(x[j] - x[i], y[j] - y[i], xp)
        rho = norm(0.5 * (x[i] + x[j]) - x0, 0.5 * (y[i] + y[j]) - y0, xp)
        w.append(s / xp.maximum(length, 2.0 * rho))
    total = w[0] + w[1] + w[2]
    return (w[0] * tx[0] + w[1] * tx[1] + w[2] * tx2) / total, (w[0] * ty[0] + w[1] * ty[1] + w[2] * ty2) / total


def _refine(idx: NDArray[np.intp], tx: Three, ty: Three, cx: Three, cy: Three, aligned: Arr, psi: Arr) -> None:
    """Second pass of [seed000 eq4] [seed000 eq5] [seed000 eq6] for the fixes ``idx`` (in place on ``tx, ty, psi``)."""
    if idx.size == 0:
        return

    def sub(v: Three) -> Three:
        return tuple(c if np.ndim(c) == 0 else c[idx] for c in v)

    sx, sy, scx, scy = sub(tx), sub(ty), sub(cx), sub(cy)
    sin_d, cos_d = _similarity(sx, sy, scx, scy, aligned if np.ndim(aligned) == 0 else aligned[idx], np)
    psi[idx] -= np.arctan2(sin_d, cos_d)
    nx, ny = _turn(sx, sy, scx, scy, sin_d, cos_d)
    for k in range(3):
        tx[k][idx] = nx[k]
        ty[k][idx] = ny[k]


def absolute_angles_kernel(
    x: Three, y: Three, theta: Three, heading_estimate: Arr, xp: Any = np
) -> dict[str, Arr]:
    """Absolute-angle triangulation on component arrays (m, rad); see the module docstring.

    Seed 000 §2.3 in one pass: the heading error from the similar triangles (as in
    :func:`heading_error`), then the weighted position of :func:`weighted_position`.

    ``xp`` is ``numpy`` (batches; run under ``np.errstate(all="ignore")``) or
    ``_three.ScalarMath`` (one fix in floats). Returns ``x, y, heading, quality, valid,
    heading_from_estimate``; ``quality`` is ``|C_12 C_23|`` over the layout scale (0 on
    the critical circle).
    """
    scale = xp.sqrt(layout_scale2(x, y))  # order-invariant: before reordering (scalar for one layout)
    x, y, theta, tan_ab = order_pairs(x, y, theta, xp)
    sin_a = tuple(xp.abs(t) / xp.sqrt(1.0 + t * t) for t in tan_ab)
    aligned = xp.abs(tan_ab[2]) < ALIGN_TOL
    cx, cy = centres(x, y, tan_ab)
    quality = norm(cx[1] - cx[0], cy[1] - cy[0], xp) / scale
    critical = xp.logical_not(quality > CRITICAL_TOL)
    psi_est = heading_estimate
    (tx0, ty0), rays = _error_triangle(x, y, theta, psi_est, xp)  # lines at the estimate (Fig. 2b)
    sin_d, cos_d = _similarity(tx0, ty0, cx, cy, aligned, xp)  # eqs 4-6
    psi = psi_est - xp.arctan2(sin_d, cos_d)
    tx, ty = _turn(tx0, ty0, cx, cy, sin_d, cos_d)
    if xp is ScalarMath:
        if cos_d < REFINE_COS:
            sin_d, cos_d = _similarity(tx, ty, cx, cy, aligned, xp)
            psi = psi - xp.arctan2(sin_d, cos_d)
            tx, ty = _turn(tx, ty, cx, cy, sin_d, cos_d)
        if critical:
            tx, ty, psi = tx0, ty0, psi_est
    else:
        _refine(np.flatnonzero(cos_d < REFINE_COS), tx, ty, cx, cy, aligned, psi)
        keep = np.flatnonzero(critical)  # critical circle: the estimate's own lines
        if keep.size:
            psi[keep] = np.broadcast_to(psi_est, psi.shape)[keep]
            for k in range(3):
                tx[k][keep] = tx0[k][keep]
                ty[k][keep] = ty0[k][keep]
    px, py = weighted_position(x, y, tx, ty, sin_a, xp)
    # delta is known modulo 180°: keep the half-turn that puts the reflectors ahead of P along
    # their rays. Majority vote of the three signs of (R_k - P)·ray_k, so one reflector whose
    # ray is nearly perpendicular (or noisy) cannot flip the heading alone.
    behind = _behind(x, y, rays, psi - psi_est, px, py, xp)
    psi = xp.where(critical, psi, psi + np.pi * behind)
    valid = xp.isfinite(px) & xp.isfinite(py) & xp.isfinite(psi)
    return {
        "x": px,
        "y": py,
        "heading": wrap(psi, xp),
        "quality": quality,
        "valid": valid,
        "heading_from_estimate": critical & valid,
    }


def _ray_dot(k: int, x: Three, y: Three, rays: tuple[Three, Three, Three], c: Arr, s: Arr, px: Arr, py: Arr) -> Arr:
    """``(R_k − P)·u_k`` for the ray ``u_k`` (unnormalised) at the corrected heading.

    ``rays = (ux, uy, turns)`` are the estimate's undirected line directions and the
    half-turns that orient them (``u = (-1)**turns * (ux, uy)``), turned here by the
    correction whose cosine and sine are ``c, s``.
    """
    ux, uy, turns = rays[0][k], rays[1][k], rays[2][k]
    half = 0.5 * turns
    orient = 1.0 - 4.0 * abs(half - np.round(half)) if np.ndim(half) else (-1.0 if turns % 2 else 1.0)
    return orient * ((x[k] - px) * (ux * c - uy * s) + (y[k] - py) * (ux * s + uy * c))


def _behind(x: Three, y: Three, rays: tuple[Three, Three, Three], turn: Arr, px: Arr, py: Arr, xp: Any) -> Arr:
    """True where the reflectors lie behind P along their rays: the heading is off by a half-turn.

    Majority vote of the three reflectors (each must lie ahead along its ray), so one
    reflector whose ray is noisy or mirrored cannot flip the heading alone.
    ``turn = psi - psi_est``.
    """
    return _votes(x, y, rays, xp.cos(turn), xp.sin(turn), px, py, xp) < 0


def _votes(x: Three, y: Three, rays: tuple[Three, Three, Three], c: Arr, s: Arr, px: Arr, py: Arr, xp: Any) -> Arr:
    """Sum over k of sign((R_k − P)·u_k): +3 all reflectors ahead along their rays, −3 all behind."""
    votes = 0.0
    for k in range(3):
        dot = _ray_dot(k, x, y, rays, c, s, px, py)
        votes = votes + xp.sign(dot)
    return votes
