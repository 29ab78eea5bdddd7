"""agvnav.positioning._integrity_fast: the monitor's compiled check against the forms it replaced (its oracles).

Each kernel is compared, to rounding, with the Python / NumPy form it stands for:
``triangulate(method="total")`` (its single-fix path, covariance and critical-circle flag), and
the cross-check's former plain-Python propagation (kept here, :func:`_reference_crosscheck`, as the
reference). The kernels' two modes agree to rounding (``tests/test_jit.py``), so these run in one.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import pytest

from agvnav.geometry import wrap_angle_scalar
from agvnav.positioning import _integrity_fast as fast
from agvnav.positioning.integrity import _WIDTH, IntegrityMonitor
from agvnav.positioning.triangulation import _nonlinear, triangulate


def _close(got: float, want: float, rel: float = 1e-9) -> bool:
    """``got`` equals ``want`` to ``rel`` (the kernels sum in their own order), NaN where NaN, inf where inf."""
    if math.isnan(want):
        return math.isnan(got)
    return got == want or math.isclose(got, want, rel_tol=rel, abs_tol=1e-300)


def _all_close(got: Any, want: Any, rel: float = 1e-9) -> bool:
    return all(_close(float(a), float(b), rel) for a, b in zip(got, want, strict=True))


def _random_triple(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Three reflectors (m), a head position (m) and its three bearings (rad, noisy) in a 20 m hall."""
    r = rng.uniform(-10.0, 10.0, (3, 2))
    if rng.uniform() < 0.2:  # collinear reflectors on one wall, as many maps have
        r[:, 1] = r[0, 1]
    p = rng.uniform(-10.0, 10.0, 2)
    psi = rng.uniform(-math.pi, math.pi)
    z = np.arctan2(r[:, 1] - p[1], r[:, 0] - p[0]) - psi + rng.normal(0.0, 1e-3, 3)
    return r, np.array([wrap_angle_scalar(v) for v in z.tolist()]), rng.uniform(1e-4, 5e-3, 3)


def test_total_fix_covariance_and_flag_are_triangulates() -> None:
    """ToTal's single fix, its covariance and its critical-circle flag: triangulate's, to rounding.

    The kernel decides every case itself (no rare path to triangulate): where triangulate raises
    (coincident reflectors) or flags the fix invalid, the kernel gives no valid fix; a decision on a
    value within rounding of its threshold may go the other way (at most a few in 3,000).
    """
    rng = np.random.default_rng(5)
    valid = disagree = 0
    for _ in range(3_000):
        r, z, std = _random_triple(rng)
        (x1, y1), (x2, y2), (x3, y3) = r.tolist()
        code, px, py = fast.total_fix(x1, y1, x2, y2, x3, y3, *z.tolist())
        try:
            fix = triangulate(r, z, method="total", bearing_std=std)
        except ValueError:
            assert code == fast.TOTAL_INVALID
            continue
        rx, ry = tuple(r[:, 0].tolist()), tuple(r[:, 1].tolist())
        if code == fast.TOTAL_INVALID:
            disagree += bool(fix.valid) and math.isfinite(px)
            continue
        valid += 1
        ok, c00, c01, c02, c11, c12, c22 = fast.fix_covariance(rx, ry, px, py, tuple(std.tolist()))
        flagged = ok and fast.nonlinear_fix(rx, ry, px, py, c00, c01, c11)
        if bool(fix.valid) != (not flagged):
            disagree += 1
            continue
        assert fix.covariance is not None
        if not flagged:
            assert _all_close((px, py), (fix.x, fix.y))
        want = fix.covariance[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]].tolist()
        if ok:
            assert _all_close((c00, c01, c02, c11, c12, c22), want, 1e-6)
        else:
            assert all(math.isnan(v) for v in want)
    assert valid > 2_000 and disagree <= 3


