"""Integrity check: the common offset of the last revolution's innovations (``"offset"``).

The fit of the RAIM (:mod:`agvnav.positioning.integrity_raim`), whose residual tests reflectors
that disagree, has a common part -- the pose offset all the bearings share
(:func:`common_offset`) -- chi-square with 3 dof for a consistent filter; beyond its upper
``sqrt(raim_false_alarm)`` quantile in two revolutions in a row (disjoint sightings: together at
``raim_false_alarm``) the prior estimate is off all its bearings at once, odometry having
carried it there: ``"offset"`` (:class:`OffsetCheck`). It sees the onset of wheel slip a
revolution or two after the lag passes a few sigma, where the window's NIS, averaging a
second, took a second.
"""

from __future__ import annotations

import math
from collections.abc import Collection

import numpy as np

from agvnav.positioning._integrity_fast import mean_innovations, revolution_innovations, revolution_offset
from agvnav.positioning.integrity_raim import _chi2_3dof_isf
from agvnav.positioning.integrity_window import _Window

__all__ = ["OffsetCheck", "common_offset", "revolution_fix"]

_NO_ATTRIBUTED = np.zeros((0, 7))


def common_offset(
    window: _Window, attributed: Collection[tuple[float, ...]], t: float, revolution_s: float,
    excluded: np.ndarray, map_std: np.ndarray, bearing_var: float,
) -> tuple[np.ndarray, float] | None:
    """The pose offset the last revolution's innovations share, and its chi-square (3 dof) statistic.

    The EKF innovations of the sightings of ``window`` within one revolution (``revolution_s``, s)
    before ``t`` (s) and the gated-out ones ``attributed`` to a reflector (rows ``(t, map row, y,
    S, H0, H1, H2)``), as the RAIM takes them: per reflector the mean innovation ``ybar_k``, its
    Jacobian row ``Hbar_k`` and the variance ``(map_std / d)^2 + (Sbar_k - (map_std / d)^2) / n_k``,
    fitted by weighted least squares as ``ybar = Hbar dx``. A consistent filter's innovations are
    white with variance ``S`` [seed002 eq14], so ``dx^T (Hbar^T W Hbar) dx`` is chi-square with 3
    dof; the RAIM tests the residual of the same fit (reflectors that disagree), this its common
    part: the prior estimate off all its bearings at once (odometry that carried it off: wheel
    slip). ``excluded (N,)`` flags the excluded map rows, ``map_std (N,)`` (m) the survey std,
    ``bearing_var`` (rad²) the variance of one bearing. Returns ``(dx (3,), statistic)`` (m, m,
    rad), or None with fewer than 4 reflectors or a singular fit.

    One compiled pass (:func:`~agvnav.positioning._integrity_fast.revolution_offset`) with the
    RAIM's normal equations and elimination (the same fit, one formulation). It replaced
    NumPy's ``H.T @ (W H)``, ``np.linalg.solve`` and ``dx @ A @ dx``, which OpenBLAS sums in its
    own order with fused multiply-adds (its kernel chosen by the CPU): the statistic moved by
    at most 5e-15 relative, ``dx`` by 7e-13, over the 1,900 checks of 30 s of guidance_test,
    differential_loop and tricycle_rear_loop; no decision changed and the seeded runs kept their bits.
    """
    buf, start = window.buffer()
    att = np.array(attributed, dtype=np.float64) if attributed else _NO_ATTRIBUTED
    ok, dx0, dx1, dx2, stat = revolution_offset(buf, start, len(window), t, revolution_s, excluded, att, len(att),
                                                map_std, bearing_var)
    return (np.array([dx0, dx1, dx2]), stat) if ok else None


def revolution_fix(
    window: _Window, attributed: Collection[tuple[float, ...]], t: float, revolution_s: float,
    excluded: np.ndarray, map_std: np.ndarray, bearing_var: float,
) -> tuple[np.ndarray, np.ndarray, int] | None:
    """The fit of :func:`common_offset` with its covariance: what one revolution of bearings alone says.

    The same weighted least squares ``ybar = Hbar dx`` (per reflector the mean innovation
    over the last revolution, :func:`~agvnav.positioning._integrity_fast.mean_innovations`),
    solved with its normal matrix ``A = Hbar^T W Hbar``: ``dx = A^-1 Hbar^T W ybar`` and
    ``cov(dx) = A^-1`` [seed002 eq14] (the innovations of a consistent filter are white with
    variance ``S``). The innovation is the bearing measured minus the one predicted from the
    estimate, so ``dx`` is the truth minus the estimate as the bearings see it, independent
    of what the odometry claims (its error over one revolution aside): a snapshot fix.
    Returns ``(dx (3,), cov (3, 3), reflectors)`` (m, m, rad; m², m rad, rad²), or None with
    fewer than 4 reflectors or a singular fit. NumPy, not compiled: the caller asks for it
    once per revolution (:class:`~agvnav.positioning.deviation.DeviationWatch`).
    """
    buf, start = window.buffer()
    att = np.array(attributed, dtype=np.float64) if attributed else _NO_ATTRIBUTED
    sums = revolution_innovations(buf, start, len(window), t, revolution_s, excluded, att, len(att))
    rows = np.flatnonzero(sums[:, 5] != 0.0).astype(np.int64)
    if rows.shape[0] < 4:
        return None
    ybar, hbar, _, w = mean_innovations(sums, rows, map_std, bearing_var)
    A = hbar.T @ (w[:, None] * hbar)
    if not np.all(np.isfinite(A)) or np.linalg.cond(A) > 1e12:
        return None
    cov = np.linalg.inv(A)
    dx = cov @ (hbar.T @ (w * ybar))
    return dx, 0.5 * (cov + cov.T), int(rows.shape[0])


class OffsetCheck:
    """``"offset"`` when two revolutions in a row share a pose offset beyond chance (:func:`common_offset`).

    Each revolution's statistic against the upper ``sqrt(raim_false_alarm)`` quantile of
    the chi-square with 3 dof; two revolutions at least one revolution apart (disjoint
    sightings, independent for a consistent filter) both beyond it fail together with
    probability ``raim_false_alarm`` per check. Not when the RAIM named a reflector (its
    pull is the offset: a measurement fault). Why: 30 % wheel slip on the seed-000
    tricycle carried the estimate 45-57 mm along its path in the first second while the
    nearest reflector fell out of its gate and the window's NIS stayed below its bound:
    ``tracking`` 5-14 sigma off for 1.15 s (integrity bench, seed 4); this check fails
    0.45 s into that stretch. On the bench's sound runs (10 seeds of each vehicle, about
    4,000 checks) the statistic's 99.9 % point was 9.4 on the tricycle and 19.3 on the
    differential AGV (the chi-square's 16.3: a heavier tail than the model's, which the
    second revolution covers), and no two revolutions in a row passed the bound (13.8).
    """

    def __init__(self) -> None:
        self.since: float | None = None  # first of the checks in a row whose offset was beyond chance

    def failures(
        self, t: float, offset: tuple[np.ndarray, float] | None, revolution_s: float, false_alarm: float,
        raim_named: bool,
    ) -> list[str]:
        """``["offset"]`` or ``[]`` at ``t`` (s) for this revolution's ``offset`` (:func:`common_offset`)."""
        if offset is None or not offset[1] > _chi2_3dof_isf(math.sqrt(false_alarm)):
            self.since = None
            return []
        if self.since is None or t - self.since < 0.999 * revolution_s:
            if self.since is None:
                self.since = t
            return []
        return [] if raim_named else ["offset"]
