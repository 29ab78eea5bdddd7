"""A three-bearing fix's covariance, and whether it is honest near the critical circle (seed 000 §2.2).

Every exact three-reflector method has the same first-order error ``J^-1 dtheta``, so the
linearised covariance ``(J^T R^-1 J)^-1`` serves them all (:func:`_covariance`). Near the
circle through the reflectors the error is no longer linear in the bearing noise: a fix
whose position std exceeds :data:`NONLINEAR_RATIO` times its distance from that circle is
flagged (:func:`_nonlinear`, issue 12). :func:`agvnav.positioning.triangulation.triangulate`
applies both.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from agvnav.positioning.bounds import fisher_information, inv_sym3

__all__ = ["NONLINEAR_RATIO"]

#: A three-reflector fix with ``bearing_std`` whose largest position std exceeds this
#: fraction of its distance from the critical circle is flagged ``valid=False`` (issue 12):
#: there the error is no longer linear in the bearing noise and the linearised covariance
#: does not bound it. Monte Carlo near the circle (bearing std 1e-3 and 1e-4 rad, ToTal and
#: relative angles): 25 % and 10 % of the valid fixes fell outside their own 95 % ellipse;
#: of those this flag keeps, 5.3 % (tests/positioning/test_critical_circle_honesty.py).
NONLINEAR_RATIO = 0.3


def _nonlinear(
    r: NDArray[np.float64],
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    cov: NDArray[np.float64],
    from_estimate: NDArray[np.bool_],
) -> NDArray[np.bool_]:
    """``(m,)`` True where a three-reflector fix is too near its critical circle for its covariance.

    ``r`` is ``(3, 2)`` or ``(m, 3, 2)`` (m), ``x, y`` the fixes (m), ``cov (m, 3, 3)``. The
    distance from the circle through the reflectors (their line when collinear) is compared
    with the largest position std: ``std > NONLINEAR_RATIO * distance`` (see the constant).
    A fix that kept the heading estimate (``from_estimate``) is judged by its prior instead.
    """
    rr = np.broadcast_to(r, (x.shape[0], 3, 2))
    ax, bx, cx = rr[:, 0, 0], rr[:, 1, 0], rr[:, 2, 0]
    ay, by, cy = rr[:, 0, 1], rr[:, 1, 1], rr[:, 2, 1]
    with np.errstate(all="ignore"):
        den = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
        a2, b2, c2 = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
        ux = (a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / den
        uy = (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / den
        circle = np.abs(np.hypot(x - ux, y - uy) - np.hypot(ax - ux, ay - uy))
        lx, ly = cx - ax, cy - ay  # collinear: distance from the line through the reflectors
        line = np.abs(lx * (y - ay) - ly * (x - ax)) / np.hypot(lx, ly)
        dist = np.where(np.isfinite(circle), circle, line)
        a, b, c = cov[:, 0, 0], cov[:, 1, 1], cov[:, 0, 1]
        big = 0.5 * (a + b) + np.sqrt(0.25 * (a - b) ** 2 + c * c)  # largest eigenvalue of the position block
        return ~from_estimate & np.isfinite(big) & (big > (NONLINEAR_RATIO * dist) ** 2)


def _covariance(
    method: str,
    r: NDArray[np.float64],
    res: dict[str, NDArray[np.float64]],
    bs: NDArray[np.float64],
    hs: NDArray[np.float64] | None,
) -> NDArray[np.float64]:
    """Covariance ``(m, 3, 3)`` from the linearisation at the solution.

    For three bearings every exact method has the same first-order error
    ``J^-1 dtheta``, so ``(J^T R^-1 J)^-1`` applies to all of them; where absolute_angles
    kept the heading estimate its std ``heading_std`` enters as a prior on the heading.
    """
    if method == "least_squares":
        info = res["information"]
    else:
        pose = np.stack([res["x"], res["y"], res["heading"]], axis=-1)
        with np.errstate(all="ignore"):
            info = fisher_information(r, pose, bs)
        if hs is not None and "heading_from_estimate" in res:
            info[:, 2, 2] += np.where(res["heading_from_estimate"], 1.0 / hs**2, 0.0)
    cov, ok = inv_sym3(info)
    cov[~ok] = np.nan
    if method == "absolute_angles" and hs is None:
        # Critical circle without heading_std: three bearings do not bound the fix (the
        # position turns with the heading error), so say so with infinite variances.
        unbounded = np.asarray(res["heading_from_estimate"], dtype=bool)
        cov[unbounded] = np.diag([np.inf, np.inf, np.inf])
    return cov