def test_nonlinear_fix_is_triangulations_flag_on_near_critical_fixes() -> None:
    """Fixes near their critical circle (where the flag turns): the kernel's flag is ``_nonlinear``'s."""
    rng = np.random.default_rng(9)
    flips = 0
    for _ in range(2_000):
        r = rng.uniform(-5.0, 5.0, (3, 2))
        px, py = rng.uniform(-5.0, 5.0, 2).tolist()
        c = rng.uniform(1e-6, 1e-1) * np.array([rng.uniform(0.1, 1.0), rng.uniform(-0.05, 0.05), rng.uniform(0.1, 1)])
        cov = np.array([[[c[0], c[1], 0.0], [c[1], c[2], 0.0], [0.0, 0.0, 1.0]]])
        want = bool(_nonlinear(r, np.array([px]), np.array([py]), cov, np.array([False]))[0])
        got = fast.nonlinear_fix(tuple(r[:, 0].tolist()), tuple(r[:, 1].tolist()), px, py, *c.tolist())
        assert got == want
        flips += want
    assert 100 < flips < 1_900  # both outcomes exercised


def _monitor(rng: np.random.Generator, n: int) -> IntegrityMonitor:
    xy = rng.uniform(0.0, 20.0, (n, 2))
    radius = rng.uniform(0.02, 0.05, n)
    map_std = np.where(rng.uniform(size=n) < 0.2, 0.0, rng.uniform(1e-3, 1e-2, n))
    return IntegrityMonitor(xy, radius, (0.3, 0.05, 0.01), 1e-3, 0.125, map_std=map_std,
                            odometry_noise=(1e-4, 2e-4, 1e-3))


def _window(rng: np.random.Generator, mon: IntegrityMonitor, t: float) -> None:
    """Accepted reflections over the last second: stamps, map rows, bearings and odometric poses."""
    n_rows = int(rng.integers(0, 80))
    ts = np.sort(rng.uniform(t - 0.9, t, n_rows))
    for tk in ts.tolist():
        j = int(rng.integers(0, mon.xy.shape[0]))
        odom = (float(rng.uniform(8, 12)), float(rng.uniform(8, 12)), float(rng.uniform(-3, 3)))
        mon.accepted(tk, float(rng.uniform(0, 3)), j, float(rng.uniform(-math.pi, math.pi)), odom)


# The former plain-Python forms the kernels replaced, copied verbatim from the monitor before the
# compiled check (c5c8164:src/agvnav/positioning/integrity.py; plain, uncompiled): the references
# below do not call the kernels under test.


def _head(x: Any, mount: np.ndarray) -> tuple[float, float, float]:
    """Head pose in ``map`` from the base_link pose ``x`` (array or floats) and the ``mount`` (floats)."""
    c, s = math.cos(float(x[2])), math.sin(float(x[2]))
    mx, my = float(mount[0]), float(mount[1])
    return float(x[0]) + c * mx - s * my, float(x[1]) + s * mx + c * my, float(x[2]) + float(mount[2])


def _spread8(n: int) -> list[int]:
    """Eight positions spread evenly over ``range(n)`` (n > 8), first and last included.

    ``numpy.linspace(0, n - 1, 8).round()`` in floats: ``k (n - 1) / 7`` rounded half to even.
    """
    step = (n - 1) / 7
    return [round(k * step) for k in range(7)] + [n - 1]


def _position_crlb_one(a00: float, a01: float, a02: float, a11: float, a12: float, a22: float) -> float:
    """Trace of the position block of the inverse of the symmetric 3x3 ``a`` (upper triangle; inf if singular)."""
    c00 = a11 * a22 - a12 * a12
    c11 = a00 * a22 - a02 * a02
    det = a00 * c00 + a01 * (a02 * a12 - a01 * a22) + a02 * (a01 * a12 - a02 * a11)
    if det == 0.0:
        return math.inf
    score = (c00 + c11) / det
    return score if score >= 0.0 and score < math.inf else math.inf


