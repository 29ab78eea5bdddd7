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

from typing import Any

import numpy as np

from agvnav.positioning._three import CRITICAL_TOL, Arr, Three, heading_from_position, layout_scale2, order_pairs


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
