"""The streaming estimator's supervision: start, loss, lock-out, and its integrity monitor (issue 12).

:class:`EstimatorSupervision` is the base of
:class:`~agvnav.positioning.estimator.StreamingEstimator` (itself on
:class:`~agvnav.positioning.readout.EstimatorReadout`): the lifecycle of the estimate -- start
from a given pose or the start-up search, loss of a broken state, the lock-out watch
(:mod:`agvnav.positioning.lifecycle`) -- and the wiring of the
:class:`~agvnav.positioning.integrity.IntegrityMonitor`. The estimator hands the monitor every
accepted reflection with, for the EKF, its Kalman correction (:func:`correction_of`) and
innovation (:func:`innovation_of`), and the rejected reflections that one unseen reflector
explains (:func:`attribute`); once per revolution the monitor judges the estimate
(:func:`watch`), and the estimator takes back the inflation of ``P``, the drift noise and the
exclusions.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite
from agvnav.geometry import wrap_angle
from agvnav.positioning import _fast
from agvnav.positioning.association import BearingAssociation
from agvnav.positioning.ekf_core import ConsiderState, EkfCore
from agvnav.positioning.integrity import IntegrityMonitor
from agvnav.positioning.lifecycle import LockoutWatch
from agvnav.positioning.plausibility import sound_state
from agvnav.positioning.readout import EstimatorReadout

__all__ = ["EstimatorSupervision", "attribute", "correction_of", "innovation_of", "watch"]


class EstimatorSupervision(EstimatorReadout):
    """Lifecycle and integrity of the estimate, over the estimator's parts (module docstring).

    The parts and settings are the estimator's
    (:class:`~agvnav.positioning.estimator.StreamingEstimator` sets them).
    """

    method: ClassVar[str] = "base"
    consider: ClassVar[bool] = False
    association: BearingAssociation
    lockout: LockoutWatch
    survey_std: NDArray[np.float64]
    n_inflations: int
    _calibration_var: tuple[float, float]

    def _new_consider(self) -> ConsiderState | None:
        """A fresh consider state (``P_xp = 0``, ``P_xc = 0``) for a consider filter, else None."""
        if not self.consider:
            return None
        return ConsiderState((self.survey_std**2).tolist(), self._calibration_var != (0.0, 0.0))

    # ------------------------------------------------------------------ lifecycle
    def _judge_state(self, t: float) -> None:
        """After every call: a pose and covariance that are not sound make the estimator ``"lost"``.

        Sound: a finite pose and a finite, symmetric, positive-definite ``P``
        (:func:`~agvnav.positioning.plausibility.sound_state`). The inputs are checked before
        they reach the state, so this is the last line: whatever still broke the state
        (rounding in an update of an extreme ``P``) never leaves a usable status over it. Lost,
        the estimator stops correcting and relocalises (class docstring); the event is
        counted in :attr:`n_dropped` as ``"broken_state"`` (never raised: it is no input).
        """
        if sound_state(self.core.x, self.core.P) or not self.core.has_pose() or self.monitor.verdict == "lost":
            return
        self._lose(t, "broken_state")

    def _lose(self, t: float, reason: str) -> None:
        """Make the verdict ``"lost"`` for ``reason``, counted in :attr:`n_dropped` (see :meth:`_judge_state`)."""
        self.inputs.drops.drop(t, reason)
        self.monitor.verdict = "lost"
        self.monitor.reasons = (reason,)
        self.monitor.quality = 0.0
        self.startup.buffer.clear()

    def _watch_lockout(self, t: float, accepted: bool) -> None:
        """Inflate ``P`` x4 on a lock-out (:meth:`~agvnav.positioning.lifecycle.LockoutWatch.inflated`, counted in
        :attr:`n_inflations`) and judge the estimate now, not a revolution later."""
        P = self.lockout.inflated(t, accepted, self.core.P)
        if P is not None:
            self.core.P = P
            self.n_inflations += 1
            self._watch_integrity(t, force=True)  # judge the estimate now, not a revolution later
            self.lockout.clear()

    def _start(self, pose: ArrayLike, covariance: ArrayLike | None) -> None:
        x = require_finite("initial_pose", pose)
        if x.shape != (3,):
            raise ValueError(f"initial_pose must have shape (3,), got {x.shape}")
        P = np.diag([0.05, 0.05, 0.02]) ** 2 if covariance is None else require_finite("initial_covariance", covariance)
        if P.shape != (3, 3):
            raise ValueError(f"initial_covariance must have shape (3, 3), got {P.shape}")
        self._x = (x[0], x[1], wrap_angle(x[2]))
        self._P = 0.5 * (P + P.T)
        self.core.consider = self._new_consider()  # a new start is independent of the survey errors
        self._t_last_accept = self.inputs.t  # None before the first input: counted from the first one
        self.monitor.reset()
        self.association.reset_claims(self.monitor.excluded)
        self.lockout.clear()

    def _try_start(self) -> None:
        """Start-up search once a full revolution of reflections at standstill is buffered."""
        result = self.startup.search(relocalising=self.core.has_pose())
        if result is not None:
            self._start(result.pose, result.covariance + np.diag([1e-6, 1e-6, 1e-8]))
            self._on_start()

    def _on_start(self) -> None:
        """Called once the start-up search has set the pose (a fix-based method drops its buffer)."""

    def _consider_args(self, f02: float, f12: float) -> Any:
        """``(M, C, svar)`` for :func:`~agvnav.positioning._fast.gate_one`, ``M`` moved by ``F(f02, f12)``.

        None without consider parameters.
        """
        c = self.core.consider
        if c is None:
            return None
        M = c.M if f02 == 0.0 and f12 == 0.0 else _fast.shear(c.M, f02, f12)
        return M, c.C, c.svar

    def _attribute(self, t: float, z: float) -> None:
        """A rejected bearing for the monitor's RAIM (:func:`~agvnav.positioning.estimator_integrity.attribute`;
        EKF only: the RAIM judges Kalman innovations)."""
        if self.method == "ekf":
            attribute(self.monitor, self.association, self.core, t, z, self._consider_args(0.0, 0.0))

    # ------------------------------------------------------------------ integrity (issue 12)
    def _watch_integrity(self, t: float, force: bool = False) -> None:
        """Once per revolution, or now with ``force``: the monitor's check, its inflation, drift noise and
        exclusions taken back (:func:`~agvnav.positioning.estimator_integrity.watch`)."""
        core = self.core
        if not core.has_pose() or self.monitor.verdict == "lost" or not (force or self.monitor.due(t)):
            return
        if watch(self.monitor, core, self.association, t, self._dead_reckoning()):
            self.n_inflations += 1

    def apply_exclusions(self) -> None:
        """Never associate the reflectors the monitor excluded (claimed forever: outside every sweep)."""
        self.association.exclude(self.monitor.excluded)

    def _correction(
        self, x0: tuple[float, ...], P0: tuple[float, ...]
    ) -> tuple[float, float, float, float, float] | None:
        """The last update's position correction and covariance decrease (the EKF's), for the monitor."""
        return correction_of(x0, P0, self.core.x, self.core.P) if self.method == "ekf" else None

    def _innovation(self, y: float, S: float, H: ArrayLike) -> tuple[float, float, float, float, float] | None:
        """The update's innovation, its variance and Jacobian row for the monitor's RAIM (EKF only)."""
        return innovation_of(y, S, H) if self.method == "ekf" else None


def watch(
    monitor: IntegrityMonitor, core: EkfCore, association: BearingAssociation, t: float, dead_reckoning: bool,
) -> bool:
    """The monitor's check at ``t`` (s) on the core's estimate; True when it inflated ``P``.

    An inflation multiplies ``P`` by ``limits.inflation``. In a drift episode the monitor also
    hands the position noise of the measured drift
    (:attr:`~agvnav.positioning.integrity.IntegrityMonitor.drift_noise`, m²), added to
    ``P``'s position block as process noise (the consider cross-covariances stay: the
    noise is independent of the survey errors). The reflectors the check excluded are
    never associated again (:meth:`BearingAssociation.exclude`).
    """
    n_excluded = len(monitor.excluded)
    inflated = monitor.check(t, np.array(core.x), np.array(core.P).reshape(3, 3), core.odom, dead_reckoning)
    if inflated:
        k = monitor.limits.inflation
        core.P = tuple(k * v for v in core.P)
    q00, q01, q11 = monitor.drift_noise
    if q00 or q11:
        P = list(core.P)
        P[0] += q00
        P[1] += q01
        P[3] += q01
        P[4] += q11
        core.P = tuple(P)
    if len(monitor.excluded) != n_excluded:
        association.exclude(monitor.excluded)
    return inflated


def correction_of(
    x0: Sequence[float], P0: Sequence[float], x1: Sequence[float], P1: Sequence[float]
) -> tuple[float, float, float, float, float]:
    """An update's position correction ``(dx, dy)`` (m) and covariance decrease ``P0 - P1`` as ``(00, 01, 11)`` (m²).

    ``x0``, ``P0`` (row-major ``(9,)``) the prior, ``x1``, ``P1`` the posterior.
    """
    return (x1[0] - x0[0], x1[1] - x0[1], P0[0] - P1[0], P0[1] - P1[1], P0[4] - P1[4])


def innovation_of(y: float, S: float, H: ArrayLike) -> tuple[float, float, float, float, float]:
    """The update's innovation ``y`` (rad), its variance ``S`` (rad²) and Jacobian row ``H (3,)``, for the RAIM."""
    h = np.asarray(H, dtype=np.float64).reshape(-1)
    return (float(y), float(S), float(h[0]), float(h[1]), float(h[2]))


def attribute(
    monitor: IntegrityMonitor, association: BearingAssociation, core: EkfCore, t: float, z: float,
    consider: Any,
) -> None:
    """Hand the monitor a rejected bearing ``z`` (rad) at ``t`` (s) that one unseen reflector explains.

    The association part's attribution gate
    (:meth:`~agvnav.positioning.association.BearingAssociation.attribution`) widened to the
    monitor's (:meth:`~agvnav.positioning.integrity.IntegrityMonitor.attribution_gate`);
    the reflection is that reflector's sighting for the RAIM only
    (:meth:`~agvnav.positioning.integrity.IntegrityMonitor.attributed`). ``consider``: the
    consider arguments of the gate (None without consider parameters).
    """
    if not monitor.limits.attribute:
        return
    found = association.attribution(t, z, core.x, core.P, monitor.attribution_gate, consider)
    if found is not None:
        j, y, S, H = found
        monitor.attributed(t, j, (float(y), float(S), float(H[0]), float(H[1]), float(H[2])))
