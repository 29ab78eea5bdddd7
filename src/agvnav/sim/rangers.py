"""The ultrasonic rangers as a sensor role of the closed loop, on any vehicle.

Wiring only: the rangers are :class:`agvnav.sensors.ultrasonic.UltrasonicArray`
(HY-SRF05-like cones, seed 004 §II-B), simulated exactly against the map's
walls along the true motion; each instant's readings go to the ``update_ranges`` of the
estimator it was wired to (a :class:`agvnav.roles.RangeEstimator`: the seed-004 wall-landmark rule of
:class:`~agvnav.positioning.wall_landmarks.WallLandmarkLocalizer`, or the
EKF's range update); with none (an estimator that positions without ranges) they are only
observed and recorded, for the reaction to obstacles.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import compose
from agvnav.roles import PoseFunction, RangeEstimator
from agvnav.sensors.ultrasonic import UltrasonicArray, cone_echo

__all__ = ["UltrasonicSensorRole"]


class UltrasonicSensorRole:
    """The ultrasonic array as a closed-loop sensor: every ping in ``(t0, t1]`` along the true motion.

    ``observe`` casts all pings of the window in one batched :func:`cone_echo`
    call and adds the sensor model's noise and dropouts (one normal and one
    uniform draw per ping, in time then sensor order). Rows are ``(t,
    range_0, ..., range_{S-1})`` grouped by instant (see :meth:`observe`).
    ``deliver`` hands the readings of one instant to the estimator it was wired to
    (``update_ranges``), which the engine has predicted up to that
    instant first. A run that does not use the landmarks leaves this role out.
    """

    name = "ultrasonic"

    def __init__(
        self, array: UltrasonicArray, segments: NDArray[np.float64], estimator: RangeEstimator | None = None
    ) -> None:
        self.array = array
        self.estimator = estimator
        self.segments = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
        sensors = [array[n] for n in array.names]
        self.names = array.names
        self.event_names = ("t", *array.names)
        self._mount = np.array([s.mount for s in sensors])
        self._p = {a: np.array([getattr(s, a) for s in sensors]) for a in (
            "half_angle", "max_incidence", "min_range", "max_range", "optimal_max", "noise_std", "noise_growth",
            "p_miss")}
        self._sensors = sensors

    def observe(self, pose_at: PoseFunction, t0: float, t1: float, rng: np.random.Generator) -> NDArray[np.float64]:
        """Rows ``(t, range_0, ..., range_{S-1})`` per ping instant in ``(t0, t1]``, in ``names`` order.

        A sensor that does not ping at that instant has ``inf``; a ping without a
        valid echo ``nan``. Sensors pinging together (same phase) share a row, so
        the automaton sees them as one simultaneous reading.
        """
        n_s = len(self.names)
        times, index = [], []
        for i, s in enumerate(self._sensors):
            pt = s.ping_times(t0, t1)
            times.extend(pt.tolist())
            index.extend([i] * pt.size)
        if not times:
            return np.zeros((0, 1 + n_s))
        order = np.lexsort((np.array(index), np.array(times)))
        t = np.array(times)[order]
        idx = np.array(index, dtype=np.int64)[order]
        ranges = self._measure(pose_at, t, idx, rng)
        instants, row = np.unique(t, return_inverse=True)
        out = np.full((instants.size, 1 + n_s), np.inf)
        out[:, 0] = instants
        out[row, 1 + idx] = ranges
        return out

    def _measure(
        self, pose_at: PoseFunction, t: NDArray[np.float64], idx: NDArray[np.int64], rng: np.random.Generator
    ) -> NDArray[np.float64]:
        noise = rng.standard_normal(t.size)
        drop = rng.random(t.size)
        if self.segments.shape[0] == 0:
            return np.full(t.size, np.nan)
        p = self._p
        heads = compose(pose_at(t), self._mount[idx])
        e = cone_echo(heads, self.segments, p["half_angle"][idx], p["max_incidence"][idx], p["min_range"][idx],
                      p["max_range"][idx])
        finite = np.where(np.isfinite(e.range), e.range, 0.0)
        std = p["noise_std"][idx] + p["noise_growth"][idx] * np.maximum(finite - p["optimal_max"][idx], 0.0)
        noisy = finite + std * noise
        valid = e.valid & (drop >= p["p_miss"][idx]) & (noisy >= p["min_range"][idx]) & (noisy <= p["max_range"][idx])
        return np.where(valid, noisy, np.nan)

    def deliver(self, event: NDArray[np.float64]) -> None:
        """Hand the readings of one instant (sensors that pinged then) to the estimator's ``update_ranges``."""
        if self.estimator is None:
            return
        ranges = {n: float(r) for n, r in zip(self.names, event[1:], strict=True) if r != np.inf}
        self.estimator.update_ranges(float(event[0]), ranges)
