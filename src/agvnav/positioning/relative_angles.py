"""Relative-angle triangulation by intersecting two circles ("arcos capaces"; Cohen & Koss 1992).

The classic method seed 000 (§2.2, Fig. 1b) compares against: the relative angles
``alpha_12 = theta_2 - theta_1`` and ``alpha_23 = theta_3 - theta_2`` fix the circles through
``P, R_1, R_2`` and ``P, R_2, R_3`` (centres ``C_12``, ``C_23``); both pass through ``R_2``, so
P is the mirror image of ``R_2`` across the line of centres. The heading follows from P.
It is independent of the heading estimate and undetermined on the critical circle
through the three reflectors, where ``C_12 = C_23``: there ``valid`` is False.

The fix is cyclically reordered so that the common reflector is the one opposite the
pair most nearly aligned with P (the classic method with a fixed pair fails there too).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from agvnav.positioning._three import (
    CRITICAL_TOL,
    Arr,
    Three,
    centres,
    heading_from_position,
    layout_scale2,
    order_pairs,
)


def relative_angles_kernel(x: Three, y: Three, theta: Three, xp: Any = np) -> dict[str, Arr]:
    """Circle-intersection triangulation on component arrays (m, rad).

    Nothing raises; callers run it under ``np.errstate(all='ignore')``.
    Returns ``x, y, heading, quality, valid``; ``quality`` is ``|C_12 C_23|`` over the
    layout scale and ``valid`` is False below ``CRITICAL_TOL`` (on the critical circle).
    """
    scale2 = layout_scale2(x, y)  # order-invariant: before reordering
    x, y, theta, tan_ab = order_pairs(x, y, theta, xp)
    cx, cy = centres(x, y, tan_ab)
    ex, ey = cx[1] - cx[0], cy[1] - cy[0]
    e2 = ex * ex + ey * ey
    # foot of R_2 on the line of centres, then mirror R_2 across it
    s = ((x[1] - cx[0]) * ex + (y[1] - cy[0]) * ey) / e2
    px = 2.0 * (cx[0] + s * ex) - x[1]
    py = 2.0 * (cy[0] + s * ey) - y[1]
    quality = xp.sqrt(e2 / scale2)
    heading = heading_from_position(px, py, x, y, theta, xp)
    valid = (quality > CRITICAL_TOL) & xp.isfinite(px) & xp.isfinite(py)
    return {"x": px, "y": py, "heading": heading, "quality": quality, "valid": valid}
