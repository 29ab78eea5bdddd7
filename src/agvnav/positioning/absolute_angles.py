"""Absolute-angle triangulation of Font-Llagunes & Batlle (seed 000, §2.3, eqs 1-7; seed 001, §3).

With a heading estimate ``psi_est = psi + delta``, the line through reflector ``R_i`` at the
absolute angle ``Phi_i,est = psi_est + theta_i`` is the true ray rotated by ``delta`` about
``R_i``. Two such lines meet at the vertex ``T_ij`` of the *error triangle*, which lies on the
circle through ``P, R_i, R_j`` (same inscribed angle), whose centre ``C_ij`` is therefore also
the circumcentre of ``R_i, R_j, T_ij``. ``T_ij`` is ``P`` rotated by ``2 delta`` about ``C_ij``, so

    T_ij - T_ik = (1 - e^{2 i delta}) (C_ij - C_ik) = 2 sin|delta| e^{∓i(90° - |delta|)} (C_ij - C_ik):

the error triangle is the *centres triangle* scaled by ``r = 2 sin|delta|`` (eq. 1) and turned
clockwise by ``90° - |delta|`` when ``delta > 0``. Hence ``|delta|`` from the area ratio
(eqs 2, 4) or, when P is aligned with two reflectors and one vertex is at infinity, from the
ratio of finite sides (eqs 3, 5); the sign from the cross product of homologous sides (eq. 6);
the corrected absolute angles give three pairwise intersections ``P_ij`` averaged with the
weights of eq. 7.

Deviations, each for a stated reason:

* ``arcsin`` is evaluated as ``atan2(s, sqrt(1 - s²))`` (same value; cheaper and defined when
  noise pushes ``s`` slightly past 1, where it is clipped).
* Refinement: eqs 2-6 are applied a second time from the corrected heading. Near
  ``|delta| = 90°`` ``arcsin`` is flat, so one pass loses half the significant digits
  (error ~ sqrt(eps)); the second pass has ``delta ≈ 0`` where ``arcsin`` is linear. This
  is the seed's own construction repeated, not a different estimator; a full
  maximum-likelihood refinement is what ``method="least_squares"`` is for.
* ``delta`` is only known modulo 180° (lines are undirected): the half-turn is chosen so
  that reflector 1 lies ahead along its ray, which makes any heading estimate work away
  from the critical circle.
* The corrected error triangle is not re-intersected from new lines: each vertex is turned
  about its centre ``C_ij`` by ``-2 delta`` (the seed's own similarity relation), which is
  the same point and needs no trigonometry (speed).
* The distance ``rho_ij`` of eq. 7 needs P; it is measured from a first weighted mean
  with ``rho`` left out (weights ``sin alpha_ij / L_ij``).
* On or near the critical circle (``|C_12 C_23|`` below ``CRITICAL_TOL`` of the layout
  scale) the heading is unobservable: the heading estimate is kept, the position is the
  intersection of the lines it defines, and ``heading_from_estimate`` is set (seed 000, §2.3).
"""

from __future__ import annotations

from typing import Any

import math

import numpy as np

from agvnav.positioning._three import (
    CRITICAL_TOL,
    Arr,
    ScalarMath,
    Three,
    centres,
    intersect,
    layout_scale2,
    line_directions,
    order_pairs,
    wrap,
)

#: |tan(alpha_31)| below which vertex T_31 is treated as at infinity and eq. 5 replaces eq. 4.
ALIGN_TOL = 1e-3
#: sin of the angle between two lines below which their intersection is not used (eq. 7 weight 0).
#: The turned vertex of such a pair carries a rounding error ~ eps L / sin², i.e. ~ eps / sin
#: after weighting; below 1e-3 its weight is under 0.1 % of the others anyway.
SIN_TOL = ALIGN_TOL


def _parallel(ui: float, vi: float, uj: float, vj: float) -> bool:
    """Float path only: True when two line directions are exactly parallel (no intersection)."""
    return ui * vj - vi * uj == 0.0


def _tri_area(ax: Arr, ay: Arr, bx: Arr, by: Arr, cx: Arr, cy: Arr, xp: Any) -> Arr:
    """Unsigned area (m²) of triangle abc."""
    return 0.5 * xp.abs((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))


def _error_triangle(x: Three, y: Three, theta: Three, heading: Arr, xp: Any) -> tuple[Three, Three]:
    """Vertices ``T_12, T_23, T_31`` of the error triangle for a heading estimate (seed 000, Fig. 2b)."""
    ux, uy = line_directions(heading, theta, xp)
    t12 = intersect(x[0], y[0], ux[0], uy[0], x[1], y[1], ux[1], uy[1])
    t23 = intersect(x[1], y[1], ux[1], uy[1], x[2], y[2], ux[2], uy[2])
    if xp is ScalarMath and _parallel(ux[2], uy[2], ux[0], uy[0]):
        t31 = (math.inf, math.inf)  # eq. 5 case: this vertex is not used
    else:
        t31 = intersect(x[2], y[2], ux[2], uy[2], x[0], y[0], ux[0], uy[0])
    return (t12[0], t23[0], t31[0]), (t12[1], t23[1], t31[1])


