"""The read side of a streaming estimator: its state as arrays and what it reports.

:class:`EstimatorReadout` is the base of
:class:`~agvnav.positioning.estimator.StreamingEstimator`: the pose, covariance, status and
quality of the latest estimate, the counters of its parts and the measurement steps
(:class:`~agvnav.positioning.ekf_core.EkfStep`), read from the parts the estimator assembles
(:mod:`agvnav.positioning.estimator`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.positioning.ekf_core import EkfCore, EkfStep, RawStep, make_step
from agvnav.positioning.identification import InitialPoseResult
from agvnav.positioning.inputs import InputChecks
from agvnav.positioning.integrity import IntegrityMonitor
from agvnav.positioning.lifecycle import StartUp, status_of
from agvnav.positioning.plausibility import DropCounter, PlausibilityLimits

__all__ = ["EstimatorReadout"]


class EstimatorReadout:
    """The estimator's state and reports, read from its parts (module docstring).

    The parts are the estimator's (:class:`~agvnav.positioning.estimator.StreamingEstimator`
    sets them): ``core`` the filter core, ``monitor`` the integrity monitor, ``inputs`` the
    input checks, ``startup`` the start-up search.
    """

    core: EkfCore
    monitor: IntegrityMonitor
    inputs: InputChecks
    startup: StartUp
    dead_reckoning_after: float
    _t_last_accept: float | None
    _step: RawStep | None
    _recorder: Callable[[EkfStep], None] | None

    # ------------------------------------------------------------------ state (the core's) as arrays
    @property
    def _x_t(self) -> tuple[float, ...]:
        return self.core.x

    @_x_t.setter
    def _x_t(self, value: tuple[float, ...]) -> None:
        self.core.x = value

    @property
    def _P_t(self) -> tuple[float, ...]:
        return self.core.P

    @_P_t.setter
    def _P_t(self, value: tuple[float, ...]) -> None:
        self.core.P = value

    @property
    def _x(self) -> NDArray[np.float64]:
        return np.array(self.core.x)

    @_x.setter
    def _x(self, value: ArrayLike) -> None:
        self.core.x = tuple(np.asarray(value, dtype=np.float64).reshape(3).tolist())

    @property
    def _P(self) -> NDArray[np.float64]:
        return np.array(self.core.P).reshape(3, 3)

    @_P.setter
    def _P(self, value: ArrayLike) -> None:
        self.core.P = tuple(np.asarray(value, dtype=np.float64).reshape(9).tolist())

    @property
    def _odom(self) -> NDArray[np.float64]:
        return np.array(self.core.odom)

    # ------------------------------------------------------------------ read
    @property
    def t(self) -> float:
        """Time (s) of the latest input (NaN before the first one)."""
        return self.inputs.now

    @property
    def pose(self) -> NDArray[np.float64]:
        """``(3,)`` base_link pose ``[x, y, psi]`` in ``map`` at :attr:`t` (NaN while initialising)."""
        return self._x

    @property
    def covariance(self) -> NDArray[np.float64]:
        """``(3, 3)`` covariance of :attr:`pose` (m², rad²; NaN while initialising).

        For the fix-based estimators (``naive``, ``angle_propagation``, ``batch_ml``): the
        filter's ``P`` plus the survey floor of the reflectors that support it
        (:attr:`~agvnav.positioning.integrity.IntegrityMonitor.survey_floor`): the
        error a constant survey error of the reflectors leaves, which ``P``, taking it
        as white bearing noise, averages away. The two add (the estimate's error is the
        filter's white error plus the survey bias, independent of each other); the part
        of the survey error ``P`` still holds after averaging over ``n`` revolutions is
        about ``floor / n``, a double count on the safe side. The EKF overrides this:
        its Schmidt-Kalman consider filter carries the survey errors' correlation with
        the pose, so its ``P`` alone is the covariance (:mod:`agvnav.positioning.ekf`;
        with the floor added, 200 runs of ``guidance_test`` gave NEES 2.40, band
        2.67-3.35, the heading part 0.54 of 1: the double count).
        """
        P = self._P
        floor = self.monitor.survey_floor
        if not floor.any():
            return P
        return P + floor

    @property
    def filter_covariance(self) -> NDArray[np.float64]:
        """``(3, 3)`` the filter's own ``P`` (m², rad²), without the survey floor of :attr:`covariance`."""
        return self._P

    @property
    def status(self) -> str:
        """``"initialising"``, ``"tracking"``, ``"degraded"``, ``"dead_reckoning"`` or ``"lost"``.

        ``lost`` and ``degraded`` are the integrity monitor's verdicts (class docstring);
        ``dead_reckoning`` no accepted reflection for ``dead_reckoning_after`` seconds.
        """
        return status_of(self.core.has_pose(), self.monitor.verdict, self._dead_reckoning())

    @property
    def quality(self) -> float:
        """0-1 quality figure of the latest integrity check (0 while initialising or lost)."""
        return self.monitor.quality if self.core.has_pose() else 0.0

    @property
    def reflectors_used(self) -> int:
        """Distinct reflectors that supported the estimate over the monitor's window."""
        return self.monitor.reflectors_used

    @property
    def n_dropped(self) -> dict[str, int]:
        """Inputs dropped as implausible (``strict=False``), per reason."""
        return dict(self.inputs.drops.by_reason)

    @property
    def drops(self) -> DropCounter:
        """The dropped inputs, per reason and time (:class:`~agvnav.positioning.plausibility.DropCounter`)."""
        return self.inputs.drops

    @property
    def strict(self) -> bool:
        """Whether a bad input raises ValueError (True) or is dropped and counted."""
        return self.inputs.strict

    @property
    def plausibility(self) -> PlausibilityLimits:
        """The :class:`~agvnav.positioning.plausibility.PlausibilityLimits` of the inputs."""
        return self.inputs.plausibility

    @property
    def last_search(self) -> InitialPoseResult | None:
        """The latest start-up or relocalisation search's result."""
        return self.startup.last_search

    @property
    def ambiguous(self) -> bool:
        """Whether the latest search found several poses (and took none)."""
        return self.startup.ambiguous

    @property
    def n_relocalisations(self) -> int:
        """Relocalisations (searches that set the pose again after ``lost``)."""
        return self.startup.n_relocalisations

    @property
    def n_unreachable(self) -> int:
        """Relocalised poses refused as out of reach of the last trusted one."""
        return self.startup.n_unreachable

    @property
    def last_step(self) -> EkfStep | None:
        """The latest measurement step (:class:`~agvnav.positioning.ekf_core.EkfStep`), None before any.

        Prior and posterior pose and covariance, innovation, its variance, gain (NaN for
        the fix-based methods, which replace the pose by a fix), accepted or why not.
        """
        return None if self._step is None else make_step(self._step)

    def record_steps(self, recorder: Callable[[EkfStep], None] | None) -> None:
        """Hand every measurement step to ``recorder`` (e.g. ``list.append``); None stops recording."""
        self._recorder = recorder

    def _keep_step(self, raw: RawStep) -> None:
        self._step = raw
        if self._recorder is not None:
            self._recorder(make_step(raw))

    def _dead_reckoning(self) -> bool:
        inputs = self.inputs
        since = self._t_last_accept if self._t_last_accept is not None else inputs.t_first
        return inputs.t is not None and since is not None and inputs.t - since > self.dead_reckoning_after
