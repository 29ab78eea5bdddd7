"""Safe behaviour when positioning degrades: slow down, stop, resume (issue 12 §2).

:class:`PositioningGuard` turns the estimator's ``status`` and ``covariance`` into a
speed scale the autopilot applies to its speed profile's target:

* ``normal`` (scale 1): status ``tracking`` and 3σ of the position across the
  vehicle's heading below the slow limit;
* ``slow`` (``slow_speed_fraction``): status ``degraded`` or ``dead_reckoning``, or
  3σ lateral above ``lateral_3sigma_slow_m``;
* ``stop`` (scale 0, the profile brakes at the vehicle's deceleration limit):
  status ``lost``, ``initialising`` or any status this module does not know
  (conservative), a non-finite covariance, or 3σ lateral above
  ``lateral_3sigma_stop_m``.

A worse level applies at once; a better one only after it has been demanded
continuously for ``resume_after_s`` (hysteresis, so the vehicle does not surge on
one good fix); a demand that worsens during that hold restarts it. The lateral
standard deviation is that of the position along the body y axis,
``σ_lat² = n^T P_xy n`` with ``n = (-sin ψ, cos ψ)``: the direction in which a
guidance error puts the vehicle into the aisle's walls.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from agvnav.roles import Estimator

__all__ = [
    "GUARD_LEVELS",
    "GUARD_SIGNALS",
    "EstimatorWatch",
    "GuardLimits",
    "PositioningGuard",
    "SpeedWatch",
    "demanded_level",
    "lateral_sigma",
]

#: Guard levels, in order of severity; their index is the level code recorded in the series.
GUARD_LEVELS = ("normal", "slow", "stop")

#: Estimator statuses with their demanded level; any other status demands ``stop``.
_STATUS_LEVEL = {"tracking": 0, "degraded": 1, "dead_reckoning": 1, "lost": 2, "initialising": 2}


@dataclass(frozen=True)
class GuardLimits:
    """Thresholds of the guard (see the module docstring); lengths in m, times in s."""

    lateral_3sigma_slow_m: float = 0.10
    lateral_3sigma_stop_m: float = 0.30
    slow_speed_fraction: float = 0.3
    resume_after_s: float = 1.0

    def __post_init__(self) -> None:
        for name in ("lateral_3sigma_slow_m", "lateral_3sigma_stop_m", "slow_speed_fraction"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be a positive finite number, got {value!r}")
        if self.lateral_3sigma_stop_m < self.lateral_3sigma_slow_m:
            raise ValueError("lateral_3sigma_stop_m must be at least lateral_3sigma_slow_m")
        if self.slow_speed_fraction > 1.0:
            raise ValueError(f"slow_speed_fraction must be at most 1, got {self.slow_speed_fraction!r}")
        if not (math.isfinite(self.resume_after_s) and self.resume_after_s >= 0.0):
            raise ValueError(f"resume_after_s must be >= 0 and finite, got {self.resume_after_s!r}")


def lateral_sigma(cov: Sequence[float], psi: float) -> float:
    """Standard deviation (m) of the position across heading ``psi`` (rad).

    ``cov`` is the pose covariance flattened row-major (9 values: m², m·rad, rad²);
    ``σ_lat² = sin²ψ P_xx − 2 sinψ cosψ P_xy + cos²ψ P_yy``. NaN when the covariance
    is not finite or the variance is negative.
    """
    s, c = math.sin(psi), math.cos(psi)
    var = s * s * cov[0] - 2.0 * s * c * cov[1] + c * c * cov[4]
    return math.sqrt(var) if var >= 0.0 else math.nan


def demanded_level(status: str, lateral_3sigma: float | None, limits: GuardLimits) -> int:
    """The level (index into :data:`GUARD_LEVELS`) that ``status`` and 3σ lateral (m) demand.

    ``lateral_3sigma`` None: the estimator reports no covariance; only its status counts.
    """
    level = _STATUS_LEVEL.get(status, 2)
    if lateral_3sigma is None:
        return level
    if not math.isfinite(lateral_3sigma) or lateral_3sigma > limits.lateral_3sigma_stop_m:
        return 2
    if lateral_3sigma > limits.lateral_3sigma_slow_m:
        return max(level, 1)
    return level


class PositioningGuard:
    """Speed scale from the estimator's status and covariance, with hysteresis on recovery.

    Parameters
    ----------
    limits : the thresholds.
    enabled : False: always scale 1 (the figures are still computed).

    Attributes
    ----------
    level : current level (0 normal, 1 slow, 2 stop).
    lateral_3sigma : 3σ lateral (m) at the last update.
    """

    def __init__(self, limits: GuardLimits = GuardLimits(), enabled: bool = True) -> None:
        self.limits = limits
        self.enabled = bool(enabled)
        self.level = 0
        self.lateral_3sigma = math.nan
        self._better_since: float | None = None
        self._last_demand = 0
        self._scales = (1.0, float(limits.slow_speed_fraction), 0.0)

    def update(self, t: float, status: str, cov: Sequence[float] | None, psi: float) -> float:
        """Take the estimator's state at ``t`` (s) and return the speed scale (0..1).

        ``cov`` is the covariance flattened row-major (9 values; None for an estimator
        that reports none), ``psi`` the estimated heading (rad).
        """
        self.lateral_3sigma = math.nan if cov is None else 3.0 * lateral_sigma(cov, psi)
        if not self.enabled:
            return 1.0
        demand = demanded_level(status, None if cov is None else self.lateral_3sigma, self.limits)
        if demand >= self.level:
            self.level = demand
            self._better_since = None
        elif self._better_since is None or demand > self._last_demand:
            self._better_since = t  # the hold (re)starts: positioning got better, or worse again
        self._last_demand = demand
        if self._better_since is not None and t - self._better_since >= self.limits.resume_after_s - 1e-9:
            self.level = demand
            self._better_since = None
        return self._scales[self.level]

    @property
    def state(self) -> str:
        """The current level's name (``normal``, ``slow`` or ``stop``)."""
        return GUARD_LEVELS[self.level]


