"""Integrity: the verdict (``"ok"``, ``"degraded"``, ``"lost"``), the quality figure and the inflation of ``P``.

A failed check makes the verdict ``degraded`` and asks the estimator to inflate its
covariance (the estimate says it is less sure; not for a RAIM failure that names a reflector,
and always on an exclusion: :mod:`agvnav.positioning.integrity_raim`; :func:`inflates`); the
verdict returns to ``ok`` only after ``recover_s`` seconds of passing checks (a full window of
fresh innovations after an inflation: without it a persistent fault that each inflation hides
for one revolution flips the status between ``tracking`` and ``degraded``). A failure of the
cross-check alone is not held (:func:`failed_at`): one triple of one revolution is a thin basis
(before its bearings carried the odometry error of their propagation it failed on about 6 % of
the checks of the sound differential_loop run, fix and estimate 5-14 cm apart, and holding
each for ``recover_s`` kept that vehicle slow until its time ran out); a verdict ``degraded``
by failing checks for longer than ``lost_after_s``, or a position or heading uncertainty
beyond what the bearing gate can identify reflectors with (``lost_position_std_m``,
``lost_heading_std_rad``: ``"uncertainty"``), makes it ``lost`` (:func:`verdict_of`): the
estimator then stops correcting and relocalises. An open drift episode
(:mod:`agvnav.positioning.integrity_drift`) holds ``degraded`` with its checks passing, not
counted towards ``lost_after_s``.
"""

from __future__ import annotations

import math
from collections.abc import Collection

from agvnav.positioning.integrity_limits import IntegrityLimits

__all__ = ["failed_at", "inflates", "score", "verdict_of"]

#: Failed checks that ask for an inflation of ``P`` (the estimate may be off).
_SUSPECT = frozenset({"nis", "crosscheck", "rejections", "unexplained", "corrections", "raim", "offset"})
#: Failed checks that halve the quality figure.
_BAD = frozenset({"geometry", "crosscheck", "rejections", "unexplained", "timing", "corrections", "raim", "offset"})


def failed_at(t: float, reasons: Collection[str], previous: float) -> float:
    """The last check (s) that failed and is held: ``t`` unless no check or only the cross-check failed."""
    return t if set(reasons) - {"crosscheck"} else previous


def verdict_of(
    t: float, reasons: Collection[str], last_failed: float, degraded_since: float | None, drifting: bool,
    limits: IntegrityLimits,
) -> tuple[str, float | None]:
    """The verdict at ``t`` (s) and the start (s) of the failing stretch (None when none is open).

    ``last_failed``: the last held failure (:func:`failed_at`); ``degraded_since``: the
    previous start; ``drifting``: a drift episode is open.
    """
    if "uncertainty" in reasons:
        return "lost", degraded_since
    if reasons or t - last_failed < limits.recover_s:
        since = t if degraded_since is None else degraded_since
        return ("lost" if t - since > limits.lost_after_s else "degraded"), since
    if drifting:  # held by the drift model: consistent checks, so not counted towards lost_after_s
        return "degraded", None
    return "ok", None


def inflates(reasons: Collection[str], raim_named: bool, excluded_now: bool, verdict: str) -> bool:
    """Whether the estimator should inflate ``P`` (and the monitor judge it on fresh innovations).

    A failed check that says the estimate may be off, not a RAIM failure that named a
    reflector (a measurement fault: exclude the reflector, do not widen the gates for it);
    always on an exclusion (``excluded_now``), which leaves the estimate with the pull of the
    excluded reflector's past updates that ``P`` does not hold: inflated, the sound
    reflectors take it back (its gates no longer admit it). Never when ``lost``.
    """
    suspect = _SUSPECT - {"raim"} if raim_named else _SUSPECT
    return (excluded_now or bool(suspect.intersection(reasons))) and verdict != "lost"


def score(verdict: str, reflectors_used: int, nis_ratio: float, reasons: Collection[str]) -> float:
    """0-1: reflectors (4 or more count fully) x innovation consistency x geometry and cross-check."""
    if verdict == "lost":
        return 0.0
    q_count = min(reflectors_used, 4) / 4.0
    ratio = nis_ratio if math.isfinite(nis_ratio) else 1.0
    q_nis = 1.0 / (1.0 + max(0.0, 2.0 * ratio - 1.0) ** 2) if ratio > 0.5 else 1.0
    q_check = 0.5 if _BAD & set(reasons) or verdict == "degraded" else 1.0
    return q_count * q_nis * q_check