def _best_triple_kernel(
    hx: float, hy: float, rx: list[float], ry: list[float], var: list[float], bearing_var: float, max_var: float,
) -> int:
    """Rank (in ``itertools.combinations`` order) of the triple of reflectors with the smallest position CRLB."""
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
                bound = _position_crlb_one(
                    info[pa] + info[pb] + info[pc], info[pa + 1] + info[pb + 1] + info[pc + 1],
                    info[pa + 2] + info[pb + 2] + info[pc + 2], info[pa + 3] + info[pb + 3] + info[pc + 3],
                    info[pa + 4] + info[pb + 4] + info[pc + 4], info[pa + 5] + info[pb + 5] + info[pc + 5])
                if bound * bearing_var <= max_var:
                    wa, wb, wc = var[a], var[b], var[c]
                    score = _position_crlb_one(
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


#: ``n -> (C(n, 3), 3)`` index triples of ``range(n)`` in :func:`_best_triple_kernel`'s rank order.
_TRIPLE_CODES = {n: tuple(itertools.combinations(range(n), 3)) for n in range(3, 9)}


def _best_triple(mon: IntegrityMonitor, x: np.ndarray, rows: list[int], variances: list[float]) -> list[int] | None:
    """The former ``IntegrityMonitor._best_triple`` (its ``self`` the monitor)."""
    if len(rows) < 3:
        return None
    if len(rows) > 8:  # a dense map: eight spread over the revolution, not the eight newest in one sector
        pick = _spread8(len(rows))
        rows, variances = [rows[k] for k in pick], [variances[k] for k in pick]
    hx, hy, _ = _head(x, mon.mount)
    rx, ry = [float(mon.xy[j, 0]) for j in rows], [float(mon.xy[j, 1]) for j in rows]
    var = [float(v) for v in variances]
    best = _best_triple_kernel(hx, hy, rx, ry, var, mon.bearing_std**2, mon.limits.max_fix_std_m**2)
    if best < 0:
        return None
    i, j, k = _TRIPLE_CODES[len(rows)][best]
    return [rows[i], rows[j], rows[k]]


def _information_sums(hx: float, hy: float, rx: list[float], ry: list[float], std: list[float]) -> tuple[
    bool, tuple[float, float, float, float, float, float], tuple[float, float, float, float, float, float], bool
]:
    """Bearing information of reflectors ``rx, ry (n,)`` (m) from the head ``(hx, hy)`` (m), summed in order."""
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


def _reference_crosscheck(mon: IntegrityMonitor, x: np.ndarray, odom: tuple[float, ...], newest: np.ndarray) -> tuple:
    """The cross-check's former plain-Python form (propagation, best triple, triangulate): ``(x, y, c00, c01, c11)``."""
    seen = np.flatnonzero(newest >= 0)
    pos = np.sort(newest[seen])[::-1].tolist()
    if len(pos) < 3:
        return None
    if len(pos) > 8:
        pos = [pos[k] for k in _spread8(len(pos))]
    px, py, ppsi = float(x[0]), float(x[1]), float(x[2])
    ox, oy, opsi = float(odom[0]), float(odom[1]), float(odom[2])
    co, so, cp, sp = math.cos(opsi), math.sin(opsi), math.cos(ppsi), math.sin(ppsi)
    head_now = _head(x, mon.mount)
    k_d, k_dtheta, k_theta = mon.odometry_noise

    def edge(pose: tuple[float, float, float], i: int) -> tuple[float, float]:
        hx, hy, hpsi = pose
        rx, ry = float(mon.xy[i, 0]), float(mon.xy[i, 1])
        d = math.hypot(rx - hx, ry - hy)
        r = float(mon.radius[i])
        e = -math.asin(min(max(r / d, 0.0), 1.0)) if d > 0.0 else -0.5 * math.pi
        return wrap_angle_scalar(math.atan2(ry - hy, rx - hx) - hpsi + e), d

    prop: dict[int, tuple[float, float]] = {}
    for k in pos:
        e = mon._entries.row(k)
        i = int(e[2])
        ex, ey = e[4] - ox, e[5] - oy
        rx_, ry_ = co * ex + so * ey, -so * ex + co * ey
        turn = e[6] - opsi
        h_then, d_then = edge(_head((px + cp * rx_ - sp * ry_, py + sp * rx_ + cp * ry_, ppsi + turn), mon.mount), i)
        h_now, _ = edge(head_now, i)
        r = float(mon.radius[i])
        d = max(d_then, 1e-12)
        centre = e[3] + math.asin(min(max(r / d, 0.0), 1.0))
        s_odo = math.hypot(ex, ey)
        var_th = k_dtheta * s_odo + k_theta * abs(wrap_angle_scalar(turn))
        var_pos = k_d * s_odo + var_th * s_odo * s_odo / 3.0
        var = mon.bearing_std**2 + (float(mon.map_std[i]) / d) ** 2 + var_th + var_pos / (d * d)
        prop[i] = (centre + (h_now - h_then), var)
    idx = _best_triple(mon, x, list(prop), [prop[i][1] for i in prop])
    if idx is None:
        return None
    try:
        fix = triangulate(mon.xy[idx], np.array([prop[i][0] for i in idx]), method="total",
                          bearing_std=np.sqrt([prop[i][1] for i in idx]))
    except ValueError:
        return None
    if not bool(fix.valid) or fix.covariance is None or not np.all(np.isfinite(fix.covariance)):
        return None
    c = fix.covariance
    return float(fix.x), float(fix.y), float(c[0, 0]), float(c[0, 1]), float(c[1, 1])


def test_crosscheck_fix_is_the_former_propagation_and_fix() -> None:
    """Random windows (0-80 sightings of 5-40 reflectors): the kernel's fix is the plain form's, bit for bit."""
    rng = np.random.default_rng(17)
    fixes = 0
    for _ in range(300):
        mon = _monitor(rng, int(rng.integers(5, 40)))
        t = 10.0
        _window(rng, mon, t)
        tally = mon._tally(t)
        x = np.array([rng.uniform(8, 12), rng.uniform(8, 12), rng.uniform(-3, 3)])
        odom = (float(rng.uniform(8, 12)), float(rng.uniform(8, 12)), float(rng.uniform(-3, 3)))
        buf, start = mon._entries.buffer()
        rx, ry, radius, map_std = mon._tables
        out = fast.crosscheck_fix(buf, start, tally.newest, tuple(x.tolist()), odom, mon._mount_t, rx, ry, radius,
                                  map_std, mon.odometry_noise, mon.bearing_std**2, mon.limits.max_fix_std_m**2)
        want = _reference_crosscheck(mon, x, odom, tally.newest)
        if want is None:
            assert out[0] == 0
            continue
        assert out[0] == 1
        assert _all_close(out[1:6], want, 1e-6)
        fixes += 1
    assert fixes > 100


def test_the_monitor_writes_its_window_rows_in_the_kernels_layout() -> None:
    """``accepted`` stores each value in its named field, the column the kernels read it from."""
    from agvnav.positioning import integrity_window as iw

    mon = IntegrityMonitor(np.array([[1.0, 2.0], [3.0, 4.0]]), np.full(2, 0.04), (0.3, 0.05, 0.01), 1e-3, 0.125)
    mon.accepted(7.0, 2.5, 1, 0.4, (5.0, 6.0, 0.7), (0.01, 0.02, 1e-4, 2e-5, 3e-4), (0.003, 4e-6, 0.1, -0.2, -1.0))
    rec = mon._entries.records()[0]
    assert len(rec) == iw._WIDTH == _WIDTH
    assert (rec["t"], rec["nis"], rec["reflector"], rec["bearing"]) == (7.0, 2.5, 1.0, 0.4)
    assert (rec["odom_x"], rec["odom_y"], rec["odom_psi"], rec["on_time"]) == (5.0, 6.0, 0.7, 1.0)
    assert rec["has_correction"] == 1.0 and [rec[f] for f in ("dx", "dy", "dP00", "dP01", "dP11")] == [
        0.01, 0.02, 1e-4, 2e-5, 3e-4]
    assert rec["has_innovation"] == 1.0 and rec["y"] == 0.003 and rec["S"] == 4e-6
    assert [rec["H0"], rec["H1"], rec["H2"]] == [0.1, -0.2, -1.0]
    row = mon._entries.row(0)  # the kernels' offsets name the same columns
    assert (row[iw._T], row[iw._IDX], row[iw._OX], row[iw._C0], row[iw._Y], row[iw._H0]) == (
        7.0, 1.0, 5.0, 0.01, 0.003, 0.1)


def _reference_inverse3(a: list[float]) -> tuple[float, ...] | None:
    """The monitor's former plain-Python inverse of a symmetric 3x3 (upper triangle), None if singular."""
    a00, a01, a02, a11, a12, a22 = a
    c00, c01, c02 = a11 * a22 - a12 * a12, a02 * a12 - a01 * a22, a01 * a12 - a02 * a11
    det = a00 * c00 + a01 * c01 + a02 * c02
    scale = max(abs(a00), abs(a11), abs(a22)) ** 3
    if not (math.isfinite(det) and abs(det) > 1e-12 * scale and det != 0.0):
        return None
    c11, c12, c22 = a00 * a22 - a02 * a02, a01 * a02 - a00 * a12, a00 * a11 - a01 * a01
    return c00 / det, c01 / det, c02 / det, c11 / det, c12 / det, c22 / det


def test_information_is_the_former_pdop_and_survey_floor() -> None:
    """PDOP² and the survey floor of the sighted reflectors: the former form's, to rounding."""
    rng = np.random.default_rng(29)
    floors = 0
    for _ in range(1_500):
        mon = _monitor(rng, int(rng.integers(3, 30)))
        sightings = (rng.uniform(size=mon.xy.shape[0]) < 0.5).astype(np.float64)
        x = np.array([rng.uniform(0, 20), rng.uniform(0, 20), rng.uniform(-3, 3)])
        head = _head(x, mon.mount)
        unit, floor = mon._information(head, sightings)
        used = np.flatnonzero(sightings)
        ok, a, b, survey = _information_sums(head[0], head[1], mon.xy[used, 0].tolist(), mon.xy[used, 1].tolist(),
                                             mon.map_std[used].tolist())
        if not ok:
            assert unit == math.inf and not floor.any()
            continue
        inv = _reference_inverse3(list(a))
        want = math.inf if inv is None else inv[0] + inv[3]
        assert _close(unit, want if math.isfinite(want) and want >= 0.0 else math.inf)
        cov = _reference_inverse3(list(b)) if survey and len(used) >= 3 else None
        if cov is None or not all(math.isfinite(v) for v in cov):
            assert not floor.any()
            continue
        c00, c01, c02, c11, c12, c22 = cov
        psi = head[2] - float(mon.mount[2])
        c, s = math.cos(psi), math.sin(psi)
        ta, tb = s * mon.mount[0] + c * mon.mount[1], -c * mon.mount[0] + s * mon.mount[1]
        want_floor = [c00 + 2.0 * ta * c02 + ta * ta * c22, c01 + ta * c12 + tb * c02 + ta * tb * c22,
                      c02 + ta * c22, c11 + 2.0 * tb * c12 + tb * tb * c22, c12 + tb * c22, c22]
        got = floor[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]].tolist()
        assert _all_close(got, want_floor, 1e-6)
        floors += 1
    assert floors > 150


