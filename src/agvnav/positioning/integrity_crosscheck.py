"""Integrity check: the estimate against an independent ToTal fix of the last revolution (seed 000 §2.2-2.3).

:func:`crosscheck_distance` brings the bearings of the best triple seen in the last
revolution to now through the odometry and triangulates them with ToTal, in one compiled pass
over the window (:func:`~agvnav.positioning._integrity_fast.crosscheck_fix`); the fix and the
estimate must agree within the chi-square bound of their summed covariances.

It runs when three distinct reflectors were seen in the last revolution: their bearings are
brought to one instant through the odometry (the angle propagation of seed 000 §2.2) and
triangulated with ToTal (:func:`~agvnav.positioning.triangulate`, ``valid=False`` near the
critical circle), each bearing's variance counting the odometry error of its propagation (the
monitor's ``odometry_noise``, the filter's seed-002 coefficients); the fix and the estimate
must agree within the chi-square bound of their summed covariances (``crosscheck_bound``), or
within ``crosscheck_min_m`` (the check looks for gross errors such as a wrong association; a
fixed survey error of the three reflectors can bias one triple's fix by a few sigma while the
filter, averaging every reflector, stays consistent). A failure of the cross-check alone is not
held (:mod:`agvnav.positioning.integrity_verdict`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agvnav.positioning._integrity_fast import CROSSCHECK_FIX, _head, crosscheck_fix

__all__ = ["crosscheck_distance"]


def crosscheck_distance(
    buffer: tuple[Any, int], newest: np.ndarray, x: np.ndarray, P: np.ndarray, odom: tuple[float, ...],
    mount: tuple[float, float, float], tables: tuple[np.ndarray, ...], odometry_noise: tuple[float, float, float],
    bearing_var: float, max_fix_std_m: float, min_m: float,
) -> float:
    """Mahalanobis distance² between the head position of the estimate and a ToTal fix (NaN if none).

    ``buffer`` the window's flat buffer and offset (:meth:`~agvnav.positioning.integrity_window._Window.buffer`),
    ``newest (N,)`` each reflector's newest sighting in the last revolution (-1: none), ``x (3,)``,
    ``P (3, 3)`` the estimate, ``odom`` the odometric pose now, ``tables`` the map's ``x, y,
    radius, map_std`` (m), ``odometry_noise`` seed 002's ``(k_d, k_dtheta, k_theta)``,
    ``bearing_var`` (rad²), ``max_fix_std_m`` the bound on a triple's CRLB and ``min_m`` the
    gross-error floor (m): closer than that the distance is 0.

    The bearings of the best triple seen in the last revolution are brought to now
    through the odometry (``z_now = centre + h(now) - h(then)``, seed 000 §2.2) and
    triangulated with ToTal (:func:`~agvnav.positioning.triangulate`).
    Each propagated bearing's variance is the bearing's, the survey's
    ``(map_std / d)^2`` and the error of the odometry between then and now
    (``var_th + var_pos / d^2``, ``var_th = k_dtheta s + k_theta |turn|``,
    ``var_pos = k_d s + var_th s^2 / 3`` over the ``s`` m travelled): without that
    last term a differential AGV, whose odometric heading wanders ~7 mrad in the 6 cm
    of one revolution at 0.5 m/s, failed the check every ~2 s with its estimate a few
    mm from the truth (fix 5-14 cm off, from the 10-13 m distant reflectors of a
    revolution-old triple).

    The triple (:func:`~agvnav.positioning._integrity_fast.best_triple`) is the one with the
    smallest position CRLB (seed 000 §2.3) with these variances, among those whose bound with
    the bearing noise alone is within ``max_fix_std_m``: near the critical circle of a triple
    its linearised covariance is not honest (issue 12). Of more than eight reflectors seen, the
    candidates are eight spread evenly over the revolution (``numpy.linspace(0, n - 1, 8)``
    rounded, in time order; only theirs are propagated): with 256 reflectors in the lab the
    eight newest reflections came from one 15° sector, and the best of their triples (three
    reflectors 1.7 m apart on one wall: 19 x 48 cm fix std with the 5 mm survey error, far
    from Gaussian) put fixes 5-7 cm off a sound estimate on 3 % of the checks.
    """
    buf, start = buffer
    rx, ry, radius, map_std = tables
    pose = (float(x[0]), float(x[1]), float(x[2]))
    out = crosscheck_fix(
        buf, start, newest, pose, (float(odom[0]), float(odom[1]), float(odom[2])), mount, rx, ry, radius,
        map_std, odometry_noise, bearing_var, max_fix_std_m**2)
    if out[0] != CROSSCHECK_FIX:
        return math.nan
    fx, fy, c00, c01, c11 = out[1:6]
    head_now = _head(pose[0], pose[1], pose[2], *mount)
    dx, dy = fx - head_now[0], fy - head_now[1]
    if math.hypot(dx, dy) <= min_m:
        return 0.0  # agreement within the gross-error floor
    return _mahalanobis2(dx, dy, float(c00 + P[0, 0]), float(c01 + P[0, 1]), float(c11 + P[1, 1]))


def _mahalanobis2(dx: float, dy: float, s00: float, s01: float, s11: float) -> float:
    """``[dx dy] S^-1 [dx dy]^T`` for the symmetric 2x2 ``S`` (NaN if not positive definite)."""
    det = s00 * s11 - s01 * s01
    if not det > 0.0:
        return math.nan
    return (s11 * dx * dx - 2.0 * s01 * dx * dy + s00 * dy * dy) / det
