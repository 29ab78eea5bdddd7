"""The thresholds of the integrity monitor (:class:`~agvnav.positioning.integrity.IntegrityMonitor`).

Each threshold belongs to one check; the check's module says why it is set where it is:
:mod:`~agvnav.positioning.integrity_nis` (NIS, corrections, per-reflector exclusion, uncertainty),
:mod:`~agvnav.positioning.integrity_support` (rejections, explained reflectors, timing, count and
geometry), :mod:`~agvnav.positioning.integrity_crosscheck`, :mod:`~agvnav.positioning.integrity_raim`,
:mod:`~agvnav.positioning.integrity_offset`, :mod:`~agvnav.positioning.integrity_drift` and
:mod:`~agvnav.positioning.integrity_verdict` (recovery, lost, inflation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from agvnav.positioning.integrity_nis import CHI2_2DOF_999, chi2_upper

__all__ = ["IntegrityLimits"]


@dataclass(frozen=True)
class IntegrityLimits:
    """Thresholds of :class:`~agvnav.positioning.integrity.IntegrityMonitor` (lengths m, angles rad, times s).

    ``enabled=False`` keeps the figures (quality, NIS ratio...) but never leaves ``"ok"``.
    ``recover_s``: passing checks needed before ``degraded`` returns to ``ok``;
    ``max_latency_s``: stamp latency the timing check tolerates; ``exclude_sigmas``,
    ``exclude_ratio``, ``max_excluded``: the exclusion of an inconsistent reflector
    (``max_excluded = 0`` disables it); ``raim_false_alarm``: probability per check
    that the leave-one-out test (:meth:`~agvnav.positioning.integrity.IntegrityMonitor.raim`) fails on a sound
    revolution, ``raim_confirm``: failing checks of one episode that must name a reflector
    (more often than any other) before it is excluded; ``attribute``: the RAIM also sees the
    gated-out reflections that only one reflector, unseen in that sweep, explains within the
    attribution gate (:meth:`~agvnav.positioning.integrity.IntegrityMonitor.attribution_gate`,
    :meth:`~agvnav.positioning.integrity.IntegrityMonitor.attributed`).
    See the check modules (this module's docstring).
    """

    window_s: float = 1.0
    nis_confidence: float = 0.999
    min_reflectors: int = 3
    max_fix_std_m: float = 0.05
    crosscheck_bound: float = CHI2_2DOF_999
    crosscheck_min_m: float = 0.05
    max_correction_m: float = 0.02
    max_reject_fraction: float = 0.75
    min_rejections: int = 8
    min_explained_fraction: float = 0.5
    lost_after_s: float = 5.0
    lost_position_std_m: float = 0.3
    lost_heading_std_rad: float = 0.1
    inflation: float = 4.0
    recover_s: float = 1.0
    max_latency_s: float = 0.01
    exclude_sigmas: float = 1.75
    exclude_ratio: float = 3.0
    max_excluded: int = 2
    raim_false_alarm: float = 1e-5
    raim_confirm: int = 3
    attribute: bool = True
    enabled: bool = True

    def __post_init__(self) -> None:
        if not 0.0 <= self.min_explained_fraction <= 1.0:
            raise ValueError(f"min_explained_fraction must be in [0, 1], got {self.min_explained_fraction!r}")
        if not 0.0 < self.max_reject_fraction <= 1.0:
            raise ValueError(f"max_reject_fraction must be in (0, 1], got {self.max_reject_fraction!r}")
        for name in ("window_s", "max_fix_std_m", "crosscheck_bound", "crosscheck_min_m", "max_correction_m",
                     "lost_after_s",
                     "lost_position_std_m", "lost_heading_std_rad", "max_latency_s", "exclude_sigmas",
                     "exclude_ratio"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"{name} must be a positive finite number, got {v!r}")
        if not self.inflation >= 1.0:
            raise ValueError(f"inflation must be >= 1, got {self.inflation!r}")
        if self.min_reflectors < 1:
            raise ValueError(f"min_reflectors must be >= 1, got {self.min_reflectors!r}")
        if not (math.isfinite(self.recover_s) and self.recover_s >= 0.0):
            raise ValueError(f"recover_s must be a non-negative finite number, got {self.recover_s!r}")
        if self.max_excluded < 0:
            raise ValueError(f"max_excluded must be >= 0, got {self.max_excluded!r}")
        if not 0.0 < self.raim_false_alarm < 0.5:
            raise ValueError(f"raim_false_alarm must be in (0, 0.5), got {self.raim_false_alarm!r}")
        if self.raim_confirm < 1:
            raise ValueError(f"raim_confirm must be >= 1, got {self.raim_confirm!r}")
        chi2_upper(1, self.nis_confidence)
