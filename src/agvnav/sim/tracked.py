"""The seed-004 tracked robot as plant, sensor and autopilot roles of the closed loop.

Wiring only: the truth motion is :class:`agvnav.kinematics.TrackedVehicle`
(ICR slip model), the speed loops are :class:`agvnav.actuators.WheelSpeedLoop`
(seed 004 PID, Kp = 10, Ki = 20, Kd = 0.5, on a motor pair with asymmetry),
the rangers are :class:`agvnav.sensors.ultrasonic.UltrasonicArray`, the
automaton :class:`agvnav.guidance.hybrid.HybridController` (Fig. 7) whose
:class:`~agvnav.positioning.wall_landmarks.WallLandmarkLocalizer` is the
estimator role; :class:`KanayamaAutopilot` follows any line/arc path instead.

Truth versus nominal. The tracks slip on the ground as the *truth* terrain
says; odometry (seed 004 eqs 3-5 generalised to the ICR model) converts the
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
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.actuators._fast import ScalarSpeedLoop
from agvnav.geometry import compose
from agvnav.kinematics._fast import track_twist, twist_pose
from agvnav.kinematics.base import twist_step
from agvnav.odometry._fast import track_increments
from agvnav.sensors.ultrasonic import UltrasonicArray, cone_echo
from agvnav.world.walls import square_landmarks

__all__ = [
    "HybridAutopilot",
    "KanayamaAutopilot",
    "TrackedPlant",
    "UltrasonicSensorRole",
]

TWO_PI = 2.0 * math.pi


class TrackedPlant:
    """Truth tracked robot: speed loops, ICR slip, sprocket encoders, nominal odometry.

    Parameters
    ----------
    vehicle : :class:`agvnav.kinematics.TrackedVehicle` with the *truth* terrain.
    loop : :class:`agvnav.actuators.WheelSpeedLoop` (its state is copied at construction).
    odometry_terrain : the :class:`~agvnav.kinematics.tracked.TrackTerrain` odometry believes.
    counts_per_rev : sprocket encoder counts per revolution (quantisation).
    initial_pose : true ``[x, y, heading]`` (m, rad).
    substep : speed-loop period (s).
    slip_noise_std : random slip, ``slip_noise_std`` m after 1 m per track: the
        :class:`agvnav.kinematics.TrackSlipNoise` model, drawn once per engine step.

    The command is the sprocket speed set-point ``[right, left]`` (rad/s).
    """

    signal_names = ("x", "y", "psi", "omega_right", "omega_left", "v", "yaw_rate", "odo_dd", "odo_dtheta", "distance")

    def __init__(
        self,
        vehicle: Any,
        loop: Any,
        odometry_terrain: Any,
        counts_per_rev: int,
        initial_pose: Sequence[float],
        substep: float = 0.01,
        slip_noise_std: float = 0.0,
    ) -> None:
        from agvnav.kinematics.tracked import TrackedVehicle, TrackSlipNoise

        if int(counts_per_rev) < 1:
            raise ValueError(f"counts_per_rev must be >= 1, got {counts_per_rev!r}")
        if not (math.isfinite(substep) and substep > 0):
            raise ValueError(f"substep must be a positive number of seconds, got {substep!r}")
        self.vehicle = vehicle
        self.r = float(vehicle.sprocket_radius)
        self.speed_loop = ScalarSpeedLoop(loop)
        self.odometry_model = TrackedVehicle(vehicle.gauge, self.r, odometry_terrain)
        self.counts_per_rev = int(counts_per_rev)
        self.substep = float(substep)
        self.slip_noise_std = float(slip_noise_std)
        self.slip_noise = TrackSlipNoise(self.slip_noise_std)
        self._T = [[float(v) for v in row] for row in vehicle.twist_matrix]
        self._To = [[float(v) for v in row] for row in self.odometry_model.twist_matrix]
        p = np.asarray(initial_pose, dtype=np.float64).reshape(3)
        self._pose = [float(p[0]), float(p[1]), float(p[2])]
        self._angle = [0.0, 0.0]  # true sprocket rotations (rad)
        self._counts = [0, 0]
        self._t0, self._h = 0.0, self.substep
        self._states = p[None, :].copy()
        self._twists = np.zeros((1, 3))
        self._odo = (0.0, 0.0)
        self._v = self._w = 0.0
        self.distance = 0.0

    @property
    def pose(self) -> NDArray[np.float64]:
        """True base_link pose now ``(3,)``."""
        return np.array(self._pose)

    def advance(self, command: Sequence[float], t0: float, dt: float, rng: np.random.Generator) -> None:
        """Hold sprocket set-points ``[right, left]`` (rad/s) from ``t0`` for ``dt`` s."""
        n = max(1, int(round(dt / self.substep)))
        h = dt / n
        sp = (float(command[0]), float(command[1]))
        # random slip of the step: the faster sprocket's set-point distance sets its scale
        noise = self.slip_noise.factors_scalar(max(abs(sp[0]), abs(sp[1])) * self.r * dt, rng)
        T = self._T
        x, y, th = self._pose
        states, twists = [(x, y, th)], []
        loop = self.speed_loop
        dist = 0.0
        for _ in range(n):
            w0 = loop.omega[0], loop.omega[1]
            w1 = loop.step(sp, h)
            wr, wl = 0.5 * (w0[0] + w1[0]), 0.5 * (w0[1] + w1[1])
            self._angle[0] += wr * h
            self._angle[1] += wl * h
            vx, vy, w = track_twist(wr * self.r * noise[0], wl * self.r * noise[1], T)
            x, y, th = twist_pose(x, y, th, vx, vy, w, h)
            states.append((x, y, th))
            twists.append((vx, vy, w))
            dist += math.hypot(vx, vy) * h
        self._pose = [x, y, th]
        self._t0, self._h = float(t0), h
        self._states = np.array(states)
        self._twists = np.array(twists)
        self._v, self._w = twists[-1][0], twists[-1][2]
        self.distance += dist
        self._odo = self._odometry_increment()

    def _odometry_increment(self) -> tuple[float, float]:
        """Nominal ``(delta_d, delta_theta)`` from the encoder counts (seed 004 eqs 3-5, ICR-generalised)."""
        q = TWO_PI / self.counts_per_rev
        ds = []
        for i in (0, 1):
            c = math.floor(self._angle[i] / q)
            ds.append((c - self._counts[i]) * q * self.r)
            self._counts[i] = c
        return track_increments(ds[0], ds[1], self._To)

    def pose_at(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """True pose ``(k, 3)`` at instants ``t (k,)`` of the last step (exact per sub-step twist)."""
        t = np.asarray(t, dtype=np.float64).reshape(-1)
        n = self._twists.shape[0]
        rel = np.clip(t - self._t0, 0.0, n * self._h)
        i = np.minimum((rel / self._h).astype(np.int64), n - 1)
        tau = rel - i * self._h
        tw = self._twists[i] * tau[:, None]
        return twist_step(self._states[i], tw[:, 0], tw[:, 1], tw[:, 2], 1.0)

    def odometry(self) -> tuple[float, float]:
        """``(delta_d, delta_theta)`` of base_link over the last step (nominal model)."""
        return self._odo

    def signals(self) -> tuple[float, ...]:
        x, y, th = self._pose
        w = self.speed_loop.omega
        return (x, y, th, w[0], w[1], self._v, self._w, self._odo[0], self._odo[1], self.distance)


class UltrasonicSensorRole:
    """The ultrasonic array as a closed-loop sensor: every ping in ``(t0, t1]`` along the true motion.

    ``observe`` casts all pings of the window in one batched :func:`cone_echo`
    call and adds the sensor model's noise and dropouts (one normal and one
    uniform draw per ping, in time then sensor order). Rows are ``(t,
    sensor_index, range)`` grouped by instant (see :meth:`observe`).
    ``deliver`` hands the reading to the automaton (``controller.observe``),
    which recalibrates its localizer at that instant (the engine has predicted
    it up to the ping first). When the automaton does not use landmarks
    (dead-reckoning runs) the rangers' readings would be discarded, so they
    are not simulated at all (no rows): the run is faster and otherwise identical.
    """

    name = "ultrasonic"

    def __init__(self, array: UltrasonicArray, segments: NDArray[np.float64], controller: Any = None) -> None:
        self.array = array
        self.segments = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
        self.controller = controller
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
        if self.controller is not None and not getattr(self.controller, "use_landmarks", True):
            return np.zeros((0, 1 + n_s))
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
        if self.controller is None:
            return
        ranges = {n: float(r) for n, r in zip(self.names, event[1:]) if r != np.inf}
        self.controller.observe(float(event[0]), ranges)


class HybridAutopilot:
    """Seed 004 Fig. 7: the hybrid automaton's wheel set-points; the estimator is its localizer."""

    signal_names = ("v_cmd", "omega_cmd", "omega_right_cmd", "omega_left_cmd", "state", "leg", "laps_done")

    def __init__(self, controller: Any) -> None:
        self.controller = controller
        self._sig: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    @property
    def finished(self) -> bool:
        return bool(self.controller.finished)

    def command(self, t: float, estimator: Any, plant: Any, dt: float) -> tuple[float, float]:
        c = self.controller
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
