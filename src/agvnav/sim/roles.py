"""The goniometer as a sensor role of the closed loop, the same for every vehicle.

Wiring only: :class:`GoniometerSensor` scans with :class:`agvnav.sensors.goniometer.Goniometer`
against the true world along the true motion and hands each reflection to the estimator it
was wired to (a :class:`agvnav.roles.BearingEstimator`). The autopilots a vehicle runs are in
:mod:`agvnav.navigation`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from agvnav.roles import BearingEstimator, PoseFunction
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import WorldMap

__all__ = ["GoniometerSensor"]


class GoniometerSensor:
    """The laser goniometer as a closed-loop sensor: scans along the true motion.

    ``estimator`` takes the reflections (None: positioning does not use the goniometer, e.g. a
    run that dead-reckons on purpose; the reflections are still observed and recorded).
    """

    name = "reflections"
    event_names: tuple[str, ...] = ("t", "bearing", "reflector_index")

    def __init__(self, goniometer: Goniometer, world: WorldMap, estimator: BearingEstimator | None) -> None:
        self.goniometer = goniometer
        self.world = world
        self.estimator = estimator

    def observe(self, pose_at: PoseFunction, t0: float, t1: float, rng: np.random.Generator) -> NDArray[np.float64]:
        """Reflections in ``(t0, t1]`` as rows ``(t, bearing, true reflector index)``."""
        rows: NDArray[np.float64] = self.goniometer.scan_rows(self.world, pose_at, t0, t1, rng)
        return rows

    def deliver(self, event: NDArray[np.float64]) -> None:
        """One anonymous reflection ``(t, bearing)`` to the estimator (the index is truth, never read)."""
        if self.estimator is not None:
            self.estimator.update(float(event[0]), float(event[1]))