class SpeedWatch(Protocol):
    """What an autopilot asks once per step before its speed profile: a speed scale (0..1) and the signals to record.

    :class:`EstimatorWatch` (the positioning guard) is one; the reactive watch
    (:class:`agvnav.navigation.reactive.ReactiveWatch`) composes the reaction to obstacles in.
    """

    @property
    def signal_names(self) -> tuple[str, ...]:
        """Names of :meth:`signals`."""

    def scale(self, t: float, estimator: Estimator) -> float:
        """The speed scale at ``t`` (s) from the estimate."""

    def signals(self) -> tuple[float, ...]:
        """Current values of ``signal_names``."""


#: Signals a guard adds to the autopilot's recorded series (covariance entries in m², m·rad, rad²).
GUARD_SIGNALS = (
    "guard_level",
    "speed_scale",
    "lateral_3sigma_est",
    "est_cov_xx",
    "est_cov_xy",
    "est_cov_xpsi",
    "est_cov_yy",
    "est_cov_ypsi",
    "est_cov_psipsi",
    "est_quality",
    "est_reflectors_used",
    "est_n_dropped",
)


_NO_COV = [math.nan] * 9


class EstimatorWatch:
    """Reads an estimator once per step for a :class:`PositioningGuard` and keeps the recorded signals.

    ``quality`` is read when the estimator exposes one (a 0-1 figure, issue 12 §1),
    else recorded as NaN; so are ``reflectors_used`` (distinct reflectors behind the
    estimate) and the count of readings dropped as implausible so far (``drops.total``).
    """

    signal_names = GUARD_SIGNALS

    def __init__(self, guard: PositioningGuard) -> None:
        self.guard = guard
        nan = math.nan
        self._sig: tuple[float, ...] = (0.0, 1.0, nan, nan, nan, nan, nan, nan, nan, nan, nan, nan)

    def scale(self, t: float, estimator: Estimator) -> float:
        """The guard's speed scale at ``t`` (s) from ``estimator``'s status, covariance and heading."""
        P: NDArray[np.float64] | None = getattr(estimator, "covariance", None)  # a bare pose source has none
        cov = _NO_COV if P is None else P.ravel().tolist()  # floats (a float64 array's tolist)
        psi = float(estimator.pose[2])
        scale = self.guard.update(t, str(estimator.status), None if P is None else cov, psi)
        quality = _quality(estimator)
        used = getattr(estimator, "reflectors_used", None)
        drops = getattr(estimator, "drops", None)
        self._sig = (
            float(self.guard.level), scale, self.guard.lateral_3sigma,
            cov[0], cov[1], cov[2], cov[4], cov[5], cov[8], quality,
            math.nan if used is None else float(used),
            math.nan if drops is None else float(drops.total),
        )
        return scale

    def signals(self) -> tuple[float, ...]:
        """Current values of :data:`GUARD_SIGNALS`."""
        return self._sig


def _quality(estimator: Estimator) -> float:
    """The estimator's quality as a float (its ``score`` when it is a record), NaN if absent."""
    q = getattr(estimator, "quality", None)
    if q is None:
        return math.nan
    q = getattr(q, "score", q)
    try:
        return float(q)
    except (TypeError, ValueError):
        return math.nan
