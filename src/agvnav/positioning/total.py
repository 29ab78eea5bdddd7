"""ToTal three-object triangulation (Pierlot & Van Droogenbroeck, IEEE T-RO 30(3), 2014).

Written from the published equations. With reflector 2 as origin
(``x'_i = x_i - x_2``) and ``T_ij = cot(theta_j - theta_i)``:

* ``T_31 = (1 - T_12 T_23) / (T_12 + T_23)`` (cot of a sum),
* modified circle centres ``x'_12 = x'_1 + T_12 y'_1``, ``y'_12 = y'_1 - T_12 x'_1``,
  ``x'_23 = x'_3 - T_23 y'_3``, ``y'_23 = y'_3 + T_23 x'_3``,
  ``x'_31 = (x'_3 + x'_1) + T_31 (y'_3 - y'_1)``, ``y'_31 = (y'_3 + y'_1) - T_31 (x'_3 - x'_1)``,
* ``k'_31 = x'_1 x'_3 + y'_1 y'_3 + T_31 (x'_1 y'_3 - x'_3 y'_1)``,
* ``D = (x'_12 - x'_23)(y'_23 - y'_31) - (y'_12 - y'_23)(x'_23 - x'_31)``,
* ``x = x_2 + k'_31 (y'_12 - y'_23) / D``, ``y = y_2 + k'_31 (x'_23 - x'_12) / D``.

Quality is ``1 / |D|`` (m⁻², as published: D → 0 on the critical circle; it depends on the
reflector order and on the layout's size). ``valid`` is False within ``CRITICAL_TOL`` of
the critical circle, by the same test on ``|C_12 C_23|`` as ``relative_angles``.

Two documented deviations, both exact rewrites: (1) each fix is cyclically reordered
so that the pair (3, 1) is the most nearly aligned with P (the paper's special-case
handling of an infinite cotangent), which keeps ``T_12`` and ``T_23`` finite; (2) ``T_31``
is kept as the fraction ``n/d`` and ``x'_31, y'_31, k'_31, D`` are all multiplied by
``d = T_12 + T_23``, so an infinite ``T_31`` (P aligned with reflectors 3 and 1) needs no
special case. The heading is the circular mean of ``atan2(R_i - P) - theta_i``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav._jit import jit
from agvnav.geometry.angles import PI, TWO_PI, wrap_angle_kernel
from agvnav.positioning._three import (
    CRITICAL_TOL,
    REORDER_TOL,
    Arr,
    Three,
    heading_from_position,
    layout_scale2,
    order_pairs,
)


def total_kernel(x: Three, y: Three, theta: Three, xp: Any = np) -> dict[str, Arr]:
    """ToTal on component arrays (reflector coordinates in m, bearings in rad).

    Returns ``x, y, heading, quality, valid`` arrays of the broadcast batch shape
    (``xp``: ``numpy`` or ``_three.ScalarMath`` for one fix in floats).
    """
    scale2 = layout_scale2(x, y)  # order-invariant: before reordering
    x, y, theta, tan_ab = order_pairs(x, y, theta, xp)
    t12 = 1.0 / tan_ab[0]
    t23 = 1.0 / tan_ab[1]
    x1, y1 = x[0] - x[1], y[0] - y[1]
    x3, y3 = x[2] - x[1], y[2] - y[1]
    n = 1.0 - t12 * t23  # T_31 = n / d
    d = t12 + t23
    x12, y12 = x1 + t12 * y1, y1 - t12 * x1
    x23, y23 = x3 - t23 * y3, y3 + t23 * x3
    dx31 = d * (x3 + x1) + n * (y3 - y1)  # d * x'_31
    dy31 = d * (y3 + y1) - n * (x3 - x1)  # d * y'_31
    dk31 = d * (x1 * x3 + y1 * y3) + n * (x1 * y3 - x3 * y1)  # d * k'_31
    a = y12 - y23
    b = x23 - x12
    dd = (x12 - x23) * (d * y23 - dy31) - a * (d * x23 - dx31)  # d * D
    f = dk31 / dd
    px = x[1] + f * a
    py = y[1] + f * b
    quality = xp.abs(d / dd)
    # |C_12 C_23| = |(a, b)| / 2: the same critical-circle test as relative_angles
    off_circle = a * a + b * b > (2.0 * CRITICAL_TOL) ** 2 * scale2
    valid = xp.isfinite(px) & xp.isfinite(py) & off_circle
    heading = heading_from_position(px, py, x, y, theta, xp)
    return {"x": px, "y": py, "heading": heading, "quality": quality, "valid": valid}


#: The critical-circle bound's factor as :func:`total_kernel` computes it (a Python float power),
#: frozen here for :func:`total_batch`.
_CRIT2 = (2.0 * CRITICAL_TOL) ** 2


@jit
def total_core(u1: float, v1: float, u3: float, v3: float, t12: float, t23: float) -> tuple[float, float, float, float]:
    """ToTal's circle intersection with reflector 2 as origin: ``(a, b, k'_31 d, D d)`` (see the module docstring).

    ``u1, v1`` and ``u3, v3`` are ``x'_1, y'_1`` and ``x'_3, y'_3`` (m), ``t12, t23`` the cotangents
    ``T_12, T_23``. The position is ``x_2 + f a``, ``y_2 + f b`` with ``f = k'_31 d / (D d)``; ``D d = 0``
    on the critical circle. The one form of these equations: the batch (:func:`total_batch`) and
    the integrity monitor's cross-check (``_integrity_fast.total_fix``) call it.
    """
    n = 1.0 - t12 * t23
    d = t12 + t23
    x12, y12 = u1 + t12 * v1, v1 - t12 * u1
    x23, y23 = u3 - t23 * v3, v3 + t23 * u3
    dx31 = d * (u3 + u1) + n * (v3 - v1)
    dy31 = d * (v3 + v1) - n * (u3 - u1)
    dk31 = d * (u1 * u3 + v1 * v3) + n * (u1 * v3 - u3 * v1)
    a = y12 - y23
    b = x23 - x12
    dd = (x12 - x23) * (d * y23 - dy31) - a * (d * x23 - dx31)
    return a, b, dk31, dd


@jit
def _div(a: float, b: float) -> float:
    """``a / b`` (IEEE, as NumPy divides): ``±inf`` or NaN for a zero ``b``, where Python and numba raise."""
    if b != 0.0:
        return a / b
    if a != a or a == 0.0:
        return math.nan
    return math.copysign(math.inf, a) * math.copysign(1.0, b)


@jit
def _wrap(angle: float) -> float:
    """:func:`~agvnav.geometry.angles.wrap_angle_scalar` bit for bit (rad, to ``[-pi, pi)``), no ``fmod`` below 4 pi.

    For ``2 pi <= |a| < 4 pi``, ``fmod(a, 2 pi)`` is ``a ∓ 2 pi`` exactly, with the sign of ``a``
    (``-0.0`` at ``a = -2 pi``); ``|a| - 2 pi`` is exact there (Sterbenz), so ``copysign`` of it
    is the same double, and so is the one exact shift that follows. Written as selects rather than
    the early return for ``[-pi, pi)`` (same result): the differences of bearings this wraps fall on
    either side at random, and a mispredicted branch cost more than the ``fmod`` it saves
    (measured: 167 -> 147 ns per ToTal fix). ``fmod`` costs ~14 ns.
    """
    mag = abs(angle)
    if mag < 2.0 * TWO_PI:
        r = math.copysign(mag - TWO_PI, angle) if mag >= TWO_PI else angle
        r = r - TWO_PI if r >= PI else r
        return r + TWO_PI if r < -PI else r
    return wrap_angle_kernel(angle)


@jit
def total_batch(
    rx: NDArray[np.float64],
    ry: NDArray[np.float64],
    scale2: NDArray[np.float64],
    theta: NDArray[np.float64],
    px_out: NDArray[np.float64],
    py_out: NDArray[np.float64],
    heading_out: NDArray[np.float64],
    quality_out: NDArray[np.float64],
    valid_out: NDArray[np.bool_],
) -> None:
    """:func:`total_kernel` over a batch in one compiled pass, the same float operations in the same order.

    ``rx, ry`` are the reflector coordinates (m) ``(1, 3)`` (one layout for the batch) or
    ``(m, 3)``, ``scale2`` their :func:`~agvnav.positioning._three.layout_scale2` (m², ``(1,)`` or
    ``(m,)``, computed by the caller with NumPy so its squares are NumPy's), ``theta (m, 3)`` the
    bearings (rad); writes ``x, y`` (m), heading (rad, [-pi, pi)), quality (m⁻²) and valid into the
    ``*_out`` arrays ``(m,)``. ``math.tan``/``atan2`` are libm's, as NumPy's float64 ufuncs call
    them on this machine's SIMD level (AVX512 builds of NumPy may use SVML: the last bit may differ
    there). Divisions go through :func:`_div` (IEEE's ``±inf``/NaN for a zero divisor, as NumPy);
    ``tan(theta1 - theta3)`` is only computed where :func:`~agvnav.positioning._three.order_pairs`
    needs it (a pair within ``REORDER_TOL``). A fix with a NaN or inf bearing is NaN and invalid
    (NumPy's NaNs give the same flag).
    """
    m = theta.shape[0]
    shared = rx.shape[0] == 1
    for k in range(m):
        kr = 0 if shared else k
        t0, t1, t2 = theta[k, 0], theta[k, 1], theta[k, 2]
        if not (math.isfinite(t0) and math.isfinite(t1) and math.isfinite(t2)):
            px_out[k] = py_out[k] = heading_out[k] = quality_out[k] = math.nan
            valid_out[k] = False
            continue
        x0, x1, x2 = rx[kr, 0], rx[kr, 1], rx[kr, 2]
        y0, y1, y2 = ry[kr, 0], ry[kr, 1], ry[kr, 2]
        # order_pairs: put the pair most nearly aligned with P last, (3, 1)
        tn12 = math.tan(t1 - t0)
        tn23 = math.tan(t2 - t1)
        a12, a23 = abs(tn12), abs(tn23)
        ta, tb = tn12, tn23
        if a12 < REORDER_TOL or a23 < REORDER_TOL:
            tn31 = math.tan(t0 - t2)
            a31 = abs(tn31)
            if a12 < REORDER_TOL and a12 < a23 and a12 < a31:  # order (2, 3, 1)
                x0, x1, x2, y0, y1, y2, t0, t1, t2 = x1, x2, x0, y1, y2, y0, t1, t2, t0
                ta, tb = tn23, tn31
            elif a23 < REORDER_TOL and a23 <= a12 and a23 < a31:  # order (3, 1, 2)
                x0, x1, x2, y0, y1, y2, t0, t1, t2 = x2, x0, x1, y2, y0, y1, t2, t0, t1
                ta, tb = tn31, tn12
        t12 = _div(1.0, ta)
        t23 = _div(1.0, tb)
        a, b, dk31, dd = total_core(x0 - x1, y0 - y1, x2 - x1, y2 - y1, t12, t23)
        d = t12 + t23  # quality 1/|D| = d/|D d|
        f = _div(dk31, dd)
        px = x1 + f * a
        py = y1 + f * b
        quality_out[k] = abs(_div(d, dd))
        valid_out[k] = math.isfinite(px) and math.isfinite(py) and a * a + b * b > _CRIT2 * scale2[kr]
        px_out[k] = px
        py_out[k] = py
        h0 = math.atan2(y0 - py, x0 - px) - t0
        h1 = math.atan2(y1 - py, x1 - px) - t1
        h2 = math.atan2(y2 - py, x2 - px) - t2
        heading_out[k] = _wrap(h0 + (_wrap(h1 - h0) + _wrap(h2 - h0)) / 3.0)
