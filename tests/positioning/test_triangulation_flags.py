"""Batch triangulation's validity flags and its compiled ToTal (issue 29: the batch speed regression).

The flags of a batch (coincident reflectors, P on the line of collinear ones, NaN/inf bearings)
are now computed by ``triangulation._layout_ok`` (compiled in one pass, or NumPy on the collinear
fixes only); the former formulation, copied here verbatim, is the oracle: the same flags on the
same inputs, in both kernel modes, on random and degenerate layouts. ToTal's batch runs compiled
(``total.total_batch``): the NumPy kernel's numbers, bit for bit.
"""

from __future__ import annotations

import math
import tracemalloc

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agvnav import _jit
from agvnav.geometry import bearing_to
from agvnav.geometry.angles import PI, TWO_PI, wrap_angle_scalar
from agvnav.positioning import triangulate
from agvnav.positioning import triangulation as tri
from agvnav.positioning._three import ScalarMath
from agvnav.positioning.total import _div, _wrap, total_batch, total_kernel

pytestmark = pytest.mark.usefixtures("restore_jit_mode")
fixture_ok = settings(suppress_health_check=[HealthCheck.function_scoped_fixture])

LAYOUT_TOL = 1e-9
PARALLEL_TOL = 1e-9


# --- the oracle: the flags as triangulation computed them before issue 29, verbatim ---------------------------
def _old_layout_flags(r):
    d = r[..., :, None, :] - r[..., None, :, :]
    dist2 = np.sum(d * d, axis=-1)
    n = r.shape[-2]
    scale = np.max(dist2, axis=(-2, -1))
    off = np.where(np.eye(n, dtype=bool), np.inf, dist2)
    coincident = np.min(off, axis=(-2, -1)) <= LAYOUT_TOL**2 * scale
    c = r - np.mean(r, axis=-2, keepdims=True)
    sxx, syy, sxy = np.sum(c[..., 0] ** 2, -1), np.sum(c[..., 1] ** 2, -1), np.sum(c[..., 0] * c[..., 1], -1)
    collinear = (n >= 3) & (sxx * syy - sxy * sxy <= LAYOUT_TOL * (sxx + syy) ** 2)
    return coincident, collinear


def _old_parallel_rays(b):
    with np.errstate(invalid="ignore"):
        d = np.sin(b[..., :, None] - b[..., None, :])
        return np.asarray(np.max(np.abs(d), axis=(-2, -1)) <= PARALLEL_TOL)


def _old_layout_ok(r, b):
    with np.errstate(all="ignore"):
        coincident, collinear = _old_layout_flags(r)
        return ~(coincident | (collinear & _old_parallel_rays(b))) & np.all(np.isfinite(b), axis=-1)


def _both_modes(r, b):
    """``_layout_ok`` interpreted (NumPy) and compiled (kernel)."""
    out = []
    for on in (False, True):
        _jit.set_compiled(on)
        with np.errstate(all="ignore"):
            out.append(tri._layout_ok(r, b))
    return out


# --- layouts and bearings, random and degenerate ------------------------------------------------------------
coord = st.floats(-50.0, 50.0, allow_nan=False, width=64)
scale_exp = st.integers(-6, 6)