def _similarity(tx: Three, ty: Three, cx: Three, cy: Three, aligned: Arr, xp: Any) -> tuple[Arr, Arr]:
    """``(sin delta, cos delta)`` from the error and centres triangles (seed 000, eqs 1-6).

    ``sin²|delta| = A_e / (4 A_c)`` (eqs 1, 2, 4) or ``|T_12 T_23|² / (4 |C_12 C_23|²)`` where
    ``aligned`` (eqs 3, 5); the sign of ``[T_12T_23 ∧ C_12C_23]_z`` (eq. 6); ``cos delta >= 0``.
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

    The error triangle of the lines at ``heading`` (seed 000, Fig. 2b), then eqs 4-6:
    ``|delta| = arcsin(sqrt(A_e / A_c) / 2)``, evaluated as ``atan2(sin, cos)``.
    """
    tx, ty = _error_triangle(x, y, theta, heading, xp)
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
    """Eq. 7: mean of the pairwise intersections ``P_ij`` weighted ``W_ij = sin a_ij / max(L_ij, 2 rho_ij)``.

    ``tx, ty`` are the intersections of the corrected lines, in pair order (12, 23, 31). A
    pair of parallel lines has ``sin a_ij = 0`` and drops out (its P_ij is not used).
    """
    pairs = ((0, 1), (1, 2), (2, 0))
    px: list[Arr] = []
    py: list[Arr] = []
    lengths: list[Arr] = []
    used: list[Arr] = []
    for k, ((i, j), s) in enumerate(zip(pairs, sin_a, strict=True)):
        lengths.append(xp.hypot(x[j] - x[i], y[j] - y[i]))
        if xp is ScalarMath:
            keep = s > SIN_TOL
            px.append(tx[k] if keep else 0.0)
            py.append(ty[k] if keep else 0.0)
            used.append(s if keep else 0.0)
        else:
            keep = s > SIN_TOL
            px.append(xp.where(keep, tx[k], 0.0))
            py.append(xp.where(keep, ty[k], 0.0))
            used.append(xp.where(keep, s, 0.0))
    sin_a = (used[0], used[1], used[2])

    def mean(weights: list[Arr]) -> tuple[Arr, Arr]:
        total = weights[0] + weights[1] + weights[2]
        mx = (weights[0] * px[0] + weights[1] * px[1] + weights[2] * px[2]) / total
        my = (weights[0] * py[0] + weights[1] * py[1] + weights[2] * py[2]) / total
        return mx, my

    x0, y0 = mean([s / lng for s, lng in zip(sin_a, lengths, strict=True)])
    w = []
    for (i, j), s, lng in zip(pairs, sin_a, lengths, strict=True):
        rho = xp.hypot(0.5 * (x[i] + x[j]) - x0, 0.5 * (y[i] + y[j]) - y0)
        w.append(s / xp.maximum(lng, 2.0 * rho))
    return mean(w)


def absolute_angles_kernel(
    x: Three, y: Three, theta: Three, heading_estimate: Arr, xp: Any = np
) -> dict[str, Arr]:
    """Absolute-angle triangulation on component arrays (m, rad); see the module docstring.

    ``xp`` is ``numpy`` (batches; run under ``np.errstate(all="ignore")``) or
    ``_three.ScalarMath`` (one fix in floats). Returns ``x, y, heading, quality, valid,
    heading_from_estimate``; ``quality`` is ``|C_12 C_23|`` over the layout scale (0 on
    the critical circle).
    """
    x, y, theta, tan_ab = order_pairs(x, y, theta, xp)
    sin_a = tuple(xp.abs(t) / xp.sqrt(1.0 + t * t) for t in tan_ab)
    aligned = xp.abs(tan_ab[2]) < ALIGN_TOL
    cx, cy = centres(x, y, tan_ab)
    quality = xp.hypot(cx[1] - cx[0], cy[1] - cy[0]) / xp.sqrt(layout_scale2(x, y))
    critical = xp.logical_not(quality > CRITICAL_TOL)
    psi_est = heading_estimate
    tx0, ty0 = _error_triangle(x, y, theta, psi_est, xp)  # lines at the estimate (Fig. 2b)
    tx, ty, psi = tx0, ty0, psi_est
    for _ in range(2):  # one pass of eqs 4-6, then the refinement pass
        sin_d, cos_d = _similarity(tx, ty, cx, cy, aligned, xp)
        psi = psi - xp.arctan2(sin_d, cos_d)
        tx, ty = _turn(tx, ty, cx, cy, sin_d, cos_d)
    if xp is ScalarMath:
        if critical:
            tx, ty, psi = tx0, ty0, psi_est
    else:
        psi = xp.where(critical, psi_est, psi)
        tx = tuple(xp.where(critical, a, b) for a, b in zip(tx0, tx, strict=True))
        ty = tuple(xp.where(critical, a, b) for a, b in zip(ty0, ty, strict=True))
    px, py = weighted_position(x, y, tx, ty, sin_a, xp)
    # delta is known modulo 180°: keep the half-turn that puts reflector 1 ahead of P.
    ahead = xp.arctan2(y[0] - py, x[0] - px) - theta[0]
    psi = xp.where(critical, psi, psi + np.pi * xp.rint(wrap(ahead - psi, xp) / np.pi))
    valid = xp.isfinite(px) & xp.isfinite(py) & xp.isfinite(psi)
    return {
        "x": px,
        "y": py,
        "heading": wrap(psi, xp),
        "quality": quality,
        "valid": valid,
        "heading_from_estimate": critical & valid,
    }
