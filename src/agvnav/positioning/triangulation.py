"""Pose of the goniometer head from reflector bearings: one entry point, four methods.

``triangulate(reflectors, bearings, method=...)`` solves one fix or a million at once.
Bearings are measured from the head's x-axis, counter-clockwise (REP-103); the
result is the pose ``[x, y, heading]`` of the head centre P in the world frame
(seed 000, §2.2, Fig. 1a).

Methods (see each module):

* ``"absolute_angles"`` (``absolute_angles``): seed 000 §2.3, needs a heading
  estimate (``None`` means 0: the method corrects any heading error away from the
  critical circle, but on it no estimate means no fix, so ``valid=False`` there);
* ``"relative_angles"`` (``relative_angles``): circle intersection, heading-free;
* ``"total"`` (``total``): ToTal, the speed baseline; its batches run its kernel
  (``total.total_batch``, compiled or interpreted as :mod:`agvnav._jit` runs every kernel);
* ``"least_squares"`` (``least_squares``): maximum likelihood over N >= 3 bearings, or
  N >= 2 with ``heading_estimate`` and ``heading_std``.

The first three take exactly three reflectors.

Bad input. *Structural* problems raise ``ValueError`` on every path: unknown method,
reflectors not ``(..., N, 2)``, bearings not ``(..., N)`` with the same N, batch shapes
that do not broadcast, too few/many reflectors for the method, non-positive
``bearing_std``/``heading_std``. *Value* problems depend on the path:

* single fix (no batch dimensions): NaN/inf in reflectors, bearings or the heading
  estimate and coincident reflectors raise ``ValueError`` naming the problem;
* batch: the same problems only set ``valid=False`` for the element concerned (its
  x, y, heading are NaN); neighbours are unaffected.

Degenerate *geometry* is not bad input and never raises: on the critical circle
``relative_angles``/``total`` give ``valid=False``, ``absolute_angles`` keeps the heading
estimate and sets ``heading_from_estimate``. Near it, with ``bearing_std``, a fix whose
position std exceeds ``NONLINEAR_RATIO`` times its distance from the circle is
``valid=False`` too: its linearised covariance would not be honest (issue 12).

Collinear reflectors (three or more on one wall, a common layout) are geometry too
(issue 13): the circle through three of them degenerates to their line, so the fix is
determined wherever P is off that line and every method returns it; on the line all
the bearings are parallel (they differ by 0 or pi) and every method returns
``valid=False`` (seed 000 §2.2-2.3: the methods are indeterminate on the critical circle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import as_float_array
from agvnav.geometry.angles import wrap_angle, wrap_angle_scalar
from agvnav.positioning._three import ScalarMath, layout_scale2
from agvnav.positioning.absolute_angles import absolute_angles_kernel

# the tolerances are re-exported: the compiled integrity fix (positioning._integrity_fast) imports them from here
from agvnav.positioning.fix_covariance import NONLINEAR_RATIO, _covariance, _nonlinear  # noqa: F401
from agvnav.positioning.fix_validity import (  # noqa: F401
    LAYOUT_TOL,
    PARALLEL_TOL,
    _check_single,
    _layout_flags,
    _layout_ok,
    _OnReflectorLine,
)
from agvnav.positioning.least_squares import (
    _normal_equations_single,
    inv3_single,
    least_squares_kernel,
    least_squares_single,
)
from agvnav.positioning.relative_angles import relative_angles_kernel
from agvnav.positioning.total import total_batch, total_kernel

METHODS = ("absolute_angles", "relative_angles", "total", "least_squares")

#: Fixes per kernel call: 16384 float64 = 128 KiB per temporary. Measured on the bench
#: machine, 16k-32k beat 4k-8k (fewer Python calls per fix) and 64k (the working set
#: leaves the cache); the kernels create a few dozen temporaries per chunk.
CHUNK = 16384

@dataclass(frozen=True)
class TriangulationResult:
    """A fix (or a batch of fixes): head pose, flags, quality and optional covariance.

    ``x, y`` (m), ``heading`` (rad, [-pi, pi)), ``valid``, ``heading_from_estimate``,
    ``quality`` all have the batch shape ``(...)`` (0-d for one fix); ``covariance`` is
    ``(..., 3, 3)`` over ``[x, y, heading]`` (m², m·rad, rad²) or None without ``bearing_std``.
    ``quality`` is method specific: |C_12 C_23| / layout scale (absolute and relative
    angles), 1/|D| (ToTal, m⁻²), 1/PDOP (least squares, rad/m); larger is better.
    """

    x: NDArray[np.float64]
    y: NDArray[np.float64]
    heading: NDArray[np.float64]
    valid: NDArray[np.bool_]
    heading_from_estimate: NDArray[np.bool_]
    quality: NDArray[np.float64]
    covariance: NDArray[np.float64] | None

    @property
    def pose(self) -> NDArray[np.float64]:
        """The pose ``(..., 3)`` = ``[x, y, heading]``."""
        return np.stack([self.x, self.y, self.heading], axis=-1)


def triangulate(
    reflectors: ArrayLike,
    bearings: ArrayLike,
    method: str = "absolute_angles",
    heading_estimate: ArrayLike | None = None,
    bearing_std: ArrayLike | None = None,
    heading_std: ArrayLike | None = None,
) -> TriangulationResult:
    """Pose of the goniometer head from the bearings of known reflectors.

    Parameters
    ----------
    reflectors : (..., N, 2) world coordinates (m); a plain ``(N, 2)`` layout is shared
        by the whole batch without copying.
    bearings : (..., N) bearings (rad) from the head x-axis, CCW, in reflector order.
    method : one of ``METHODS``.
    heading_estimate : (...) odometric heading estimate ``psi_est`` (rad), optional.
    bearing_std : bearing noise std (rad), broadcasting against (..., N); gives the
        covariance from the linearisation at the solution (and weights least squares).
    heading_std : std (rad) of ``heading_estimate``; with it, least squares uses the
        estimate as a prior, and absolute_angles' covariance on the critical circle uses it.
        Without it, a critical-circle absolute_angles fix (``heading_from_estimate``) with
        ``bearing_std`` gets the covariance ``diag(inf, inf, inf)``: valid fix, unbounded
        uncertainty (the bearings alone do not bound it, see Notes), never NaN.

    Notes
    -----
    On (or near) the critical circle through the three reflectors, three bearings do not
    determine the pose: every point of the circle sees the reflectors under the same
    relative angles. Without the true heading the position cannot be recovered:
    ``absolute_angles`` keeps the estimate's lines, so with a heading-estimate error δ it
    returns P rotated by 2δ about the circle's centre (the inscribed angle turns by δ, the
    central angle by 2δ), and ``heading = heading_estimate``. That is why the
    estimator's seed falls back on odometry there, and why ``relative_angles``/``total``
    return ``valid=False``.

    Returns
    -------
    TriangulationResult, shapes as described there. See the module docstring for
    which bad inputs raise and which are flagged.

    Examples
    --------
    >>> import numpy as np
    >>> r = [(0.0, 1.0), (-np.sqrt(3) / 2, -0.5), (np.sqrt(3) / 2, -0.5)]
    >>> fix = triangulate(r, np.deg2rad([90.0, -150.0, -30.0]), heading_estimate=0.2)
    >>> bool(fix.valid), (np.round(fix.pose, 12) + 0.0).tolist()
    (True, [0.0, 0.0, 0.0])
    """
    if method not in METHODS:
        raise ValueError(f"unknown triangulation method {method!r}; choose one of {', '.join(METHODS)}")
    r, b = _check_shapes(reflectors, bearings)
    n = r.shape[-2]
    h = None if heading_estimate is None else as_float_array("heading_estimate", heading_estimate)
    bs = _optional_std("bearing_std", bearing_std)
    hs = _optional_std("heading_std", heading_std)
    _check_count(method, n, h is not None and hs is not None)
    if r.ndim == 2 and b.ndim == 1 and (h is None or h.ndim == 0) and bs is None and hs is None:
        batch: tuple[int, ...] = ()  # one plain fix: nothing to broadcast (np.broadcast_shapes costs ~2 µs)
    else:
        try:
            batch = np.broadcast_shapes(r.shape[:-2], b.shape[:-1], () if h is None else h.shape)
            if bs is not None:
                np.broadcast_shapes(bs.shape, batch + (n,))
            if hs is not None:
                np.broadcast_shapes(hs.shape, batch)
        except ValueError:
            raise ValueError(
                f"batch shapes do not broadcast: reflectors {r.shape}, bearings {b.shape}"
                + ("" if h is None else f", heading_estimate {h.shape}")
            ) from None
    if batch == ():
        try:
            _check_single(r, b, h)
        except _OnReflectorLine:
            return _solve(method, r, b, h, bs, hs, batch)
        try:
            if method == "least_squares":
                return _solve_single_ls(r, b, h, bs, hs)
            return _solve_single(method, r, b, h, bs, hs)
        except (ArithmeticError, ValueError):
            pass  # a float singularity (e.g. exact alignment): the NumPy path flags it
    return _solve(method, r, b, h, bs, hs, batch)


def _check_shapes(reflectors: ArrayLike, bearings: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    r = as_float_array("reflectors", reflectors)
    b = as_float_array("bearings", bearings)
    if r.ndim < 2 or r.shape[-1] != 2:
        raise ValueError(f"reflectors must have shape (..., N, 2), got {r.shape}")
    if b.ndim < 1 or b.shape[-1] != r.shape[-2]:
        raise ValueError(f"bearings must have shape (..., N) with N={r.shape[-2]} reflectors, got {b.shape}")
    return r, b


def _optional_std(name: str, value: ArrayLike | None) -> NDArray[np.float64] | None:
    if value is None:
        return None
    arr = as_float_array(name, value)
    if not np.all(arr > 0.0) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be positive and finite")
    return arr


def _check_count(method: str, n: int, has_prior: bool) -> None:
    if method != "least_squares" and n != 3:
        raise ValueError(f"method {method!r} needs exactly 3 reflectors, got {n}")
    need = 2 if has_prior else 3
    if method == "least_squares" and n < need:
        hint = "" if has_prior else " (2 with heading_estimate and heading_std)"
        raise ValueError(f"method 'least_squares' needs at least {need} reflectors{hint}, got {n}")


def _solve(
    method: str,
    r: NDArray[np.float64],
    b: NDArray[np.float64],
    h: NDArray[np.float64] | None,
    bs: NDArray[np.float64] | None,
    hs: NDArray[np.float64] | None,
    batch: tuple[int, ...],
) -> TriangulationResult:
    n = r.shape[-2]
    m = int(np.prod(batch))
    shared = r.ndim == 2
    rf = r if shared else np.broadcast_to(r, batch + (n, 2)).reshape(m, n, 2)
    bf = np.broadcast_to(b, batch + (n,)).reshape(m, n)
    hf = None if h is None else np.broadcast_to(h, batch).reshape(m)
    bsf = None if bs is None else np.broadcast_to(bs, batch + (n,)).reshape(m, n)
    hsf = None if hs is None else np.broadcast_to(hs, batch).reshape(m)
    fused = method == "total"  # ToTal's batch is its kernel (total_batch); the other methods' NumPy forms
    # the validity flags, NaN/inf bearings included; ToTal's kernel flags NaN/inf bearings itself, so
    # a shared layout that is neither coincident nor collinear leaves it nothing to add
    plain = fused and shared and not any(bool(f) for f in _layout_flags(rf))
    layout_ok = None if plain else _layout_ok(rf, bf)
    out: dict[str, NDArray[Any]] = {k: np.empty(m) for k in ("x", "y", "heading", "quality")}
    out["valid"] = np.empty(m, dtype=bool)
    out["heading_from_estimate"] = np.zeros(m, dtype=bool)
    cov = None if bs is None else np.empty((m, 3, 3))
    if fused:  # one pass of the kernel (total_batch)
        _total_batch(rf, bf, out)
    for start in range(0, m, CHUNK) if cov is not None or not fused else ():  # fused: only the covariance
        s = slice(start, min(start + CHUNK, m))
        rc = rf if shared else rf[s]
        hc = None if hf is None else hf[s]
        if fused:
            res = {k: out[k][s] for k in ("x", "y", "heading")}
        else:
            res = _kernel(method, rc, bf[s], hc, None if bsf is None else bsf[s], None if hsf is None else hsf[s])
            for key, value in res.items():
                if key in out:
                    out[key][s] = value
        if cov is not None:
            cov[s] = _covariance(method, rc, res, bsf[s], None if hsf is None else hsf[s])  # type: ignore[index]
    valid = out["valid"] if layout_ok is None else out["valid"] & layout_ok
    if cov is not None and method != "least_squares":
        valid &= ~_nonlinear(rf, out["x"], out["y"], cov, out["heading_from_estimate"])
    for key in ("x", "y", "heading"):
        out[key][~valid] = np.nan
    out["quality"][~valid] = 0.0
    out["heading_from_estimate"] &= valid
    shaped = {k: v.reshape(batch) for k, v in out.items()}
    shaped["valid"] = valid.reshape(batch)
    if method == "least_squares":  # the three-reflector kernels return headings in [-pi, pi) already
        shaped["heading"] = np.asarray(wrap_angle(shaped["heading"]))
    return TriangulationResult(
        covariance=None if cov is None else cov.reshape(batch + (3, 3)),
        **shaped,
    )


def _total_batch(r: NDArray[np.float64], b: NDArray[np.float64], out: dict[str, NDArray[Any]]) -> None:
    """ToTal over the flat batch ``b (m, 3)``, layout ``r`` ``(3, 2)`` or ``(m, 3, 2)``, by its kernel, into ``out``."""
    x = (r[..., 0, 0], r[..., 1, 0], r[..., 2, 0])
    y = (r[..., 0, 1], r[..., 1, 1], r[..., 2, 1])
    scale2 = np.atleast_1d(np.asarray(layout_scale2(x, y), dtype=np.float64))  # NumPy's squares, as total_kernel
    rx = np.ascontiguousarray(np.atleast_2d(r[..., 0]))
    ry = np.ascontiguousarray(np.atleast_2d(r[..., 1]))
    with np.errstate(all="ignore"):  # interpreted, the elements are NumPy scalars: inf * 0 warns
        total_batch(rx, ry, scale2, np.ascontiguousarray(b), out["x"], out["y"], out["heading"], out["quality"],
                    out["valid"])


def _solve_single(
    method: str,
    r: NDArray[np.float64],
    b: NDArray[np.float64],
    h: NDArray[np.float64] | None,
    bs: NDArray[np.float64] | None,
    hs: NDArray[np.float64] | None,
) -> TriangulationResult:
    """One fix of a three-reflector method in Python floats (``ScalarMath``): ~20x less overhead."""
    (x1, y1), (x2, y2), (x3, y3) = r.tolist()
    t = tuple(b.tolist())
    x, y = (x1, x2, x3), (y1, y2, y3)
    if method == "total":
        res = total_kernel(x, y, t, ScalarMath)
    elif method == "relative_angles":
        res = relative_angles_kernel(x, y, t, ScalarMath)
    else:
        res = absolute_angles_kernel(x, y, t, 0.0 if h is None else float(h), ScalarMath)
        if h is None and res["heading_from_estimate"]:
            res["valid"] = False
    valid = bool(res["valid"])
    hfe = bool(res.get("heading_from_estimate", False)) and valid
    nan = float("nan")
    px, py = (res["x"], res["y"]) if valid else (nan, nan)
    heading = np.asarray(wrap_angle_scalar(res["heading"]) if valid else nan)
    cov = None
    if bs is not None:
        arrays = {"x": np.array([px]), "y": np.array([py]), "heading": np.array([heading]),
                  "heading_from_estimate": np.array([hfe])}
        hs1 = None if hs is None else np.reshape(hs, (1,))
        cov = _covariance(method, r, arrays, np.broadcast_to(bs, (1, 3)), hs1)[0]
        if valid and bool(_nonlinear(r, np.array([px]), np.array([py]), cov[None], np.array([hfe]))[0]):
            valid, hfe, px, py, heading = False, False, nan, nan, np.asarray(nan)
            res["quality"] = 0.0
    return TriangulationResult(
        x=np.asarray(px, dtype=np.float64),
        y=np.asarray(py, dtype=np.float64),
        heading=heading,
        valid=np.asarray(valid),
        heading_from_estimate=np.asarray(hfe),
        quality=np.asarray(res["quality"] if valid else 0.0, dtype=np.float64),
        covariance=cov,
    )


def _solve_single_ls(
    r: NDArray[np.float64],
    b: NDArray[np.float64],
    h: NDArray[np.float64] | None,
    bs: NDArray[np.float64] | None,
    hs: NDArray[np.float64] | None,
) -> TriangulationResult:
    """One least-squares fix in floats, started from ToTal on the first three reflectors."""
    pts = r.tolist()
    theta = b.tolist()
    n = len(pts)
    if n < 3:
        raise ArithmeticError("no three-reflector start: use the batch path")
    start = total_kernel(tuple(p[0] for p in pts[:3]), tuple(p[1] for p in pts[:3]), tuple(theta[:3]), ScalarMath)
    if not start["valid"]:
        raise ArithmeticError("ToTal start failed: use the batch path")
    w = [1.0] * n if bs is None else (1.0 / np.broadcast_to(bs, (n,)) ** 2).tolist()
    prior = None if h is None or hs is None else (float(h), 1.0 / float(hs) ** 2)
    state, converged, info = least_squares_single(pts, theta, w, prior, [start["x"], start["y"], start["heading"]])
    cov = inv3_single(info)  # singular: ZeroDivisionError, the batch path flags it
    try:
        unit_cov = inv3_single(_normal_equations_single(state, pts, theta, [1.0] * n, None)[0])
        quality = 1.0 / math.sqrt(unit_cov[0][0] + unit_cov[1][1])
    except ZeroDivisionError:  # observable only with the heading prior
        quality = 0.0
    valid = converged and all(math.isfinite(v) for v in state)
    nan = float("nan")
    return TriangulationResult(
        x=np.asarray(state[0] if valid else nan),
        y=np.asarray(state[1] if valid else nan),
        heading=np.asarray(wrap_angle(state[2] if valid else nan)),
        valid=np.asarray(valid),
        heading_from_estimate=np.asarray(False),
        quality=np.asarray(quality if valid else 0.0),
        covariance=None if bs is None else np.array(cov),
    )


def _kernel(
    method: str,
    r: NDArray[np.float64],
    b: NDArray[np.float64],
    h: NDArray[np.float64] | None,
    bs: NDArray[np.float64] | None,
    hs: NDArray[np.float64] | None,
) -> dict[str, NDArray[np.float64]]:
    """Run one method's kernel on a flat chunk: ``r`` (N, 2) or (m, N, 2), ``b`` (m, N)."""
    if method == "least_squares":
        return least_squares_kernel(r[..., 0], r[..., 1], b, bs, h, hs)
    x = (r[..., 0, 0], r[..., 1, 0], r[..., 2, 0])
    y = (r[..., 0, 1], r[..., 1, 1], r[..., 2, 1])
    t = (b[:, 0], b[:, 1], b[:, 2])
    with np.errstate(all="ignore"):
        if method == "total":
            return total_kernel(x, y, t)
        if method == "relative_angles":
            return relative_angles_kernel(x, y, t)
        res = absolute_angles_kernel(x, y, t, np.zeros(b.shape[0]) if h is None else h)
    if h is None:  # no estimate to fall back on near the critical circle
        res["valid"] = res["valid"] & ~res["heading_from_estimate"]
    return res

