"""The roles of the closed loop as Protocols: what every part of a run promises the others.

docs/ARCHITECTURE.md ("Role contracts") describes them. They live at the lowest layer, beside
no implementation, because every layer meets them: the truth vehicles (:mod:`agvnav.vehicles`)
are :class:`Plant`\\ s, the streaming estimators (:mod:`agvnav.positioning`) are
:class:`Estimator`\\ s, the autopilots a vehicle runs (:mod:`agvnav.navigation`) read an
:class:`Estimator` and are :class:`Autopilot`\\ s, and the engine and its sensor roles
(:mod:`agvnav.sim`) wire them. A Protocol here lets each of them be checked by mypy against
the contract without importing the layer that implements the other side.

Measurements come in kinds, one protocol each: a :class:`BearingEstimator` takes the
goniometer's anonymous bearings (``update``), a :class:`RangeEstimator` the ultrasonic
rangers' readings (``update_ranges``). An EKF with rangers is both; the wall-landmark
localizer only the second; a sensor role is given the estimator of its kind when it is wired.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "Autopilot",
    "BearingEstimator",
    "Estimator",
    "Plant",
    "PoseFunction",
    "RangeEstimator",
    "Sensor",
    "SteeringReading",
]

#: ``pose_at(t (k,)) -> (k, 3)``: the true base_link pose at instants inside the last step (m, m, rad).
PoseFunction = Callable[[NDArray[np.float64]], NDArray[np.float64]]


class Plant(Protocol):
    """Truth vehicle with its proprioceptive sensors (encoders); :mod:`agvnav.vehicles` implements it."""

    @property
    def family(self) -> str:
        """``"steered"``, ``"unicycle"`` or ``"holonomic"``: the form of the command (docs/ARCHITECTURE.md)."""

    @property
    def signal_names(self) -> tuple[str, ...]:
        """Names of :meth:`signals`, starting ``x, y, psi``."""

    @property
    def geometry(self) -> object:
        """The nominal geometry record the autopilot reads (:mod:`agvnav.vehicles.geometry`)."""

    @property
    def footprint(self) -> NDArray[np.float64]:
        """Body polygon ``(k, 2)`` in base_link (m)."""

    @property
    def pose(self) -> NDArray[np.float64]:
        """True base_link pose ``(3,)`` now (m, m, rad): truth, read by the simulator's watches only."""

    def advance(self, command: Sequence[float], t0: float, dt: float, rng: np.random.Generator) -> None:
        """Apply ``command`` (vehicle-specific, e.g. ``(v, gamma_dot)``) from ``t0`` for ``dt`` s."""

    def pose_at(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """True base_link pose ``(k, 3)`` at instants ``t (k,)`` inside the last step."""

    def odometry(self) -> tuple[float, float, float]:
        """Measured body-twist increment ``(delta_d, delta_theta, delta_lateral)`` of base_link over the last step."""

    def failure(self) -> str | None:
        """A physical failure that ends the run (e.g. ``"jackknife"``), else None."""

    def signals(self) -> tuple[float, ...]:
        """Current values of ``signal_names`` (truth and raw sensor readings)."""


@runtime_checkable
class SteeringReading(Protocol):
    """A steered vehicle's measured steering angle ``gamma_meas`` (rad): proprioceptive, read by its autopilot."""

    gamma_meas: float


class Estimator(Protocol):
    """Streaming positioning: odometry in, the estimate out (:mod:`agvnav.positioning`)."""

    def predict(self, t: float, delta_d: float, delta_theta: float, delta_lateral: float = 0.0) -> None:
        """Dead-reckon to ``t`` (s) with the body-twist increment (m, rad, m)."""

    @property
    def t(self) -> float:
        """Time (s) of the estimate."""

    @property
    def pose(self) -> NDArray[np.float64]:
        """Estimated base_link pose ``(3,)`` (m, m, rad); NaN before a fix."""

    @property
    def covariance(self) -> NDArray[np.float64]:
        """Covariance ``(3, 3)`` of :attr:`pose` (m², m·rad, rad²)."""

    @property
    def status(self) -> str:
        """``initialising``, ``tracking``, ``degraded``, ``dead_reckoning`` or ``lost``."""


class BearingEstimator(Estimator, Protocol):
    """An estimator of the goniometer's anonymous reflections."""

    def update(self, t: float, bearing: float) -> object:
        """One bearing (rad, head frame) measured at ``t`` (s); a bad one is dropped and counted."""


class RangeEstimator(Estimator, Protocol):
    """An estimator of ultrasonic wall ranges [seed004 eq6] [seed004 eq7] [seed004 eq8]."""

    def update_ranges(self, t: float, ranges: Mapping[str, float]) -> object:
        """The readings (m) of the sensors that pinged at ``t`` (s), by sensor name."""


class Sensor(Protocol):
    """An exteroceptive sensor: scans a time window along the true motion.

    It is wired to the estimator of its kind (or to none, when positioning does not use it)
    and hands each of its events to it.
    """

    @property
    def name(self) -> str:
        """The name its events are recorded under."""

    @property
    def event_names(self) -> tuple[str, ...]:
        """Columns of an event row, ``t`` first."""

    def observe(self, pose_at: PoseFunction, t0: float, t1: float, rng: np.random.Generator) -> NDArray[np.float64]:
        """Events in ``(t0, t1]`` as rows ``(k, len(event_names))``, column 0 the time, in time order."""

    def deliver(self, event: NDArray[np.float64]) -> None:
        """Feed one event row to the estimator the sensor was wired to."""


class Autopilot(Protocol):
    """Guidance law plus actuators: estimate and readings -> physical command."""

    @property
    def signal_names(self) -> tuple[str, ...]:
        """Names of :meth:`signals`."""

    @property
    def finished(self) -> bool:
        """True once the autopilot has completed its task (read only for the loop)."""

    def command(self, t: float, estimator: Estimator, plant: Plant, dt: float) -> Sequence[float]:
        """Command to hold over the next step."""

    def signals(self) -> tuple[float, ...]:
        """Current values of ``signal_names`` (commands, estimated errors...)."""
