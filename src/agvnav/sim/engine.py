"""The fixed-step closed loop of seed 000 Fig. 9, independent of the vehicle type.

One step of length ``dt`` from ``t_k`` to ``t_{k+1}``:

1. the **autopilot** (guidance law + actuators) turns the latest pose estimate and
   the vehicle's proprioceptive readings into the physical command held over the
   step;
2. the **plant** (truth vehicle) advances under that command; afterwards it can
   give its true base_link pose at any instant inside the step (``pose_at``) and
   the odometry increment its encoders measured (nominal parameters);
3. every **exteroceptive sensor** (the goniometer; ultrasonic rangers later) scans
   the window ``(t_k, t_{k+1}]`` against the world along the true motion;
4. the **estimator** receives, in time order, the odometry increment up to each
   measurement instant (the step's increment split in proportion to time) and the
   measurement, then the rest of the increment up to ``t_{k+1}``;
5. one row of every signal is recorded.

The roles are the protocols of :mod:`agvnav.roles` (re-exported here), so a
differential or tracked plant with ultrasonic sensors and a hybrid-automaton
autopilot (issue 6) plugs in without touching this loop. The engine holds no physics, estimation or control of its own.
Determinism: every random draw comes from generators spawned from the scenario
seed, one per role, in a fixed order.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from itertools import repeat
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.roles import Autopilot, Estimator, Plant, Sensor
from agvnav.sim.recorder import EventLog, Recorder

__all__ = [
    "MAX_RECORDED_ROWS", "Autopilot", "ClosedLoop", "Estimator", "LoopOutput", "Plant", "Sensor", "record_stride",
]

#: Estimator status -> recorded code (-1: a status not listed here).
STATUS_CODES = {"initialising": 0.0, "tracking": 1.0, "dead_reckoning": 2.0, "degraded": 3.0, "lost": 4.0}

#: Recorded rows a run keeps at most when ``record_every`` is automatic (None): longer runs
#: (beyond 83 min at 20 Hz) record every k-th step (~32 MB of series for 40 signals), so a
#: 24-hour drive stays small.
MAX_RECORDED_ROWS = 100_000
#: Rows per recorder block (the recorder grows by blocks; nothing is preallocated for the whole run).
RECORD_BLOCK = 16_384


def record_stride(n_steps: int, record_every: int | None) -> int:
    """Steps between recorded rows: ``record_every``, or automatic (1 up to :data:`MAX_RECORDED_ROWS` steps)."""
    if record_every is None:
        return max(1, math.ceil(n_steps / MAX_RECORDED_ROWS))
    if isinstance(record_every, bool) or not isinstance(record_every, int) or record_every < 1:
        raise ValueError(f"record_every must be a positive integer number of steps, got {record_every!r}")
    return record_every


@dataclass
class LoopOutput:
    """Everything a run produced: the fixed-step series, the sensor events, timing."""

    series: dict[str, NDArray[np.float64]]
    events: dict[str, dict[str, NDArray[np.float64]]]
    wall_time_s: float
    finished: bool
    failure: str | None = None
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class _RunState:
    """A run in progress (:meth:`ClosedLoop.start` .. :meth:`ClosedLoop.finish`)."""

    dt: float
    n_steps: int
    stride: int
    end_hold: float
    progress: Callable[[float], None] | None
    rng_plant: np.random.Generator
    rng_sensors: list[np.random.Generator]
    rec: Recorder
    logs: list[EventLog]
    every: int
    hold_left: float
    sensors: list[Sensor]
    t: float = 0.0
    k: int = 0
    cmd: Sequence[float] = ()
    recorded: bool = True
    running: bool = False
    failure: str | None = None
    start: float = 0.0


@dataclass
class ClosedLoop:
    """Wires a plant, sensors, an estimator and an autopilot at a fixed step.

    Parameters
    ----------
    plant, sensors, estimator, autopilot
        The roles (:mod:`agvnav.roles`); each sensor was wired to the estimator it feeds.
    dt
        Step (s).
    seed
        Root seed; same seed -> bit-identical recorded arrays.
    record_every
        Record one row every this many steps (and always the last step); None (default)
        records every step of runs up to :data:`MAX_RECORDED_ROWS` steps and decimates
        longer ones to about that many rows. With a stride above 1 the events of the recorded
        steps are kept (every event of every step when the stride is 1).
    """

    plant: Plant
    sensors: Sequence[Sensor]
    estimator: Estimator
    autopilot: Autopilot
    dt: float
    seed: int = 0
    record_every: int | None = None
    _state: _RunState | None = field(default=None, init=False, repr=False, compare=False)

    def run(
        self,
        duration: float,
        end_hold: float = 0.0,
        progress: Callable[[float], None] | None = None,
    ) -> LoopOutput:
        """Run until ``duration`` s, or ``end_hold`` s after the autopilot finishes.

        ``progress(t)`` is called about a hundred times during the run. The same as
        :meth:`start`, :meth:`step` until it returns False, :meth:`finish`.
        """
        self.start(duration, end_hold, progress)
        while self.step():
            pass
        return self.finish()

    # ------------------------------------------------------------------ step-wise API
    # A fleet (:mod:`agvnav.sim.fleet`) advances many loops in lockstep: every plant first
    # (:meth:`advance`), then every loop's sensors, estimator and autopilot (:meth:`sense`), so
    # that each vehicle's sensors see the others where they truly are inside the same window.

    def start(
        self,
        duration: float,
        end_hold: float = 0.0,
        progress: Callable[[float], None] | None = None,
    ) -> None:
        """Begin a run of at most ``duration`` s (see :meth:`run`): seeds the streams, gives the first command."""
        if not (math.isfinite(duration) and duration > 0):
            raise ValueError(f"duration must be a positive finite number of seconds, got {duration!r}")
        dt = float(self.dt)
        n_steps = math.ceil(duration / dt - 1e-9)
        streams = np.random.SeedSequence(self.seed).spawn(2 + len(self.sensors))
        plant, est, pilot, sensors = self.plant, self.estimator, self.autopilot, list(self.sensors)
        columns = ("t", "est_x", "est_y", "est_psi", "est_status", *plant.signal_names, *pilot.signal_names)
        stride = record_stride(n_steps, self.record_every)
        st = _RunState(
            dt=dt, n_steps=n_steps, stride=stride, end_hold=end_hold, progress=progress,
            rng_plant=np.random.default_rng(streams[0]),
            rng_sensors=[np.random.default_rng(s) for s in streams[2:]],
            rec=Recorder(columns, min(n_steps // stride + 2, RECORD_BLOCK)),
            logs=[EventLog(s.event_names) for s in sensors],
            every=max(1, n_steps // 100), hold_left=end_hold, sensors=sensors,
        )
        self._state = st
        st.start = time.perf_counter()
        st.cmd = pilot.command(st.t, est, plant, dt)
        self._record(st.rec, st.t, est, plant, pilot)
        st.running = n_steps > 0

    def _run_state(self) -> _RunState:
        st = self._state
        if st is None:
            raise ValueError("the loop has no run in progress: call start() first")
        return st

    @property
    def running(self) -> bool:
        """True between :meth:`start` and the step that ends the run (time limit, failure, end hold)."""
        return self._state is not None and self._state.running

    @property
    def t(self) -> float:
        """Simulated time reached (s)."""
        return self._run_state().t

    def advance(self) -> None:
        """First half of a step: the plant holds the last command over ``(t, t + dt]``."""
        st = self._run_state()
        self.plant.advance(st.cmd, st.t, st.dt, st.rng_plant)

    def sense(self) -> bool:
        """Second half of a step: sensors, estimator, next command, record; False once the run has ended."""
        st = self._run_state()
        plant, est, pilot = self.plant, self.estimator, self.autopilot
        dt, t, k, stride = st.dt, st.t, st.k, st.stride
        t1 = (k + 1) * dt
        dd, dth, dl = plant.odometry()
        batches: list[tuple[float, Sensor, NDArray[np.float64]]] = []
        for sensor, log, rng in zip(st.sensors, st.logs, st.rng_sensors, strict=True):
            ev = sensor.observe(plant.pose_at, t, t1, rng)
            if ev.shape[0]:
                if stride == 1 or (k + 1) % stride == 0:  # a decimated run keeps its recorded steps' events
                    log.extend(ev)
                # times as Python floats: the splitting arithmetic below stays off NumPy scalars
                batches.extend(zip(ev[:, 0].tolist(), repeat(sensor), ev))
        if batches:
            batches.sort(key=lambda item: item[0])
            t_prev = t
            for te, sensor, row in batches:
                frac = (te - t_prev) / dt
                est.predict(te, dd * frac, dth * frac, dl * frac)
                sensor.deliver(row)
                t_prev = te
            frac = (t1 - t_prev) / dt
            est.predict(t1, dd * frac, dth * frac, dl * frac)
        else:
            est.predict(t1, dd, dth, dl)
        t = t1
        st.t, st.k = t, k + 1
        st.cmd = pilot.command(t, est, plant, dt)
        st.recorded = (k + 1) % stride == 0
        if st.recorded:
            self._record(st.rec, t, est, plant, pilot)
        if st.progress is not None and k % st.every == 0:
            st.progress(t)
        st.failure = plant.failure()
        if st.failure is not None:
            st.running = False
        elif pilot.finished:
            st.hold_left -= dt
            if st.hold_left < -1e-12:
                st.running = False
        if st.k >= st.n_steps:
            st.running = False
        return st.running

    def step(self) -> bool:
        """One whole step (:meth:`advance` then :meth:`sense`); False once the run has ended."""
        self.advance()
        return self.sense()

    def stop(self, failure: str) -> None:
        """End the run now with ``failure`` (a fleet's collision judged outside the plant)."""
        st = self._run_state()
        st.failure = failure
        st.running = False

    def finish(self) -> LoopOutput:
        """The run's output (the last step is always recorded); the loop may then :meth:`start` again."""
        st = self._run_state()
        plant, est, pilot = self.plant, self.estimator, self.autopilot
        if st.n_steps and not st.recorded:  # the last step is always recorded
            self._record(st.rec, st.t, est, plant, pilot)
        wall = time.perf_counter() - st.start
        if st.progress is not None:
            st.progress(st.t)
        events = {s.name: log.drain() for s, log in zip(st.sensors, st.logs, strict=True)}
        self._state = None
        return LoopOutput(
            series=st.rec.drain(), events=events, wall_time_s=wall, finished=bool(pilot.finished), failure=st.failure
        )

    @staticmethod
    def _record(rec: Recorder, t: float, est: Estimator, plant: Plant, pilot: Autopilot) -> None:
        pose = est.pose
        status = STATUS_CODES.get(est.status, -1.0)
        rec.append((t, pose[0], pose[1], pose[2], status, *plant.signals(), *pilot.signals()))