def test_in_range_is_hypot_against_the_range_at_the_boundary_too() -> None:
    """Reflectors spread about the range boundary (within 1e-9 relative and on it): ``math.hypot``'s count."""
    rng = np.random.default_rng(31)
    for _ in range(300):
        n = int(rng.integers(1, 60))
        hx, hy = rng.uniform(-5, 5, 2).tolist()
        max_range = float(rng.uniform(1.0, 10.0))
        ang = rng.uniform(-math.pi, math.pi, n)
        d = max_range * (1.0 + rng.choice([-1e-3, -1e-10, 0.0, 1e-16, 1e-10, 1e-3], n))
        xy = np.column_stack([hx + d * np.cos(ang), hy + d * np.sin(ang)])
        excluded = (rng.uniform(size=n) < 0.1).astype(np.int64)
        rx, ry = xy[:, 0].copy(), xy[:, 1].copy()
        args = (rx, ry)
        got = fast.in_range(hx, hy, *args, max_range, excluded)
        dist = [math.hypot(rx[j] - hx, ry[j] - hy) for j in range(n) if not excluded[j]]
        # a reflector within rounding of the range may count either way (libm's hypot or CPython's)
        inside = sum(v <= max_range * (1.0 - 1e-14) for v in dist)
        assert inside <= got <= sum(v <= max_range * (1.0 + 1e-14) for v in dist)


