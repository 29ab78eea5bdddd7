"""The stated bound of a position estimate's error (issue 31: VDA 5050 ``deviationRange``).

Three statements, each a bound that holds under its own assumption; the vehicle states the
larger of those it has (the larger of two bounds holds when either assumption does):

* **covariance** (:func:`covariance_radius`): for a consistent estimate the position error
  ``e ~ N(0, P_xy)`` satisfies ``|e|^2 <= lambda_max(P_xy) e^T P_xy^-1 e`` and
  ``e^T P_xy^-1 e`` is chi-square with 2 dof, whose survival function is ``exp(-x/2)``. So
  ``|e| > k sqrt(lambda_max(P_xy))`` with probability at most ``exp(-k^2/2)``
  (:func:`radius_k` gives ``k`` for a stated probability: 4.5 is 4e-5, 3 is 1.1e-2). It
  assumes the odometry within its noise model [seed002 eq17];
* **snapshot** (:func:`snapshot_radius`): the last head revolution's bearings alone
  (:meth:`~agvnav.positioning.integrity.IntegrityMonitor.fix`: the common offset ``dx`` of
  their innovations, truth minus estimate as the bearings see it, with its covariance
  ``C``): ``|e| <= |dx_xy| + k_fix sqrt(lambda_max(C_xy))``. It assumes sound bearings
  associated to the right reflectors, and the odometry over one revolution only: wheel slip,
  which carries a consistent filter off its bearings for 0.3-0.6 s before any check can
  tell (the filter's gain is small and the lag grows slowly; 20 % slip left the hall's
  differential AGV 25-46 mm off a 21 mm covariance bound, the monitor's checks silent), does
  not break it. ``k_fix`` is smaller than ``k``: the snapshot only has to hold when the
  covariance does not (a rare fault), so its own miss probability multiplies that of the fault.
  Stated only while the odometry moved over the last revolution (more than 1 mm): standing,
  no slip can carry the estimate off, and an odometry that reads nothing while the vehicle
  drives is what the missing reflectors reveal (the reach below); a standing vehicle keeps its
  few-mm covariance bound (``finePositioning`` judges its stop on it);
* **reach** (:func:`reach_radius`): when the estimate is in doubt -- most reflectors in sight
  missing while reflections arrive (a false lock or lock-out: the bearings that are accepted
  are self-consistent about a wrong pose, so the snapshot says nothing), the integrity
  monitor finding the reflections late (``"timing"``: an uncompensated latency stamps each
  bearing at its arrival, so the bearings agree about where the vehicle was, not where it is;
  the head clock measures the latency only modulo a revolution, so nothing the vehicle knows
  bounds it), the monitor finding the odometry carrying the estimate off its bearings
  (``"corrections"``, ``"offset"``: at the onset of a 0.15 s reflection delay the estimate was
  69 mm off a 54 mm snapshot while these two failed, a revolution before ``"timing"`` did), or
  the last revolution's offset beyond chance -- what still holds is the
  triangle inequality from the last :class:`TrustedFix` ``(t0, x0, r0)``, the latest instant
  the evidence vouched for the estimate: ``|x(t) - truth(t)| <= r0 + |x(t) - x0| +
  v_max (t - t0)`` for a vehicle that cannot drive faster than ``v_max`` (its factsheet's
  ``speedMax``), whatever its odometry says.

A fix is **trusted** (:meth:`DeviationWatch.update`) when the last revolution accepted at least
half of the reflectors in sight (and at least four: a snapshot needs them), their common
offset is within chance (chi-square 3 dof, 0.999). Neither the integrity monitor's verdict nor
the estimator's lock-out watch enters: under heavy clutter (12 spurious reflections a
revolution) the lock-out watch fired every second or two with every reflector in sight
accepted and the estimate 1-15 mm off (``fault_clutter``; counting it as doubt stated a median
bound of 0.46 m there), and a verdict ``degraded`` can last minutes while each revolution
vouches for the estimate. What the lock-out is for, an estimate off its reflectors, shows
as the reflectors in sight missing. Neither trusted nor in doubt (blind: fewer than four reflectors, no
rejections), the covariance bound stands while the monitor says ``ok`` (dead reckoning on sound
odometry is what ``P`` models), the reach otherwise.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from agvnav.positioning.integrity_raim import chi2_threshold

if TYPE_CHECKING:
    from agvnav.positioning.estimator import StreamingEstimator

__all__ = [
    "DOUBT_REASONS", "DeviationWatch", "Evidence", "TrustedFix", "covariance_radius", "radius_k", "reach_radius",
    "snapshot_radius",
]


#: The integrity monitor's failed checks (:attr:`~agvnav.positioning.integrity.IntegrityMonitor.reasons`)
#: that put the estimate in doubt: late reflections (``timing``) and odometry carrying the estimate off its
#: bearings (``corrections``, ``offset``: the covariance, built on the odometry's model, no longer holds).
DOUBT_REASONS = ("timing", "corrections", "offset")


@dataclass(frozen=True)
class TrustedFix:
    """The latest instant the evidence vouched for the estimate: ``t`` (s), the estimated position
    ``x``, ``y`` (m) and the bound ``radius`` (m) stated then."""

    t: float
    x: float
    y: float
    radius: float


@dataclass(frozen=True)
class Evidence:
    """What one instant's reflections say about the estimate (:meth:`DeviationWatch.evidence`).

    ``seen``: distinct reflectors accepted in the last revolution; ``expected``: reflectors in
    sight from the estimated pose (not excluded); ``rejected``: reflections the gate rejected in
    the last revolution; ``snapshot``: :func:`snapshot_radius` (m), NaN without a fix; ``offset_d2``: the fix's
    ``dx^T C^-1 dx`` (NaN without one).
    """

    seen: int
    expected: int
    rejected: int
    snapshot: float
    offset_d2: float


def radius_k(probability: float) -> float:
    """``k`` with ``P(|e| > k sqrt(lambda_max(P_xy))) <= probability`` for ``e ~ N(0, P_xy)`` in the plane.

    ``sqrt(-2 ln probability)``: the chi-square (2 dof) quantile's square root (module doc).
    """
    if not 0.0 < probability < 1.0:
        raise ValueError(f"probability must be in (0, 1), got {probability!r}")
    return math.sqrt(-2.0 * math.log(probability))


def _largest_eigenvalue(p00: float, p01: float, p11: float) -> float:
    half = 0.5 * (p00 - p11)
    return 0.5 * (p00 + p11) + math.sqrt(half * half + p01 * p01)


def covariance_radius(P_xy: ArrayLike, k: float) -> float:
    """``k sqrt(lambda_max(P_xy))`` (m) of a ``(2, 2)`` position covariance (m²); NaN if it is not finite."""
    P = np.asarray(P_xy, dtype=np.float64)
    if P.shape != (2, 2):
        raise ValueError(f"P_xy must have shape (2, 2), got {P.shape}")
    if not np.all(np.isfinite(P)):
        return math.nan
    lam = _largest_eigenvalue(float(P[0, 0]), 0.5 * float(P[0, 1] + P[1, 0]), float(P[1, 1]))
    return float(k * math.sqrt(max(lam, 0.0)))


def snapshot_radius(dx: ArrayLike, C: ArrayLike, k: float) -> float:
    """``|dx_xy| + k sqrt(lambda_max(C_xy))`` (m): the bound one revolution's bearings give (module doc).

    ``dx (3,)`` the common offset of their innovations (m, m, rad), ``C (3, 3)`` its covariance.
    """
    d = np.asarray(dx, dtype=np.float64).reshape(-1)
    return math.hypot(float(d[0]), float(d[1])) + covariance_radius(np.asarray(C, dtype=np.float64)[:2, :2], k)


def reach_radius(anchor: TrustedFix, x: float, y: float, t: float, max_speed: float) -> float:
    """Bound (m) of the error at ``t`` (s) of the estimate ``(x, y)`` (m) from the last trusted fix.

    ``r0 + |(x, y) - (x0, y0)| + max_speed (t - t0)``, ``max_speed`` in m/s: the triangle
    inequality of the module doc.
    """
    if not max_speed >= 0.0:
        raise ValueError(f"max_speed must be >= 0 m/s, got {max_speed!r}")
    return anchor.radius + math.hypot(x - anchor.x, y - anchor.y) + max_speed * max(t - anchor.t, 0.0)


class DeviationWatch:
    """The stated bound of one estimator's position error, fed at every step (module doc).

    Parameters
    ----------
    max_speed:
        The speed (m/s) the vehicle cannot exceed (the reach).
    k:
        Sigmas of the covariance bound (4.5: 4e-5 for a consistent estimate).
    k_fix:
        Sigmas of the snapshot bound (3: 1.1e-2, only needed while the covariance fails).
    min_seen_fraction:
        Fraction of the reflectors in sight the last revolution must have accepted for a
        trusted fix (below it, with rejections arriving, the estimate is in doubt).
    """

    def __init__(self, max_speed: float, k: float = 4.5, k_fix: float = 3.0, min_seen_fraction: float = 0.5) -> None:
        if not (max_speed > 0.0 and k > 0.0 and k_fix > 0.0 and 0.0 < min_seen_fraction <= 1.0):
            raise ValueError(f"max_speed, k, k_fix must be > 0 and min_seen_fraction in (0, 1], got {max_speed!r}, "
                             f"{k!r}, {k_fix!r}, {min_seen_fraction!r}")
        self.max_speed, self.k, self.k_fix, self.min_seen_fraction = max_speed, k, k_fix, min_seen_fraction
        self.anchor: TrustedFix | None = None
        self.in_doubt = False
        self.trusted = False
        self._offset_bound = chi2_threshold(3, 1e-3)
        self._odometry: deque[tuple[float, float, float]] = deque()  # (t, x, y) of the odometric pose, a revolution

    def odometry_moved(self, est: StreamingEstimator) -> float:
        """How far (m) the odometric pose moved over the last revolution (records it; the snapshot's gate)."""
        t, (ox, oy, _) = est.t, est.core.odom
        q = self._odometry
        q.append((t, ox, oy))
        while len(q) > 1 and t - q[1][0] >= est.monitor.revolution_s:
            q.popleft()
        return math.hypot(ox - q[0][1], oy - q[0][2])

    def evidence(self, est: StreamingEstimator) -> Evidence:
        """What the last revolution's reflections say about ``est``'s estimate (:class:`Evidence`)."""
        m = est.monitor
        t = est.t
        seen, expected, rejected = m.explained(t, est.pose)
        fix = m.fix(t)
        snap, d2 = math.nan, math.nan
        if fix is not None:
            dx, C, _ = fix
            snap = snapshot_radius(dx, C, self.k_fix)
            d2 = float(dx @ np.linalg.solve(C, dx))
        return Evidence(seen, expected, rejected, snap, d2)

    def update(self, est: StreamingEstimator) -> float | None:
        """The bound (m) of ``est``'s position error now; None while it has no pose or is lost.

        Missing reflectors count as doubt only with at least three rejections in the revolution
        (reflections arrive that fit nowhere: a blind head or a removed reflector rejects none,
        and a blind head is what ``P``'s dead reckoning models); the snapshot only with the
        odometry moved more than 1 mm in the revolution (module doc).
        """
        if est.status in ("initialising", "lost"):
            self.anchor, self.in_doubt, self.trusted = None, True, False
            return None
        x, y = (float(c) for c in est.pose[:2])
        cov = covariance_radius(np.asarray(est.covariance)[:2, :2], self.k)
        if math.isnan(cov):
            return None
        ev = self.evidence(est)
        moving = self.odometry_moved(est) > 1e-3
        missing = ev.rejected >= 3 and ev.seen < self.min_seen_fraction * ev.expected
        disagree = any(r in est.monitor.reasons for r in DOUBT_REASONS)
        self.in_doubt = missing or disagree or ev.offset_d2 > self._offset_bound
        mostly = ev.seen >= max(4, math.ceil(self.min_seen_fraction * ev.expected))
        self.trusted = not self.in_doubt and mostly and not math.isnan(ev.snapshot) and est.status != "dead_reckoning"
        here = max(cov, ev.snapshot) if moving and not math.isnan(ev.snapshot) else cov
        if self.trusted:
            self.anchor = TrustedFix(est.t, x, y, here)
            return here
        if not self.in_doubt and est.monitor.verdict == "ok":
            return here
        if self.anchor is None:
            return None
        return max(cov, reach_radius(self.anchor, x, y, est.t, self.max_speed))
