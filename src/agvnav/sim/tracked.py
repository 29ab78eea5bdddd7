"""The seed-004 tracked robot as plant, sensor and autopilot roles of the closed loop.

The plant lives in :mod:`agvnav.vehicles.tracked` (re-exported here until sim is
restructured).
Wiring only: the truth motion is :class:`agvnav.kinematics.TrackedVehicle`
(ICR slip model), the speed loops are :class:`agvnav.actuators.WheelSpeedLoop`
(seed 004 PID, Kp = 10, Ki = 20, Kd = 0.5, on a motor pair with asymmetry),
the rangers are :class:`agvnav.sensors.ultrasonic.UltrasonicArray`, the
estimator role :class:`~agvnav.positioning.wall_landmarks.WallLandmarkLocalizer`
(dead reckoning corrected by the wall landmarks, [seed004 eq6] to [seed004 eq8]), read by
the automaton :class:`agvnav.guidance.hybrid.HybridController` (Fig. 7) or by
:class:`KanayamaAutopilot`, which follows any line/arc path instead.

Truth versus nominal. The tracks slip on the ground as the *truth* terrain
says; odometry ([seed004 eq3] to [seed004 eq5] generalised to the ICR model) converts the
quantised sprocket-encoder increments with the *odometry* terrain: the figures
the robot was calibrated with, which need not be the floor it drives on. That
mismatch, not motor asymmetry, is what drifts (plus the random slip of
:class:`agvnav.kinematics.TrackSlipNoise`): the PID integral cancels the
asymmetry at the sprockets, and the encoders see the sprockets, not the ground.

Speed. The speed loop and the vehicle run in ``substep`` sub-steps (10 ms)
inside every engine step. The hot loop calls the packages' scalar fast paths
(:class:`agvnav.actuators._fast.ScalarSpeedLoop`, :func:`agvnav.kinematics._fast.track_twist`,
:func:`agvnav.kinematics._fast.twist_pose`, :func:`agvnav.odometry._fast.track_increments`,
each tested against its kernel to 1e-12), because
NumPy's per-call overhead on 2-element arrays dominated the run time.
Within a sub-step each track moves at the mean of its start and end sprocket
speeds (trapezoidal rule of the first-order motor response).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import compose
from agvnav.sensors.ultrasonic import UltrasonicArray, cone_echo
from agvnav.vehicles.tracked import TrackedPlant

__all__ = [
    "HybridAutopilot",
    "KanayamaAutopilot",
    "TrackedPlant",
    "UltrasonicSensorRole",
]

TWO_PI = 2.0 * math.pi


class UltrasonicSensorRole:
    """The ultrasonic array as a closed-loop sensor: every ping in ``(t0, t1]`` along the true motion.

    ``observe`` casts all pings of the window in one batched :func:`cone_echo`
    call and adds the sensor model's noise and dropouts (one normal and one
    uniform draw per ping, in time then sensor order). Rows are ``(t,
    range_0, ..., range_{S-1})`` grouped by instant (see :meth:`observe`).
    ``deliver`` hands the readings of one instant to the estimator
    (``estimator.update_ranges``), which the engine has predicted up to that
    instant first. A run that does not use the landmarks leaves this role out.
    """

    name = "ultrasonic"

    def __init__(self, array: UltrasonicArray, segments: NDArray[np.float64]) -> None:
        self.array = array
        self.segments = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
        sensors = [array[n] for n in array.names]
        self.names = array.names
        self.event_names = ("t", *array.names)
        self._mount = np.array([s.mount for s in sensors])
        self._p = {a: np.array([getattr(s, a) for s in sensors]) for a in (
            "half_angle", "max_incidence", "min_range", "max_range", "optimal_max", "noise_std", "noise_growth",
            "p_miss")}
        self._sensors = sensors

    def observe(self, pose_at: Any, t0: float, t1: float, rng: np.random.Generator) -> NDArray[np.float64]:
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
        self, pose_at: Any, t: NDArray[np.float64], idx: NDArray[np.int64], rng: np.random.Generator
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

    def deliver(self, estimator: Any, event: NDArray[np.float64]) -> None:
        """Hand the readings of one instant (sensors that pinged then) to ``estimator.update_ranges``."""
        ranges = {n: float(r) for n, r in zip(self.names, event[1:], strict=True) if r != np.inf}
        estimator.update_ranges(float(event[0]), ranges)


class HybridAutopilot:
    """Seed 004 Fig. 7: the hybrid automaton's wheel set-points.

    The automaton reads the loop's estimator (it was built bound to it, see
    :meth:`agvnav.guidance.hybrid.HybridController.bind`).
    """

    signal_names = ("v_cmd", "omega_cmd", "omega_right_cmd", "omega_left_cmd", "state", "leg", "laps_done")

    def __init__(self, controller: Any) -> None:
        self.controller = controller
        self._sig: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    @property
    def finished(self) -> bool:
        return bool(self.controller.finished)

    def command(self, t: float, estimator: Any, plant: Any, dt: float) -> tuple[float, float]:
        c = self.controller
        if c.estimator is not estimator:
            c.bind(estimator)
        cmd = c.command(t)
        w = cmd.wheel_speeds
        self._sig = (cmd.v, cmd.omega, float(w[0]), float(w[1]), float(c.state.value[1]), float(c.leg),
                     float(c.laps_done))
        return float(w[0]), float(w[1])

    def signals(self) -> tuple[float, ...]:
        return self._sig


class KanayamaAutopilot:
    """A differential/tracked robot following a line/arc path with Kanayama's law (issue 6 §2)."""

    signal_names = ("v_cmd", "omega_cmd", "omega_right_cmd", "omega_left_cmd", "s_ref")

    def __init__(self, controller: Any) -> None:
        self.controller = controller
        self._sig: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0)

    @property
    def finished(self) -> bool:
        return bool(self.controller.finished)

    def command(self, t: float, estimator: Any, plant: Any, dt: float) -> tuple[float, float]:
        cmd = self.controller.command(t, estimator.pose)
        w = cmd.wheel_speeds
        self._sig = (cmd.v, cmd.omega, float(w[0]), float(w[1]), float(self.controller.s_ref))
        return float(w[0]), float(w[1])

    def signals(self) -> tuple[float, ...]:
        return self._sig