def test_revolution_and_mean_innovations_are_the_former_numpy_sums() -> None:
    """The common offset's and the RAIM's per-reflector means: the former dict sums and NumPy expressions."""
    rng = np.random.default_rng(37)
    for _ in range(200):
        n_map, n_rows = int(rng.integers(4, 40)), int(rng.integers(0, 120))
        rows = rng.normal(size=(n_rows, _WIDTH)) * 1e-2
        rows[:, 0] = np.sort(rng.uniform(9.0, 10.0, n_rows))
        rows[:, 2] = rng.integers(0, n_map, n_rows)
        rows[:, 14] = rng.integers(0, 2, n_rows)
        rows[:, 16] = rng.uniform(1e-6, 1e-4, n_rows)
        att = [(float(rng.uniform(9.5, 10.0)), int(rng.integers(0, n_map)), *rng.normal(size=5).tolist())
               for _ in range(int(rng.integers(0, 4)))]
        excluded = (rng.uniform(size=n_map) < 0.1).astype(np.int64)
        map_std = np.where(rng.uniform(size=n_map) < 0.3, 0.0, rng.uniform(1e-3, 1e-2, n_map))
        buf = rows.reshape(-1)
        att_arg = np.array(att, dtype=np.float64).reshape(-1, 7)
        sums = fast.revolution_innovations(buf, 0, n_rows, 10.0, 0.125, excluded, att_arg, len(att))
        ref: dict[int, list[float]] = {}
        for r in rows[(rows[:, 14] != 0.0) & ~(10.0 - rows[:, 0] > 0.125)].tolist():
            if not excluded[int(r[2])]:
                acc = ref.setdefault(int(r[2]), [0.0] * 6)
                for c in range(5):
                    acc[c] += r[15 + c]
                acc[5] += 1.0
        for ta, j, *v in att:
            if not 10.0 - ta > 0.125 and not excluded[j]:
                acc = ref.setdefault(j, [0.0] * 6)
                for c in range(5):
                    acc[c] += v[c]
                acc[5] += 1.0
        found = np.flatnonzero(sums[:, 5])
        assert found.tolist() == sorted(ref)
        if not len(found):
            continue
        m = np.array([ref[j] for j in found.tolist()])
        assert sums[found].tobytes() == m.tobytes()
        ybar, hbar, var, w = fast.mean_innovations(sums, found, map_std, 1e-6)
        n = m[:, 5]
        h = m[:, 2:5] / n[:, None]
        survey = map_std[found] ** 2 * (h[:, 0] * h[:, 0] + h[:, 1] * h[:, 1])
        want_var = survey + np.maximum(m[:, 1] / n - survey, 1e-6) / n
        assert ybar.tobytes() == (m[:, 0] / n).tobytes() and hbar.tobytes() == h.tobytes()
        assert var.tobytes() == want_var.tobytes() and w.tobytes() == (1.0 / want_var).tobytes()


