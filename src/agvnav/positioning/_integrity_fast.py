"""Compiled scalar kernels of the integrity monitor's once-per-revolution check (issue 11).

:meth:`agvnav.positioning.integrity.IntegrityMonitor.check` ran about forty NumPy calls and
a Python loop per sighting for one triangulation cross-check per revolution: 40 % of a
closed-loop step. These kernels (:func:`agvnav._jit.jit`: compiled by numba, or run as the
same plain Python with ``AGVNAV_JIT=0``) compute the same equations on the monitor's float
window (:meth:`~agvnav.positioning.integrity_window._Window.buffer`). They use plain ``math``
(``math.hypot``, ``x * x``, ``round``): the two modes agree to rounding (about 1e-12
relative, ``tests/test_jit.py``), not bit for bit, and a decision taken on a value within
rounding of its threshold may go either way in the two modes (issue 27: determinism is
within one mode). The leading-edge bearing is :func:`agvnav.positioning._fast.edge_bearing_row`
and the odometry variances of [seed002 eq17] :func:`agvnav.positioning._fast.increment_variances`,
the kernels the streaming estimator calls.

numba's on-disk cache keys a kernel on its own source file only (:mod:`agvnav._jit`): these
kernels read constants of other modules, which numba freezes into their machine code:
``LAYOUT_TOL``, ``NONLINEAR_RATIO``, ``PARALLEL_TOL`` (``positioning.triangulation``),
``CRITICAL_TOL`` and ``REORDER_TOL`` (``positioning._three``), and the window layout (``_T``, ...)
of :mod:`agvnav.positioning.integrity_window`. An edit of one of those alone leaves the cached
kernels with the old values until their own file changes or ``__pycache__`` is cleared
(``tests/test_jit.py`` then sees the two modes differ where the change matters on its inputs).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agvnav._jit import jit
from agvnav.geometry.angles import wrap_angle_kernel
from agvnav.positioning._fast import edge_bearing, increment_variances
from agvnav.positioning._three import CRITICAL_TOL, REORDER_TOL
from agvnav.positioning.integrity_window import _BEAR, _HAS_I, _IDX, _OPSI, _OX, _OY, _T, _WIDTH, _Y
from agvnav.positioning.total import total_core
from agvnav.positioning.triangulation import LAYOUT_TOL, NONLINEAR_RATIO, PARALLEL_TOL

__all__ = [
    "CROSSCHECK_FIX", "CROSSCHECK_NONE", "TOTAL_INVALID", "TOTAL_VALID",
    "best_triple", "crosscheck_fix", "fix_covariance", "in_range",
    "information", "mean_innovations", "nis_per_reflector", "nonlinear_fix", "position_crlb_one",
    "revolution_innovations", "revolution_offset", "total_fix", "window_fde",
]

#: :func:`total_fix` codes: no valid fix, a valid fix.
TOTAL_INVALID, TOTAL_VALID = 0, 1
#: :func:`crosscheck_fix` codes: no fix, a fix with its covariance.
CROSSCHECK_NONE, CROSSCHECK_FIX = 0, 1

_CRIT2 = (2.0 * CRITICAL_TOL) * (2.0 * CRITICAL_TOL)  # total's critical-circle bound (total_kernel's)



@jit
def _head(x: float, y: float, psi: float, mx: float, my: float, mpsi: float) -> tuple[float, float, float]:
    """Head pose in ``map`` from the base_link pose and the mount (``integrity_support``)."""
    c, s = math.cos(psi), math.sin(psi)
    return x + c * mx - s * my, y + s * mx + c * my, psi + mpsi


@jit
def _edge_bearing(hx: float, hy: float, hpsi: float, rx: float, ry: float, r: float) -> tuple[float, float]:
    """Leading-edge bearing (rad, head frame, wrapped) of the reflector at ``(rx, ry)`` (m), radius ``r`` (m).

    And its distance (m), from the head pose ``(hx, hy, hpsi)``: :func:`agvnav.positioning._fast.edge_bearing`.
    """
    h, _, _, _, d = edge_bearing(hx, hy, hpsi, 0.0, rx, ry, r)
    return h, d


@jit
def position_crlb_one(a00: float, a01: float, a02: float, a11: float, a12: float, a22: float) -> float:
    """Trace of the position block of the inverse of the symmetric 3x3 ``a`` (upper triangle; inf if singular)."""
    c00 = a11 * a22 - a12 * a12
    c11 = a00 * a22 - a02 * a02
    det = a00 * c00 + a01 * (a02 * a12 - a01 * a22) + a02 * (a01 * a12 - a02 * a11)
    if det == 0.0:
        return math.inf
    score = (c00 + c11) / det
    return score if score >= 0.0 and score < math.inf else math.inf


@jit
def best_triple(
    hx: float, hy: float, rx: Any, ry: Any, var: Any, bearing_var: float, max_var: float,
) -> int:
    """Rank (in ``itertools.combinations`` order) of the triple of reflectors with the smallest position CRLB.

    Head at ``(hx, hy)`` (m); candidates ``rx, ry (n,)`` (m) with bearing variances ``var (n,)``
    (rad²). Each reflector's information is its
    bearing Jacobian row ``[dy/d², -dx/d², -1]`` (seed 000 §2.3) squared, summed over a
    triple; triples whose bound with ``bearing_var`` (rad²) exceeds ``max_var`` (m²) are
    skipped, the rest ranked by their bound with ``var``.
    -1 when none qualifies or a reflector sits on the head.
    """
    n = len(rx)
    info = [0.0] * (6 * n)  # row k: the upper triangle 00 01 02 11 12 22 of its information
    for k in range(n):
        dx, dy = rx[k] - hx, ry[k] - hy
        d2 = dx * dx + dy * dy
        if d2 <= 0.0:
            return -1
        j0, j1 = dy / d2, -dx / d2
        info[6 * k], info[6 * k + 1], info[6 * k + 2] = j0 * j0, j0 * j1, -j0
        info[6 * k + 3], info[6 * k + 4], info[6 * k + 5] = j1 * j1, -j1, 1.0
    best, best_score, rank = -1, math.inf, 0
    for a in range(n):
        for b in range(a + 1, n):
            for c in range(b + 1, n):
                pa, pb, pc = 6 * a, 6 * b, 6 * c
                bound = position_crlb_one(
                    info[pa] + info[pb] + info[pc], info[pa + 1] + info[pb + 1] + info[pc + 1],
                    info[pa + 2] + info[pb + 2] + info[pc + 2], info[pa + 3] + info[pb + 3] + info[pc + 3],
                    info[pa + 4] + info[pb + 4] + info[pc + 4], info[pa + 5] + info[pb + 5] + info[pc + 5])
                if bound * bearing_var <= max_var:
                    wa, wb, wc = var[a], var[b], var[c]
                    score = position_crlb_one(
                        info[pa] / wa + info[pb] / wb + info[pc] / wc,
                        info[pa + 1] / wa + info[pb + 1] / wb + info[pc + 1] / wc,
                        info[pa + 2] / wa + info[pb + 2] / wb + info[pc + 2] / wc,
                        info[pa + 3] / wa + info[pb + 3] / wb + info[pc + 3] / wc,
                        info[pa + 4] / wa + info[pb + 4] / wb + info[pc + 4] / wc,
                        info[pa + 5] / wa + info[pb + 5] / wb + info[pc + 5] / wc)
                    if score < best_score:
                        best, best_score = rank, score
                rank += 1
    return best


@jit
def total_fix(
    x1: float, y1: float, x2: float, y2: float, x3: float, y3: float, t1: float, t2: float, t3: float,
) -> tuple[int, float, float]:
    """One ToTal fix (m) from three reflectors (m) and their bearings (rad): ``(code, x, y)``.

    ToTal (Pierlot & Van Droogenbroeck, IEEE T-RO 30(3), 2014; no seed document has it): the
    circle-intersection triangulation that seed 000 §2.2 names (arcs through two reflectors,
    refs [9-11] there), indeterminate on the critical circle through the three reflectors (the
    same section; no equation number in either seed).

    :func:`~agvnav.positioning.total.total_kernel` on floats (the single-fix path of
    :func:`~agvnav.positioning.triangulation.triangulate`), including the cyclic reorder of
    :func:`~agvnav.positioning._three.order_pairs` and triangulate's layout tests. ``code``:
    :data:`TOTAL_VALID`, or :data:`TOTAL_INVALID`: a bearing not finite, coincident reflectors
    (triangulate raises), rays parallel (every pair of bearings 0 or pi apart: the head on the
    reflectors' line), a cotangent that is infinite after the reorder or a degenerate
    intersection (a division by an exact zero), a fix not finite, or one within ``CRITICAL_TOL``
    of the critical circle. Decisions taken on values within rounding of a threshold may differ
    from triangulate's (and between the kernel's two modes).
    """
    if not (math.isfinite(t1) and math.isfinite(t2) and math.isfinite(t3)):
        return TOTAL_INVALID, math.nan, math.nan
    # triangulate's layout tests: coincident reflectors, or rays parallel (P on their line)
    d12 = (x2 - x1) * (x2 - x1) + (y2 - y1) * (y2 - y1)
    d23 = (x3 - x2) * (x3 - x2) + (y3 - y2) * (y3 - y2)
    d31 = (x1 - x3) * (x1 - x3) + (y1 - y3) * (y1 - y3)
    if min(d12, d23, d31) <= LAYOUT_TOL * LAYOUT_TOL * max(d12, d23, d31):
        return TOTAL_INVALID, math.nan, math.nan
    sp = max(abs(math.sin(t2 - t1)), abs(math.sin(t3 - t2)), abs(math.sin(t1 - t3)))
    if sp <= PARALLEL_TOL:
        return TOTAL_INVALID, math.nan, math.nan
    scale2 = (d12 + d23 + d31) / 3.0  # layout_scale2
    # order_pairs
    tn12, tn23, tn31 = math.tan(t2 - t1), math.tan(t3 - t2), math.tan(t1 - t3)
    a12, a23, a31 = abs(tn12), abs(tn23), abs(tn31)
    ta, tb = tn12, tn23
    if a12 < REORDER_TOL and a12 < a23 and a12 < a31:  # order (2, 3, 1)
        x1, x2, x3, y1, y2, y3 = x2, x3, x1, y2, y3, y1
        ta, tb = tn23, tn31
    elif a23 < REORDER_TOL and a23 <= a12 and a23 < a31:  # order (3, 1, 2)
        x1, x2, x3, y1, y2, y3 = x3, x1, x2, y3, y1, y2
        ta, tb = tn31, tn12
    if ta == 0.0 or tb == 0.0:
        return TOTAL_INVALID, math.nan, math.nan
    t12 = 1.0 / ta
    t23 = 1.0 / tb
    a, b, dk31, dd = total_core(x1 - x2, y1 - y2, x3 - x2, y3 - y2, t12, t23)
    if dd == 0.0:
        return TOTAL_INVALID, math.nan, math.nan
    f = dk31 / dd
    px = x2 + f * a
    py = y2 + f * b
    if not (math.isfinite(px) and math.isfinite(py)):
        return TOTAL_INVALID, px, py
    if a * a + b * b > _CRIT2 * scale2:
        return TOTAL_VALID, px, py
    return TOTAL_INVALID, px, py


@jit
def fix_covariance(
    rx: Any, ry: Any, px: float, py: float, std: Any,
) -> tuple[bool, float, float, float, float, float, float]:
    """Linearised covariance of a fix at ``(px, py)`` (m) from reflectors ``rx, ry (3,)`` (m), bearing stds ``std``.

    The Cramér-Rao bound of three bearings ``z_k = atan2(y_k - py, x_k - px) - psi`` (the
    bearing of seed 000 §2.1 about the head's centre; Jacobian rows ``[dy/d², -dx/d², -1]``),
    ``(J^T R^-1 J)^-1`` (no seed gives it an equation number) as triangulate computes it:
    :func:`~agvnav.positioning.bounds.fisher_information` (its ``einsum``: per entry
    ``((J_ki w_k) J_kj)`` summed over ``k`` in order from 0.0, ``w = 1 / std²``) and
    :func:`~agvnav.positioning.bounds.inv_sym3` (adjugate times ``1 / det``, singular when
    ``|det| <= 1e-13`` of its terms' magnitudes). Returns ``(ok, c00, c01, c02, c11, c12, c22)``
    (m², m·rad, rad²); not ``ok``: singular (the entries NaN).
    """
    a00 = a01 = a02 = a11 = a12 = a22 = 0.0
    for k in range(3):
        dx, dy = rx[k] - px, ry[k] - py
        d2 = dx * dx + dy * dy
        j0, j1 = dy / d2, -dx / d2
        w = 1.0 / (std[k] * std[k])
        a00 = a00 + j0 * w * j0
        a01 = a01 + j0 * w * j1
        a02 = a02 + j0 * w * -1.0
        a11 = a11 + j1 * w * j1
        a12 = a12 + j1 * w * -1.0
        a22 = a22 + -1.0 * w * -1.0
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    det = a00 * c00 + a01 * c01 + a02 * c02
    scale = abs(a00 * c00) + abs(a01 * c01) + abs(a02 * c02)
    if not (math.isfinite(det) and abs(det) > 1e-13 * scale):
        return False, math.nan, math.nan, math.nan, math.nan, math.nan, math.nan
    inv = 1.0 / det
    return True, c00 * inv, c01 * inv, c02 * inv, c11 * inv, c12 * inv, c22 * inv


@jit
def nonlinear_fix(rx: Any, ry: Any, px: float, py: float, c00: float, c01: float, c11: float) -> bool:
    """True where a three-reflector fix at ``(px, py)`` (m) is too near its critical circle for its covariance.

    :func:`~agvnav.positioning.triangulation._nonlinear` for one fix that did not keep a heading
    estimate: the largest eigenvalue of the position block ``[[c00, c01], [c01, c11]]`` (m²) against
    ``(NONLINEAR_RATIO * distance)²`` from the circle through ``rx, ry (3,)`` (m), or from
    their line when collinear.
    """
    ax, bx, cx = rx[0], rx[1], rx[2]
    ay, by, cy = ry[0], ry[1], ry[2]
    den = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    a2, b2, c2 = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
    circle = math.nan
    if den != 0.0:  # NumPy's 0/0 or x/0 gives NaN or inf and a circle distance that is not finite
        ux = (a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / den
        uy = (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / den
        circle = abs(math.hypot(px - ux, py - uy) - math.hypot(ax - ux, ay - uy))
    if math.isfinite(circle):
        dist = circle
    else:
        lx, ly = cx - ax, cy - ay
        norm = math.hypot(lx, ly)
        num = abs(lx * (py - ay) - ly * (px - ax))
        dist = num / norm if norm != 0.0 else (math.nan if num == 0.0 or num != num else math.inf)
    half = c00 - c11
    big = 0.5 * (c00 + c11) + math.sqrt(0.25 * (half * half) + c01 * c01)
    reach = NONLINEAR_RATIO * dist
    return bool(math.isfinite(big) and big > reach * reach)


@jit
def crosscheck_fix(
    buf: Any, start: int, newest: Any, pose: Any, odom: Any, mount: Any, rx: Any, ry: Any, radius: Any,
    map_std: Any, noise: Any, bearing_var: float, max_var: float,
) -> tuple[int, float, float, float, float, float, int, int, int, float, float, float, float, float, float]:
    """The cross-check's propagated bearings, best triple and ToTal fix (``crosscheck_distance``).

    Seed 000 §2.2: a triangulation needs the three angles at one configuration of the robot,
    so each bearing, measured at its own pose, is brought to now through the odometry between
    (``z_now = centre + h(now) - h(then)``, ``h`` the leading-edge bearing of seed 000 §2.1 and
    :func:`_edge_bearing`; that section states the condition and gives no equation). Each
    propagated bearing's variance adds the error of that odometry, by the coefficients
    ``K_D, K_Dθ, K_θ`` of [seed002 eq17] (heading ``var_th = k_dtheta s + k_theta |turn|``,
    position ``var_pos = k_d s + var_th s² / 3`` over the ``s`` m travelled, seen at ``d``:
    ``var_th + var_pos / d²``), and the survey's ``(map_std / d)²``. The triple is
    :func:`best_triple`'s (the bearing information of the rows of :func:`_information_sums`),
    the fix :func:`total_fix`'s (ToTal, Pierlot & Van Droogenbroeck 2014: not a seed document)
    with :func:`fix_covariance` and :func:`nonlinear_fix`.

    ``buf``, ``start``: the window (:meth:`~agvnav.positioning.integrity_window._Window.buffer`); ``newest (N,)``
    each map row's newest sighting within a revolution (window position, -1: none; the tally's);
    ``pose``, ``odom`` (3,) the estimate and the odometric pose now (m, m, rad); ``mount`` (3,);
    the map ``rx, ry, radius, map_std (N,)`` (m); ``noise`` (3,) the odometry coefficients
    ``k_d, k_dtheta, k_theta``; ``bearing_var`` the bearing variance (rad², squared by the
    caller), ``max_var`` ``max_fix_std_m²`` (m²).

    Returns ``(code, x, y, c00, c01, c11, i, j, k, z_i, z_j, z_k, s_i, s_j, s_k)``: ``code``
    :data:`CROSSCHECK_NONE` no fix (fewer than three reflectors, no good triple, an invalid fix or
    a covariance that is not finite), :data:`CROSSCHECK_FIX` a fix ``(x, y)`` (m) with its position
    covariance (m²), the triple's map rows, propagated bearings (rad) and stds (rad).
    """
    nan = math.nan
    pos = [0] * 0
    for j in range(len(newest)):
        if newest[j] >= 0:
            pos.append(newest[j])
    pos.sort()
    pos.reverse()  # each reflector's newest sighting, newest first
    m = len(pos)
    if m < 3:
        return CROSSCHECK_NONE, nan, nan, nan, nan, nan, -1, -1, -1, nan, nan, nan, nan, nan, nan
    if m > 8:  # _spread8: numpy.linspace(0, m - 1, 8).round()
        step = (m - 1) / 7
        pos = [pos[round(k * step)] for k in range(7)] + [pos[m - 1]]
        m = 8
    px, py, ppsi = pose[0], pose[1], pose[2]
    ox, oy, opsi = odom[0], odom[1], odom[2]
    co, so = math.cos(opsi), math.sin(opsi)
    cp, sp = math.cos(ppsi), math.sin(ppsi)
    hx, hy, hpsi = _head(px, py, ppsi, mount[0], mount[1], mount[2])
    k_d, k_dtheta, k_theta = noise[0], noise[1], noise[2]
    rows = [0] * m
    cx, cy, z, var = [0.0] * m, [0.0] * m, [0.0] * m, [0.0] * m
    for q in range(m):
        o = start + pos[q] * _WIDTH
        i = int(buf[o + _IDX])
        ex, ey = buf[o + _OX] - ox, buf[o + _OY] - oy  # odometric pose then, seen from now (between)
        rx_, ry_ = co * ex + so * ey, -so * ex + co * ey
        turn = buf[o + _OPSI] - opsi
        tx, ty, tpsi = _head(px + cp * rx_ - sp * ry_, py + sp * rx_ + cp * ry_, ppsi + turn,
                             mount[0], mount[1], mount[2])
        r = radius[i]
        h_then, d_then = _edge_bearing(tx, ty, tpsi, rx[i], ry[i], r)
        h_now = _edge_bearing(hx, hy, hpsi, rx[i], ry[i], r)[0]
        d = max(d_then, 1e-12)
        centre = buf[o + _BEAR] + math.asin(min(max(r / d, 0.0), 1.0))  # edge -> centre
        # the odometry between then and now errs too [seed002 eq17]
        s_odo = math.hypot(ex, ey)
        var_d, var_th = increment_variances(s_odo, wrap_angle_kernel(turn), k_d, k_dtheta, k_theta)
        var_pos = var_d + var_th * s_odo * s_odo / 3.0
        ms = map_std[i] / d
        var[q] = bearing_var + ms * ms + var_th + var_pos / (d * d)
        z[q] = centre + (h_now - h_then)
        rows[q], cx[q], cy[q] = i, rx[i], ry[i]
    best = best_triple(hx, hy, cx, cy, var, bearing_var, max_var)
    if best < 0:
        return CROSSCHECK_NONE, nan, nan, nan, nan, nan, -1, -1, -1, nan, nan, nan, nan, nan, nan
    rank = 0
    a = b = c = -1
    for u in range(m):  # the combination of that rank
        for v in range(u + 1, m):
            for w in range(v + 1, m):
                if rank == best:
                    a, b, c = u, v, w
                rank += 1
    sa, sb, sc = math.sqrt(var[a]), math.sqrt(var[b]), math.sqrt(var[c])
    if not (sa > 0.0 and sb > 0.0 and sc > 0.0 and math.isfinite(sa) and math.isfinite(sb) and math.isfinite(sc)):
        # triangulate raised a ValueError here
        return CROSSCHECK_NONE, nan, nan, nan, nan, nan, -1, -1, -1, nan, nan, nan, nan, nan, nan
    tri_x, tri_y = (cx[a], cx[b], cx[c]), (cy[a], cy[b], cy[c])
    code, fx, fy = total_fix(cx[a], cy[a], cx[b], cy[b], cx[c], cy[c], z[a], z[b], z[c])
    if code == TOTAL_INVALID:
        return CROSSCHECK_NONE, nan, nan, nan, nan, nan, -1, -1, -1, nan, nan, nan, nan, nan, nan
    ok, c00, c01, c02, c11, c12, c22 = fix_covariance(tri_x, tri_y, fx, fy, (sa, sb, sc))
    if not ok or nonlinear_fix(tri_x, tri_y, fx, fy, c00, c01, c11):
        return CROSSCHECK_NONE, nan, nan, nan, nan, nan, -1, -1, -1, nan, nan, nan, nan, nan, nan
    if not (math.isfinite(c00) and math.isfinite(c01) and math.isfinite(c02) and math.isfinite(c11)
            and math.isfinite(c12) and math.isfinite(c22)):
        return CROSSCHECK_NONE, nan, nan, nan, nan, nan, -1, -1, -1, nan, nan, nan, nan, nan, nan
    return CROSSCHECK_FIX, fx, fy, c00, c01, c11, rows[a], rows[b], rows[c], z[a], z[b], z[c], sa, sb, sc



@jit
def mean_innovations(sums: Any, rows: Any, map_std: Any, bearing_var: float) -> tuple[Any, Any, Any, Any]:
    """Per reflector the mean innovation, its Jacobian row and its variance, from summed innovations.

    ``sums (N, 6)``: per map row the summed ``y, S, H0, H1, H2`` (rad, rad², Jacobian row) and
    their count; ``rows (k,)`` the map rows to take (ascending); ``map_std (N,)`` the survey
    std (m), ``bearing_var`` the bearing variance (rad²). Returns ``ybar (k,)``, ``Hbar (k, 3)``
    and, as :meth:`~agvnav.positioning.integrity.IntegrityMonitor.raim` and
    :meth:`~agvnav.positioning.integrity.IntegrityMonitor.offset` model them,
    ``var = survey + max(Sbar - survey, bearing_var) / n`` with ``survey = map_std² |Hbar_xy|²``
    ``(k,)`` (rad²) and ``1 / var`` ``(k,)``: the NumPy expressions they had, element by
    element (``np.maximum`` keeps a NaN).
    """
    k = len(rows)
    ybar, hbar, var, w = np.empty(k), np.empty((k, 3)), np.empty(k), np.empty(k)
    for q in range(k):
        j = rows[q]
        n = sums[j, 5]
        ybar[q] = sums[j, 0] / n
        s_bar = sums[j, 1] / n
        h0, h1, h2 = sums[j, 2] / n, sums[j, 3] / n, sums[j, 4] / n
        hbar[q, 0], hbar[q, 1], hbar[q, 2] = h0, h1, h2
        std = map_std[j]
        survey = std * std * (h0 * h0 + h1 * h1)  # (map_std / d)^2
        white = s_bar - survey
        if not (white >= bearing_var or white != white):
            white = bearing_var
        var[q] = survey + white / n
        w[q] = 1.0 / var[q]
    return ybar, hbar, var, w


@jit
def revolution_innovations(
    buf: Any, start: int, n: int, t: float, revolution_s: float, excluded: Any, att: Any, n_att: int,
) -> Any:
    """Per map row the EKF innovations of the last revolution summed: ``(N, 6)`` ``y, S, H0, H1, H2`` and count.

    The window's sightings with an innovation within ``revolution_s`` (s) before ``t`` (s), in
    window order, then the first ``n_att`` attributed ones ``att (k, 7)`` (``t, map row, y, S,
    H0, H1, H2``) within it, each sum from 0.0 in that order; ``excluded (N,)`` flags the
    map rows left out (non-zero). :meth:`~agvnav.positioning.integrity.IntegrityMonitor.offset`.
    """
    m = excluded.shape[0]
    acc = np.zeros((m, 6))
    for k in range(n):
        o = start + k * _WIDTH
        if buf[o + _HAS_I] != 0.0 and not t - buf[o + _T] > revolution_s:
            j = int(buf[o + _IDX])
            if excluded[j] == 0:
                for c in range(5):
                    acc[j, c] += buf[o + _Y + c]
                acc[j, 5] += 1.0
    for q in range(n_att):
        if not t - att[q][0] > revolution_s:
            j = int(att[q][1])
            if excluded[j] == 0:
                for c in range(5):
                    acc[j, c] += att[q][2 + c]
                acc[j, 5] += 1.0
    return acc


@jit
def _information_sums(hx: float, hy: float, rx: Any, ry: Any, std: Any) -> tuple[
    bool, tuple[float, float, float, float, float, float], tuple[float, float, float, float, float, float], bool
]:
    """Bearing information of reflectors ``rx, ry (n,)`` (m) from the head ``(hx, hy)`` (m), summed in order.

    Each reflector's Jacobian row ``[dy/d², -dx/d², -1]`` (seed 000 §2.3) gives the upper
    triangle ``00 01 02 11 12 22`` of its unit-noise information; weighted by
    ``(d / std)^2`` (``std (n,)`` its survey std, m) the survey-error information. Returns
    ``(ok, unit, survey, every std > 0)``; ``ok`` False when a reflector sits on the head.
    """
    a0 = a1 = a2 = a3 = a4 = a5 = 0.0
    b0 = b1 = b2 = b3 = b4 = b5 = 0.0
    survey = True
    for k in range(len(rx)):
        dx, dy = rx[k] - hx, ry[k] - hy
        d2 = dx * dx + dy * dy
        if d2 <= 0.0:
            return False, (a0, a1, a2, a3, a4, a5), (b0, b1, b2, b3, b4, b5), False
        j0, j1 = dy / d2, -dx / d2
        r0, r1, r2, r3, r4 = j0 * j0, j0 * j1, -j0, j1 * j1, -j1
        a0, a1, a2, a3, a4, a5 = a0 + r0, a1 + r1, a2 + r2, a3 + r3, a4 + r4, a5 + 1.0
        s = std[k]
        if s > 0.0:
            w = d2 / (s * s)
            b0, b1, b2, b3, b4, b5 = b0 + w * r0, b1 + w * r1, b2 + w * r2, b3 + w * r3, b4 + w * r4, b5 + w * 1.0
        else:
            survey = False
    return True, (a0, a1, a2, a3, a4, a5), (b0, b1, b2, b3, b4, b5), survey


@jit
def _inverse3(
    a00: float, a01: float, a02: float, a11: float, a12: float, a22: float,
) -> tuple[bool, float, float, float, float, float, float]:
    """Inverse of the symmetric 3x3 ``[a00 a01 a02 a11 a12 a22]`` (same layout); ``ok`` False if singular.

    Singular: ``|det|`` at most 1e-12 of the cube of the largest diagonal entry.
    """
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    det = a00 * c00 + a01 * c01 + a02 * c02
    big = max(abs(a00), abs(a11), abs(a22))
    scale = big * big * big
    if not (math.isfinite(det) and abs(det) > 1e-12 * scale and det != 0.0):
        return False, math.nan, math.nan, math.nan, math.nan, math.nan, math.nan
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    return True, c00 / det, c01 / det, c02 / det, c11 / det, c12 / det, c22 / det


@jit
def information(
    hx: float, hy: float, hpsi: float, sightings: Any, rx: Any, ry: Any, map_std: Any, mount: Any,
) -> tuple[float, bool, float, float, float, float, float, float]:
    """PDOP² (m²/rad², inf if unobservable) of the sighted reflectors from the head, and the survey floor.

    ``integrity_support.survey_information`` for the map rows with ``sightings (N,)`` non-zero, in
    ascending order: their bearing information (:func:`_information_sums`), inverted
    (:func:`_inverse3`); the survey-error information's inverse, carried from the head
    ``(hx, hy, hpsi)`` (m, m, rad) to base_link through ``base = head - R(psi) mount``.
    Returns ``(pdop2, has_floor, b00, b01, b02, b11, b12, b22)``, the floor's upper triangle
    (m², m·rad, rad²) valid when ``has_floor`` (three reflectors or more, every survey std > 0).
    """
    sx = [rx[j] for j in range(len(sightings)) if sightings[j] != 0.0]
    sy = [ry[j] for j in range(len(sightings)) if sightings[j] != 0.0]
    ss = [map_std[j] for j in range(len(sightings)) if sightings[j] != 0.0]
    nan = math.nan
    ok, a, b, survey = _information_sums(hx, hy, sx, sy, ss)
    if not ok:
        return math.inf, False, nan, nan, nan, nan, nan, nan
    survey = survey and len(sx) >= 3
    ok_u, u00, _, _, u11, _, _ = _inverse3(a[0], a[1], a[2], a[3], a[4], a[5])
    pdop2 = u00 + u11 if ok_u else math.inf
    if not (math.isfinite(pdop2) and pdop2 >= 0.0):
        pdop2 = math.inf
    if not survey:
        return pdop2, False, nan, nan, nan, nan, nan, nan
    ok_c, c00, c01, c02, c11, c12, c22 = _inverse3(b[0], b[1], b[2], b[3], b[4], b[5])
    if not (ok_c and math.isfinite(c00) and math.isfinite(c01) and math.isfinite(c02) and math.isfinite(c11)
            and math.isfinite(c12) and math.isfinite(c22)):
        return pdop2, False, nan, nan, nan, nan, nan, nan
    # head pose -> base_link pose: base = head - R(psi) mount, d base / d psi = (ta, tb)
    psi = hpsi - mount[2]
    c, s = math.cos(psi), math.sin(psi)
    ta, tb = s * mount[0] + c * mount[1], -c * mount[0] + s * mount[1]
    b00 = c00 + 2.0 * ta * c02 + ta * ta * c22
    b01 = c01 + ta * c12 + tb * c02 + ta * tb * c22
    b11 = c11 + 2.0 * tb * c12 + tb * tb * c22
    b02, b12 = c02 + ta * c22, c12 + tb * c22
    return pdop2, True, b00, b01, b02, b11, b12, c22


@jit
def in_range(hx: float, hy: float, rx: Any, ry: Any, max_range: float, excluded: Any) -> int:
    """How many reflectors (not flagged in ``excluded (N,)``) lie within ``max_range`` (m) of ``(hx, hy)`` (m).

    :func:`~agvnav.positioning.integrity_support.explained_fraction`: ``math.hypot(dx, dy) <= max_range``.
    """
    count = 0
    for j in range(len(rx)):
        if excluded[j] != 0:
            continue
        if math.hypot(rx[j] - hx, ry[j] - hy) <= max_range:
            count += 1
    return count


@jit
def _solve_augmented(a: Any, m: int, dx: Any) -> bool:
    """Solve the ``m x (m + 1)`` augmented system ``a`` (row by row, destroyed) into ``dx (m,)``; False if singular.

    Gaussian elimination with partial pivoting; singular is a zero pivot (as ``numpy.linalg.solve`` raises on).
    """
    c = m + 1
    for col in range(m):
        p = col
        for i in range(col + 1, m):
            if abs(a[i * c + col]) > abs(a[p * c + col]):
                p = i
        if a[p * c + col] == 0.0:
            return False
        if p != col:
            for j in range(c):
                a[col * c + j], a[p * c + j] = a[p * c + j], a[col * c + j]
        for i in range(col + 1, m):
            f = a[i * c + col] / a[col * c + col]
            for j in range(col, c):
                a[i * c + j] -= f * a[col * c + j]
    for i in range(m - 1, -1, -1):
        acc = a[i * c + m]
        for j in range(i + 1, m):
            acc -= a[i * c + j] * dx[j]
        dx[i] = acc / a[i * c + i]
    return True


@jit
def _normal_equations(e: Any, h: Any, w: Any, m: int, skip: int, a: Any) -> float:
    """``[H^T W H | H^T W e]`` of the rows but ``skip`` (-1: none) into ``a`` (``m x (m + 1)``); returns ``e^T W e``."""
    c = m + 1
    for q in range(m * c):
        a[q] = 0.0
    ewe = 0.0
    for k in range(len(e)):
        if k == skip:
            continue
        wk = w[k]
        ewe += wk * e[k] * e[k]
        for i in range(m):
            hi = wk * h[k * m + i]
            for j in range(i, m):
                a[i * c + j] += hi * h[k * m + j]
            a[i * c + m] += hi * e[k]
    for i in range(m):
        for j in range(i):
            a[i * c + j] = a[j * c + i]
    return ewe


@jit
def _fde_statistics(r: Any, h: Any, w: Any, m: int) -> Any:
    """Weighted sums of squared residuals of the least-squares fits of ``r = H dx``: all rows, then each left out.

    ``r (n,)`` residuals, ``h (n m,)`` the Jacobian ``H (n, m)`` row by row, ``w (n,)``
    weights. The fit of all rows gives ``dx0`` and the residuals ``e = r - H dx0`` (the
    statistics are those of ``e``: fitting ``e`` instead of ``r`` only shifts ``dx``); over
    ``e`` the normal equations ``A = H^T W H``, ``b = H^T W e`` and ``e^T W e`` are summed
    once, leaving row ``k`` out subtracts its terms (a rank-one downdate), and the fit's
    statistic is ``e^T W e - b^T dx``. O(n m^2) for all ``n + 1`` fits instead of
    O(n^2 m^2) (170 reflectors in the window of a 256-reflector map); working on ``e``
    keeps the subtraction from cancelling a large common pull. NaN where singular (a
    zero pivot). Returns ``(n + 1,)``: index 0 all rows, ``1 + k`` without row ``k``.
    """
    n = len(r)
    c = m + 1
    out = np.full(n + 1, math.nan)
    a = [0.0] * (m * c)
    dx = [0.0] * m
    _normal_equations(r, h, w, m, -1, a)
    if not _solve_augmented(a, m, dx):
        return out
    e = [0.0] * n
    for k in range(n):
        ek = r[k]
        for i in range(m):
            ek -= h[k * m + i] * dx[i]
        e[k] = ek
    full = [0.0] * (m * c)
    ewe = _normal_equations(e, h, w, m, -1, full)
    for skip in range(-1, n):
        total = ewe
        for q in range(m * c):
            a[q] = full[q]
        if skip >= 0:
            ws = w[skip]
            total -= ws * e[skip] * e[skip]
            for i in range(m):
                hi = ws * h[skip * m + i]
                for j in range(i, m):
                    a[i * c + j] -= hi * h[skip * m + j]
                a[i * c + m] -= hi * e[skip]
            for i in range(m):
                for j in range(i):
                    a[i * c + j] = a[j * c + i]
        b = [a[i * c + m] for i in range(m)]  # the right-hand side, before elimination
        if not _solve_augmented(a, m, dx):
            continue
        bdx = 0.0
        for i in range(m):
            bdx += b[i] * dx[i]
        out[skip + 1] = total - bdx
    return out


@jit
def revolution_offset(
    buf: Any, start: int, n: int, t: float, revolution_s: float, excluded: Any, att: Any, n_att: int,
    map_std: Any, bearing_var: float,
) -> tuple[bool, float, float, float, float]:
    """The pose offset the last revolution's innovations share and its chi-square statistic (``offset``).

    The sums of :func:`revolution_innovations`, their means and variances
    (:func:`mean_innovations`, ascending map rows), fitted by weighted least squares as
    ``ybar = Hbar dx`` with the RAIM's normal equations and elimination (:func:`_normal_equations`,
    :func:`_solve_augmented`: the same fit), and ``dx^T A dx`` summed row by row. Returns
    ``(ok, dx0, dx1, dx2, statistic)`` (m, m, rad); not ``ok``: fewer than 4 reflectors, a
    singular fit (a zero pivot) or a statistic that is not finite.
    """
    sums = revolution_innovations(buf, start, n, t, revolution_s, excluded, att, n_att)
    rows = [j for j in range(sums.shape[0]) if sums[j, 5] != 0.0]
    if len(rows) < 4:
        return False, math.nan, math.nan, math.nan, math.nan
    ybar, hbar, _, w = mean_innovations(sums, rows, map_std, bearing_var)
    a = [0.0] * 12
    _normal_equations(ybar, hbar.reshape(-1), w, 3, -1, a)
    full = a.copy()
    dx = [0.0] * 3
    if not _solve_augmented(a, 3, dx):
        return False, math.nan, math.nan, math.nan, math.nan
    stat = 0.0
    for i in range(3):
        for j in range(3):
            stat += dx[i] * full[4 * i + j] * dx[j]
    return math.isfinite(stat), dx[0], dx[1], dx[2], stat


@jit
def window_fde(innovations: Any, map_std: Any, bearing_var: float) -> tuple[Any, Any, bool]:
    """The RAIM's fits over the window (``IntegrityMonitor.raim``): map rows and their statistics.

    ``innovations (N, 6)``: the window's summed innovations per map row (:func:`mean_innovations`
    takes their means and variances). Returns the map rows with sightings (ascending, ``(k,)``),
    :func:`_fde_statistics` of their fit (``(k + 1,)``; empty with fewer than 4 rows) and whether
    every variance is positive and finite (else the statistics are empty and the caller's
    :func:`~agvnav.positioning.integrity.leave_one_out_fde` raises, as before).
    """
    rows = np.array([j for j in range(innovations.shape[0]) if innovations[j, 5] != 0.0], dtype=np.int64)
    k = rows.shape[0]
    if k < 4:
        return rows, np.empty(0), True
    ybar, hbar, var, w = mean_innovations(innovations, rows, map_std, bearing_var)
    for q in range(k):
        if not (var[q] > 0.0 and math.isfinite(var[q])):
            return rows, np.empty(0), False
    return rows, _fde_statistics(ybar, hbar.reshape(-1), w, 3), True


@jit
def nis_per_reflector(buf: Any, start: int, n: int, sightings: Any, first: Any, nis: Any) -> float:
    """Sum over the window's distinct reflectors of the mean NIS of their sightings, in order of first sighting.

    The bearings of one reflector repeat its survey error every revolution (constant in
    time, and nearly so over a window at the same geometry: a standing vehicle sees the
    same error eight times a second), so its sightings are not independent chi-square
    draws: summing them all against ``chi2(len(entries))`` counted one reflector's fixed
    error once per revolution and failed a sound estimate standing at a warehouse station
    (NIS ratio 1.01-1.09 for 5 s, verdict ``lost`` 2 mm from the truth). Each reflector
    contributes one degree of freedom: the mean of its NIS values (its fixed error squared
    over ``S``, plus the averaged white part).

    ``buf``, ``start``, ``n``: the window (:meth:`~agvnav.positioning.integrity_window._Window.buffer`);
    ``sightings``, ``first``, ``nis (N,)`` the tally's counts, first positions and summed NIS
    per map row.
    """
    total = 0.0
    for k in range(n):
        j = int(buf[start + k * _WIDTH + _IDX])
        if first[j] == k:
            total += nis[j] / sightings[j]
    return total