@st.composite
def layouts(draw, n):
    """A layout ``(n, 2)`` (m): random, collinear, nearly collinear, with coincident or nearly coincident reflectors."""
    kind = draw(st.sampled_from(["random", "collinear", "near_collinear", "coincident", "near_coincident", "scaled"]))
    pts = np.array([[draw(coord), draw(coord)] for _ in range(n)])
    if kind in ("collinear", "near_collinear"):
        a = np.array([draw(coord), draw(coord)])
        ang = draw(st.floats(-math.pi, math.pi))
        t = np.array([draw(st.floats(-30.0, 30.0)) for _ in range(n)])
        pts = a + t[:, None] * np.array([math.cos(ang), math.sin(ang)])
        if kind == "near_collinear":  # around the tolerance: sqrt(LAYOUT_TOL) ~ 3e-5 relative
            off = draw(st.floats(1e-7, 1e-3)) * (1.0 + np.ptp(t))
            pts[n // 2] += off * np.array([-math.sin(ang), math.cos(ang)])
    elif kind in ("coincident", "near_coincident"):
        i, j = draw(st.integers(0, n - 1)), draw(st.integers(0, n - 1))
        pts[j] = pts[i]
        if kind == "near_coincident" and i != j:
            pts[j] += draw(st.floats(1e-12, 1e-6)) * (1.0 + np.ptp(pts))
    elif kind == "scaled":
        pts = pts * 10.0 ** draw(scale_exp)
    return pts


@st.composite
def bearings_for(draw, r):
    """Bearings ``(n,)`` (rad) of the layout from a vehicle: random, on the line of the reflectors (parallel rays),
    on the circle through three of them (concyclic), at a reflector, exactly equal, or with NaN/inf."""
    n = r.shape[0]
    kinds = ["random_pose", "on_line", "concyclic", "at_reflector", "equal", "noise", "bad"]
    kind = draw(st.sampled_from(kinds if n >= 2 else [k for k in kinds if k not in ("on_line", "concyclic")]))
    psi = draw(st.floats(-math.pi, math.pi))
    if kind == "random_pose":
        p = np.array([draw(coord), draw(coord)])
    elif kind == "on_line":  # on the line through reflectors 0 and 1 (all of them when collinear)
        p = r[0] + draw(st.floats(-3.0, 3.0)) * (r[1] - r[0])
    elif kind == "concyclic":  # on the circle through reflectors 0, 1, 2 (the critical circle)
        (ax, ay), (bx, by), (cx, cy) = r[0], r[1], r[2 % n]
        den = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
        a2, b2, c2 = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
        if den == 0.0:
            p = r[0] + 0.5 * (r[1] - r[0])
        else:
            u = np.array([(a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / den,
                          (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / den])
            phi = draw(st.floats(-math.pi, math.pi))
            p = u + np.hypot(*(r[0] - u)) * np.array([math.cos(phi), math.sin(phi)])
    elif kind == "at_reflector":
        p = r[draw(st.integers(0, n - 1))].copy()
    else:
        p = np.array([draw(coord), draw(coord)])
    with np.errstate(all="ignore"):
        b = bearing_to(np.array([p[0], p[1], psi]), r)
    if kind == "equal":
        b[:] = b[0]
    elif kind == "noise":
        b = b + np.array([draw(st.floats(-1e-8, 1e-8)) for _ in range(n)])
    elif kind == "bad":
        b[draw(st.integers(0, n - 1))] = draw(st.sampled_from([math.nan, math.inf, -math.inf]))
    return b


@st.composite
def batches(draw):
    """``(r, b)``: a shared layout ``(n, 2)`` or per-fix layouts ``(m, n, 2)``, and bearings ``(m, n)``, n in 2..9."""
    n = draw(st.integers(2, 9))
    m = draw(st.integers(1, 6))
    if draw(st.booleans()):
        r = draw(layouts(n))
        b = np.stack([draw(bearings_for(r)) for _ in range(m)])
    else:
        r = np.stack([draw(layouts(n)) for _ in range(m)])
        b = np.stack([draw(bearings_for(r[k])) for k in range(m)])
    return r, b


@fixture_ok
@given(batches())
def test_layout_flags_are_the_former_flags_in_both_modes(rb):
    r, b = rb
    want = _old_layout_ok(r, b)
    for got in _both_modes(r, b):
        np.testing.assert_array_equal(got, want)


def test_layout_flags_on_named_degenerate_layouts():
    """Each degenerate case flags what it should, the oracle agrees, and so do both modes (shared and per fix)."""
    wall = np.array([[0.0, 0.0], [3.0, 0.0], [7.0, 0.0]])
    tri3 = np.array([[0.0, 10.0], [-8.66, -5.0], [8.66, -5.0]])
    twin = np.array([[0.0, 0.0], [0.0, 0.0], [5.0, 1.0]])
    on_wall = bearing_to(np.array([-2.0, 0.0, 0.3]), wall)  # P on the wall's line: parallel rays
    off_wall = bearing_to(np.array([2.0, 3.0, 0.3]), wall)
    on_circle = bearing_to(np.array([10.0, 0.0, 0.1]), tri3)  # concyclic: geometry for the kernel, not a flag
    cases = [
        (wall, on_wall, False), (wall, off_wall, True), (tri3, on_circle, True),
        (twin, bearing_to(np.array([1.0, 2.0, 0.0]), twin), False),
        (tri3, np.array([0.1, math.nan, 0.2]), False), (tri3, np.array([0.1, 0.2, math.inf]), False),
    ]
    for r, b, expected in cases:
        assert bool(_old_layout_ok(r, b[None])[0]) is expected
        for shaped in (r, r[None]):
            for got in _both_modes(shaped, b[None]):
                assert bool(got[0]) is expected
    r = np.stack([c[0] for c in cases])  # per-fix layouts mixed in one batch
    b = np.stack([c[1] for c in cases])
    for got in _both_modes(r, b):
        np.testing.assert_array_equal(got, [c[2] for c in cases])


def test_large_random_batches_match_the_oracle():
    """1e4 fixes per layout kind, shared and per fix, N = 3 and 9 (the kernel's and the NumPy fallback's N)."""
    rng = np.random.default_rng(29)
    for n in (3, 9):
        m = 10_000
        r = rng.uniform(-20, 20, (m, n, 2))
        r[::3, :, 1] = 2.0 * r[::3, :, 0] + 1.0  # collinear
        r[1::7, 1] = r[1::7, 0]  # coincident
        p = rng.uniform(-20, 20, (m, 2))
        p[::6] = r[::6, 0] + rng.uniform(-2, 2, (len(p[::6]), 1)) * (r[::6, 1] - r[::6, 0])  # on the line
        b = bearing_to(np.column_stack([p, rng.uniform(-4, 4, m)])[:, None, :], r)
        b[5::11, 0] = np.nan
        want = _old_layout_ok(r, b)
        assert 0 < want.sum() < m and not want[::6][::2].any()  # every kind occurs, P on a wall is flagged
        for got in _both_modes(r, b):
            np.testing.assert_array_equal(got, want)
        for got in _both_modes(r[3], b):  # one shared collinear layout
            np.testing.assert_array_equal(got, _old_layout_ok(r[3], b))


# --- ToTal compiled: the NumPy kernel's numbers ------------------------------------------------------------
def _libm_is_numpys() -> bool:
    """NumPy's float64 tan/arctan2 are libm's here (not SVML's, as AVX512 builds may use)."""
    a = np.random.default_rng(0).uniform(-7, 7, 5000)
    return bool(np.array_equal(np.tan(a), [math.tan(v) for v in a.tolist()])
                and np.array_equal(np.arctan2(a, a[::-1]), [math.atan2(u, v) for u, v in zip(a, a[::-1], strict=True)]))


def _total_inputs(rng, m):
    """Bearings of ToTal fixes: random, near aligned pairs (reordering), the critical circle, equal bearings, NaN."""
    r = np.array([[0.0, 10.0], [-8.660254037844386, -5.0], [8.660254037844386, -5.0]])
    rad = 9.0 * np.sqrt(rng.uniform(0, 1, m))
    ang = rng.uniform(-math.pi, math.pi, m)
    poses = np.column_stack([rad * np.cos(ang), rad * np.sin(ang), rng.uniform(-math.pi, math.pi, m)])
    poses[::5, :2] = 10.0 * np.column_stack([np.cos(ang[::5]), np.sin(ang[::5])])  # on the critical circle
    poses[1::5, :2] = r[0] + rng.uniform(-0.5, 1.5, (len(poses[1::5]), 1)) * (r[1] - r[0])  # aligned with 1, 2
    b = bearing_to(poses[:, None, :], r)
    b[2::17] = b[2::17, :1]  # all three equal: tan 0, divisions by zero
    b[3::19, 1] = np.nan
    return r, b


def _numpy_total(layout, b):
    """The oracle: ToTal's NumPy form (``total_kernel`` on arrays) with the batch validity flags."""
    res = tri._kernel("total", layout, b, None, None, None)
    valid = res["valid"] & _old_layout_ok(layout, b)
    out = {k: np.where(valid, res[k], np.nan) for k in ("x", "y")}
    out["heading"] = np.where(valid, np.asarray(wrap_angle_scalar_array(res["heading"])), np.nan)
    out["quality"] = np.where(valid, res["quality"], 0.0)
    return valid, out


def wrap_angle_scalar_array(a):
    return np.array([wrap_angle_scalar(float(v)) for v in np.asarray(a).reshape(-1)]).reshape(np.shape(a))


def test_total_batch_is_the_numpy_kernel():
    """Batch ToTal is one code path, its kernel (total_batch), in either mode: the NumPy form's numbers."""
    rng = np.random.default_rng(3)
    r, b = _total_inputs(rng, 20_000)
    per_fix = r[None] + rng.normal(0, 1.0, (len(b), 3, 2))
    for layout in (r, per_fix):
        want_valid, want = _numpy_total(layout, b)
        assert 0.5 < want_valid.mean() < 0.95  # valid and invalid fixes both occur
        for on in (False, True):
            _jit.set_compiled(on)
            got = triangulate(layout, b, "total")
            np.testing.assert_array_equal(got.valid, want_valid)
            for key in ("x", "y", "heading", "quality"):
                np.testing.assert_allclose(getattr(got, key), want[key], rtol=1e-12, atol=1e-12, err_msg=key)


def test_total_batch_modes_agree_bit_for_bit_and_equal_the_float_kernel():
    """total_batch compiled and interpreted, against total_kernel on floats (ScalarMath: libm's tan/atan2 too)."""
    rng = np.random.default_rng(5)
    r, b = _total_inputs(rng, 1500)
    rx, ry = np.ascontiguousarray(r[None, :, 0]), np.ascontiguousarray(r[None, :, 1])
    scale2 = np.array([float(((r[1] - r[0]) ** 2).sum() + ((r[2] - r[1]) ** 2).sum() + ((r[0] - r[2]) ** 2).sum()) / 3])
    outs = {}
    for on in (False, True):
        _jit.set_compiled(on)
        o = [np.empty(len(b)) for _ in range(4)] + [np.empty(len(b), dtype=bool)]
        with np.errstate(all="ignore"):  # interpreted, the elements are NumPy scalars: inf * 0 warns
            total_batch(rx, ry, scale2, b, *o)
        outs[on] = o
    for a, c in zip(outs[False], outs[True], strict=True):  # the same bits, NaN as NaN (its sign bit may differ)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(c))
        assert a[~np.isnan(a)].tobytes() == c[~np.isnan(c)].tobytes()
    px, py, heading, quality, valid = outs[True]
    checked = 0
    for k in range(len(b)):
        try:
            want = total_kernel(tuple(r[:, 0].tolist()), tuple(r[:, 1].tolist()), tuple(b[k].tolist()), ScalarMath)
        except (ArithmeticError, ValueError):
            continue  # the float kernel raises on a zero divisor or NaN: the NumPy test covers those
        if bool(want["valid"]) != bool(valid[k]):  # float and NumPy layout_scale2 may differ in a last bit: rare
            continue
        if not valid[k]:
            continue
        checked += 1
        got = (px[k], py[k], heading[k], quality[k])
        assert got == (want["x"], want["y"], wrap_angle_scalar(want["heading"]), want["quality"]), k
    assert checked > 900  # of 1500 fixes, ~1/5 on the critical circle


def test_the_fast_wrap_is_wrap_angle_scalar_bit_for_bit():
    rng = np.random.default_rng(1)
    edges = [PI, -PI, TWO_PI, -TWO_PI, 2 * TWO_PI, -2 * TWO_PI, 3 * PI, -3 * PI, 0.0, -0.0, 1e-300, -1e-300, 1e9]
    values = edges + [math.nextafter(e, s) for e in edges for s in (-math.inf, math.inf)]
    values += rng.uniform(-15, 15, 20_000).tolist() + rng.uniform(-1e6, 1e6, 200).tolist()
    for on in (False, True):
        _jit.set_compiled(on)
        for v in values:
            assert math.copysign(1.0, _wrap(v)) == math.copysign(1.0, wrap_angle_scalar(v)), v
            assert _wrap(v) == wrap_angle_scalar(v), v
        assert math.isnan(_wrap(math.nan))


def test_div_is_numpys_division():
    vals = [0.0, -0.0, 1.0, -2.5, math.inf, -math.inf, math.nan, 1e-310, 1e308]
    for on in (False, True):
        _jit.set_compiled(on)
        for a in vals:
            for b in vals:
                with np.errstate(all="ignore"):
                    want = float(np.float64(a) / np.float64(b))
                got = _div(a, b)
                assert (math.isnan(got) and math.isnan(want)) or (got == want and math.copysign(1, got)
                                                                   == math.copysign(1, want)), (a, b)


def test_batch_total_builds_no_per_pair_temporaries():
    """Peak memory of a ToTal batch (compiled): its outputs and flags, not (m, 3, 3) pair temporaries.

    The former flags built ``sin`` of every bearing pair, ``(m, 3, 3)`` float64 (72 B per fix, twice
    over): peak 152 B per fix measured. Now four float64 outputs and a few flag arrays: 37 B per fix measured.
    """
    _jit.set_compiled(True)
    rng = np.random.default_rng(0)
    r, b = _total_inputs(rng, 100_000)
    triangulate(r, b[:10], "total")  # compile / load outside the measurement
    tracemalloc.start()
    triangulate(r, b, "total")
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 60 * len(b)


# --- the single-fix checks: the former ones as the oracle ---------------------------------------------------
def _old_check_single(r, b, h):
    for name, arr in (("reflectors", r), ("bearings", b), ("heading_estimate", h)):
        if arr is not None and not all(math.isfinite(v) for v in arr.ravel().tolist()):
            raise ValueError(f"{name} contains NaN or inf")
    pts = r.tolist()
    n = len(pts)
    d2 = [[(p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2 for q in pts] for p in pts]
    scale = max(max(row) for row in d2)
    for i in range(n):
        for j in range(i + 1, n):
            if d2[i][j] <= LAYOUT_TOL**2 * scale:
                raise ValueError(f"reflectors {i} and {j} coincide")
    mx, my = sum(p[0] for p in pts) / n, sum(p[1] for p in pts) / n
    sxx = sum((p[0] - mx) ** 2 for p in pts)
    syy = sum((p[1] - my) ** 2 for p in pts)
    sxy = sum((p[0] - mx) * (p[1] - my) for p in pts)
    collinear = n >= 3 and sxx * syy - sxy * sxy <= LAYOUT_TOL * (sxx + syy) ** 2
    if collinear and _old_parallel_rays(b).any():
        raise tri._OnReflectorLine


def _outcome(check, r, b, h):
    try:
        check(r, b, h)
    except (ValueError, tri._OnReflectorLine) as exc:
        return type(exc).__name__, str(exc)
    return None


@st.composite
def single_fixes(draw):
    n = draw(st.integers(1, 9))
    r = draw(layouts(n))
    if draw(st.integers(0, 9)) == 0:
        r[draw(st.integers(0, n - 1)), draw(st.integers(0, 1))] = draw(st.sampled_from([math.nan, math.inf]))
    with np.errstate(all="ignore"):
        b = draw(bearings_for(r))
    h = draw(st.sampled_from([None, 0.3, math.nan, -math.inf]))
    return r, b, None if h is None else np.asarray(h)


@given(single_fixes())
def test_single_fix_checks_are_the_former_checks(fix):
    """Same ValueError (same message) or the same on-the-line exit on the same single-fix input."""
    r, b, h = fix
    assert _outcome(tri._check_single, r, b, h) == _outcome(_old_check_single, r, b, h)


def test_single_fix_fast_path_keeps_every_value_error():
    r = np.array([[0.0, 10.0], [-8.66, -5.0], [8.66, -5.0]])
    b = np.array([1.0, 2.0, 3.0])
    for bad_r, bad_b, h, match in [
        (r, np.array([1.0, math.nan, 3.0]), None, "bearings contains NaN"),
        (np.array([[0.0, math.inf], [1.0, 0.0], [2.0, 1.0]]), b, None, "reflectors contains NaN"),
        (r, b, math.nan, "heading_estimate contains NaN"),
        (np.array([[0.0, 0.0], [0.0, 0.0], [2.0, 1.0]]), b, None, "reflectors 0 and 1 coincide"),
        (r, b[:2], None, "bearings must have shape"),
        (r[:, :1], b, None, "reflectors must have shape"),
    ]:
        with pytest.raises(ValueError, match=match):
            triangulate(bad_r, bad_b, "total", heading_estimate=h)
    with pytest.raises(ValueError, match="do not broadcast"):
        triangulate(np.stack([r, r]), np.stack([b, b, b]), "total")