def _random_window_rows(rng: np.random.Generator, n_map: int, n_rows: int) -> np.ndarray:
    """Window rows with innovations: stamps in the last second, map rows, y, S and a bearing Jacobian row."""
    rows = np.zeros((n_rows, _WIDTH))
    rows[:, 0] = np.sort(rng.uniform(9.0, 10.0, n_rows))
    rows[:, 2] = rng.integers(0, n_map, n_rows)
    rows[:, 14] = rng.uniform(size=n_rows) < 0.9
    d = rng.uniform(2.0, 15.0, n_rows)
    ang = rng.uniform(-math.pi, math.pi, n_rows)
    rows[:, 17], rows[:, 18], rows[:, 19] = np.sin(ang) / d, -np.cos(ang) / d, -1.0
    rows[:, 16] = rng.uniform(1e-6, 1e-4, n_rows)
    rows[:, 15] = rng.normal(0.0, 1.0, n_rows) * np.sqrt(rows[:, 16]) + rows[:, 17:20] @ rng.normal(0, 1e-2, 3)
    return rows


def test_revolution_offset_is_the_weighted_least_squares_fit() -> None:
    """The common offset: NumPy's solve of the same normal equations to 1e-12 (it sums in BLAS's order, with FMA)."""
    rng = np.random.default_rng(41)
    fits = 0
    for _ in range(300):
        n_map = int(rng.integers(4, 30))
        rows = _random_window_rows(rng, n_map, int(rng.integers(0, 60)))
        excluded = (rng.uniform(size=n_map) < 0.1).astype(np.int64)
        map_std = rng.uniform(0.0, 5e-3, n_map)
        buf = rows.reshape(-1)
        att = np.zeros((0, 7))
        ok, *dx, stat = fast.revolution_offset(buf, 0, rows.shape[0], 10.0, 0.5, excluded, att, 0, map_std, 1e-6)
        sums = fast.revolution_innovations(buf, 0, rows.shape[0], 10.0, 0.5, excluded, att, 0)
        found = np.flatnonzero(sums[:, 5])
        if len(found) < 4:
            assert not ok
            continue
        ybar, h, _, w = fast.mean_innovations(sums, found, map_std, 1e-6)
        A = h.T @ (w[:, None] * h)
        want = np.linalg.solve(A, h.T @ (w * ybar))
        np.testing.assert_allclose(dx, want, rtol=1e-9, atol=1e-12)
        assert stat == pytest.approx(float(want @ A @ want), rel=1e-12)
        fits += 1
    assert fits > 150


