"""Integrity checks on the filter's own statistics: the innovation chi-square, the corrections, the uncertainty.

* NIS: the window's normalised innovations squared, averaged per reflector, against the
  upper quantile of a chi-square (:func:`chi2_upper`): above it, ``"nis"``;
* corrections: the Kalman corrections summed over the window against their covariance
  (:func:`corrections_drift`): the odometry carrying the estimate off its bearings;
* uncertainty: a position or heading variance beyond what the bearing gate can identify
  reflectors with (:func:`uncertainty_failures`): ``"uncertainty"``, which makes the verdict ``lost``;
* per reflector, the exponentially weighted mean of its NIS ``y^2 / S`` (weight 1/8,
  about 8 sightings; squared, so a bias that changes sign as the vehicle moves still
  counts; :class:`ReflectorNis`): a reflector whose mean exceeds ``exclude_sigmas^2`` and
  ``exclude_ratio^2`` times the mean of the other reflectors' is inconsistent with the rest of
  the map (moved, or a reflection off a shiny surface beside it) and is *excluded*
  (:attr:`~agvnav.positioning.integrity.IntegrityMonitor.excluded`), which the estimator never
  associates again (at most ``max_excluded``, and never below ``min_reflectors + 1`` others in
  view; fault detection and exclusion as RAIM does for satellites). Only where the RAIM
  (:mod:`agvnav.positioning.integrity_raim`) has no redundancy to judge with: where it can run,
  it owns the exclusion.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["CHI2_2DOF_999", "ReflectorNis", "chi2_upper", "corrections_drift", "uncertainty_failures"]

#: Chi-square quantile, 2 dof, 0.999: agreement bound of the triangulation cross-check.
CHI2_2DOF_999 = 13.815510557964274

#: Normal quantiles of the supported confidences, for :func:`chi2_upper`.
_Z = {0.95: 1.6448536269514722, 0.99: 2.3263478740408408, 0.999: 3.090232306167813}


#: Exact 1-dof quantiles (the square of the two-sided normal quantile).
_CHI2_1DOF = {0.95: 3.841458820694124, 0.99: 6.634896601021214, 0.999: 10.827566170662733}


def chi2_upper(dof: int, confidence: float = 0.999) -> float:
    """Upper ``confidence`` quantile of a chi-square with ``dof`` degrees of freedom.

    Wilson-Hilferty cube-root approximation, ``dof (1 - a + z sqrt(a))^3`` with
    ``a = 2 / (9 dof)`` and ``z`` the normal quantile (within 2 % of the exact value
    from 3 dof on; the 1- and 2-dof values are exact). ``confidence`` is 0.95, 0.99 or 0.999.
    """
    if dof < 1:
        raise ValueError(f"dof must be >= 1, got {dof!r}")
    if confidence not in _Z:
        raise ValueError(f"confidence must be one of {sorted(_Z)}, got {confidence!r}")
    z = _Z[confidence]
    if dof == 1:
        return _CHI2_1DOF[confidence]
    if dof == 2:
        return -2.0 * math.log(1.0 - confidence)
    a = 2.0 / (9.0 * dof)
    return dof * (1.0 - a + z * math.sqrt(a)) ** 3


def corrections_drift(sums: tuple[float, ...], max_correction_m: float) -> tuple[bool, float]:
    """Whether the window's Kalman corrections add up to a drift the filter does not expect, and ``D^T C^-1 D``.

    Each update moves the estimate by ``K y``; for a consistent filter these are white with
    covariance ``P- - P+`` (``K S K^T``), so their sum ``D`` over the window has covariance
    ``C``, the sum of the decreases. ``D^T C^-1 D`` beyond the chi-square bound (2 dof,
    0.999) with ``|D|`` above ``max_correction_m`` (m) means the odometry keeps carrying the
    estimate off the bearings: wheel slip beyond the noise model. A 30 % slip burst left a
    truth-noise tricycle "tracking" 25-29 mm (5-6 sigma) off for 3 s with its NIS within
    bounds: the per-revolution corrections (7 mm, always forward) are small, their sum is
    not. ``sums``: the corrections summed in window order, ``(dx, dy, c00, c01, c11, count)``.
    The distance is NaN when it was not computed.
    """
    dx, dy, c00, c01, c11, n = sums
    if n < 8 or math.hypot(dx, dy) <= max_correction_m:
        return False, math.nan
    det = c00 * c11 - c01 * c01
    if not det > 0.0:
        return True, math.nan  # a drift beyond the floor where the filter expects none
    d2 = (c11 * dx * dx - 2.0 * c01 * dx * dy + c00 * dy * dy) / det
    return d2 > CHI2_2DOF_999, d2


def uncertainty_failures(P: np.ndarray, lost_position_std_m: float, lost_heading_std_rad: float) -> list[str]:
    """``["uncertainty"]`` when the position (largest eigenvalue of ``P``'s position block, m²) or heading
    variance (rad²) of ``P (3, 3)`` is beyond ``lost_position_std_m`` (m) or ``lost_heading_std_rad`` (rad)."""
    a, b, c = float(P[0, 0]), 0.5 * (float(P[0, 1]) + float(P[1, 0])), float(P[1, 1])
    half = 0.5 * (a - c)
    pos_var = 0.5 * (a + c) + math.sqrt(half * half + b * b)  # largest eigenvalue of [[a, b], [b, c]]
    if not (pos_var <= lost_position_std_m**2 and P[2, 2] <= lost_heading_std_rad**2):
        return ["uncertainty"]
    return []


class ReflectorNis:
    """Per map row the exponentially weighted mean of its NIS (weight 1/8) and its sightings (module docstring)."""

    def __init__(self, n: int) -> None:
        self.mean = [0.0] * n
        self.count = [0] * n

    def add(self, j: int, nis: float) -> None:
        """One finite ``nis`` of map row ``j`` (an infinite or NaN one is not counted)."""
        if -math.inf < nis < math.inf:
            n = self.count[j] + 1
            self.count[j] = n
            self.mean[j] += (nis - self.mean[j]) / min(n, 8)

    def forget(self) -> None:
        """Start afresh (after a reset or an exclusion: judge the others anew)."""
        self.mean = [0.0] * len(self.mean)
        self.count = [0] * len(self.count)

    def outlier(
        self, window_rows: list[int], n_excluded: int, max_excluded: int, min_reflectors: int,
        exclude_sigmas: float, exclude_ratio: float,
    ) -> int | None:
        """The one map row whose innovations disagree with the others' (module docstring), or None.

        ``window_rows``: the map rows of the window's reflections; ``n_excluded`` reflectors are
        excluded already. Among the rows seen 8 times or more (at least ``min_reflectors + 2``),
        the one of the largest mean beyond ``exclude_sigmas^2`` and ``exclude_ratio^2`` times
        the others' mean.
        """
        if n_excluded >= max_excluded:
            return None
        seen = [j for j in set(window_rows) if self.count[j] >= 8]  # the set's order, as before
        if len(seen) < min_reflectors + 2:
            return None
        worst = max(seen, key=lambda j: self.mean[j])
        others = sum(self.mean[j] for j in seen if j != worst) / (len(seen) - 1)
        m = self.mean[worst]
        if m > exclude_sigmas**2 and m > exclude_ratio**2 * others:
            return worst
        return None