def test_window_fde_is_leave_one_out_fde() -> None:
    """The RAIM's statistics from the window's sums: leave_one_out_fde's on the same means, bit for bit."""
    from agvnav.positioning.integrity import leave_one_out_fde

    rng = np.random.default_rng(47)
    for _ in range(200):
        n_map = int(rng.integers(4, 30))
        rows = _random_window_rows(rng, n_map, int(rng.integers(0, 80)))
        map_std = rng.uniform(0.0, 5e-3, n_map)
        sums = fast.revolution_innovations(rows.reshape(-1), 0, rows.shape[0], 10.0, 1.0,
                                           np.zeros(n_map, dtype=np.int64), np.zeros((0, 7)), 0)
        found, stats, positive = fast.window_fde(sums, map_std, 1e-6)
        assert positive and found.tolist() == np.flatnonzero(sums[:, 5]).tolist()
        if len(found) < 4:
            continue
        # the former IntegrityMonitor.raim's NumPy means (c5c8164), then leave_one_out_fde as it called it
        sel = sums[found]
        n = sel[:, 5]  # sightings per reflector
        r, s_bar, H = sel[:, 0] / n, sel[:, 1] / n, sel[:, 2:5] / n[:, None]
        survey = map_std[found] ** 2 * (H[:, 0] * H[:, 0] + H[:, 1] * H[:, 1])  # (map_std / d)^2
        white = np.maximum(s_bar - survey, 1e-6)
        var = survey + white / n
        ref = leave_one_out_fde(r, H, var, 1e-5)
        assert _close(stats[0], ref.statistic)
        assert _all_close(stats[1:].tolist(), ref.without) or ref.dof < 2
        # and independently of the fits' kernel: NumPy's least squares, all rows and each left out
        for k, keep in enumerate([np.ones(len(found), bool)] + [np.arange(len(found)) != q for q in range(len(found))]):
            if keep.sum() < 4:
                continue
            sw = 1.0 / np.sqrt(var[keep])
            dx = np.linalg.lstsq(H[keep] * sw[:, None], r[keep] * sw, rcond=None)[0]
            want = float(np.sum((r[keep] - H[keep] @ dx) ** 2 / var[keep]))
            assert stats[k] == pytest.approx(want, rel=1e-8, abs=1e-12)


def test_nis_per_reflector_is_the_former_sum_in_order_of_first_sighting() -> None:
    rng = np.random.default_rng(53)
    for _ in range(200):
        mon = _monitor(rng, int(rng.integers(3, 30)))
        _window(rng, mon, 10.0)
        tally = mon._tally(10.0)
        buf, start = mon._entries.buffer()
        got = fast.nis_per_reflector(buf, start, len(mon._entries), tally.sightings, tally.first, tally.nis)
        seen = np.flatnonzero(tally.sightings)
        means = tally.nis[seen] / tally.sightings[seen]
        want = 0.0  # an explicit loop: sum() compensates on Python 3.12+ (the kernel's module docstring)
        for v in means[np.argsort(tally.first[seen])].tolist():
            want += v
        assert _close(got, want, 1e-12)
