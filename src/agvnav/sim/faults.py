"""Fault injection around the closed-loop roles (issue 12 §3): the scenario's ``faults:`` list.

Each fault is a :class:`agvnav.world.scenario.FaultSpec` active over ``[start_s, end_s)``.
They are applied by wrappers, so the vehicles, the goniometer and the estimators
stay untouched:

* :func:`world_with_faults`: the world the goniometer really sees (a reflector
  ``reflector_moved`` from its surveyed position; the estimator keeps the map);
* :class:`FaultySensor` around a sensor: ``blind`` drops every event in the window,
  ``reflector_removed`` drops that reflector's reflections, ``clutter`` adds
  spurious reflections (index −1) at uniform random bearings, a Poisson number of
  ``per_revolution`` per head revolution, ``reflection_delay`` holds each event
  back ``delay_s`` and delivers it stamped with its arrival time (uncompensated
  latency), or with its measurement time when ``stamped`` (then an estimator that
  refuses an out-of-order reflection has it counted in ``late_rejected``, and the
  run goes on: one bad reading must not abort it);
* :class:`FaultyPlant` around a plant, on its odometry only (the truth moves as
  commanded): ``wheel_slip`` multiplies the measured distance by
  ``1 + slip_fraction``; ``encoder_dropout`` reads nothing (that motion is lost);
  ``odometry_lost`` loses the messages and the next one carries the whole missed
  increment (cumulative counters); ``counter_wrap`` adds ``jump_m`` to the one
  increment that ends just after ``start_s``.

Random draws (clutter) come from a generator of their own, derived from the
scenario seed, so a fault never shifts the other roles' random streams and a run
reproduces bit for bit.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from agvnav.roles import Plant, PoseFunction
from agvnav.sim.roles import GoniometerSensor
from agvnav.sim.wrapped import WrappedPlant
from agvnav.world import WorldMap
from agvnav.world.scenario import FaultSpec

__all__ = [
    "PLANT_FAULTS",
    "SENSOR_FAULTS",
    "FaultyPlant",
    "FaultySensor",
    "fault_rng",
    "world_with_faults",
]

#: Fault kinds that act on the exteroceptive sensor (and the true world).
SENSOR_FAULTS = frozenset({"blind", "reflector_removed", "reflector_moved", "clutter", "reflection_delay"})
#: Fault kinds that act on the plant's odometry.
PLANT_FAULTS = frozenset({"wheel_slip", "encoder_dropout", "odometry_lost", "counter_wrap"})


def fault_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of fault ``index`` of a scenario with ``seed`` (independent of every role's)."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(0xFA17, index)))


def world_with_faults(world: WorldMap, faults: Sequence[FaultSpec]) -> WorldMap:
    """``world`` with each ``reflector_moved`` reflector displaced by its ``offset_m`` (m).

    ValueError naming the reflector when a fault names one the map does not have.
    """
    moved = {}
    for f in faults:
        if f.kind in ("reflector_moved", "reflector_removed"):
            index = world.reflector_index(str(f.reflector))  # ValueError names an unknown id
            if f.kind == "reflector_moved" and f.offset_m is not None:
                moved[index] = f.offset_m
    if not moved:
        return world
    refl = list(world.reflectors)
    for i, (dx, dy) in moved.items():
        refl[i] = dataclasses.replace(refl[i], x=refl[i].x + dx, y=refl[i].y + dy)
    return dataclasses.replace(world, reflectors=tuple(refl))


def _active(f: FaultSpec, t: NDArray[np.float64]) -> NDArray[np.bool_]:
    return np.asarray((t >= f.start_s) & (t < f.end_s), dtype=np.bool_)


class FaultySensor:
    """A sensor with the scenario's sensor faults applied to its events (see the module docstring).

    Parameters
    ----------
    sensor : the wrapped goniometer role (events ``(t, bearing, reflector_index)``; its estimator
        takes the delayed reflections).
    faults : the sensor faults (other kinds are ignored).
    world : the map, to resolve reflector ids.
    rate_hz : head revolutions per second (clutter rate).
    seed : scenario seed (clutter draws).
    """

    def __init__(
        self, sensor: GoniometerSensor, faults: Sequence[FaultSpec], world: WorldMap, rate_hz: float, seed: int
    ) -> None:
        self.sensor = sensor
        self.name = sensor.name
        self.faults = [f for f in faults if f.kind in SENSOR_FAULTS and f.kind != "reflection_delay"]
        self.delays = [f for f in faults if f.kind == "reflection_delay"]
        self.event_names = (*sensor.event_names, "stamp") if self.delays else tuple(sensor.event_names)
        self.removed = [
            (world.reflector_index(str(f.reflector)), f) for f in self.faults if f.kind == "reflector_removed"
        ]
        self.rate_hz = float(rate_hz)
        self._rngs = [fault_rng(seed, i) for i in range(len(self.faults))]
        self._held = np.zeros((0, len(self.event_names)))  # delayed events, arrival time in column 0
        self.late_rejected = 0
        self.injected = 0
        self.dropped = 0

    def observe(self, pose_at: PoseFunction, t0: float, t1: float, rng: np.random.Generator) -> NDArray[np.float64]:
        """The wrapped sensor's events in ``(t0, t1]`` with the faults applied."""
        ev = np.asarray(self.sensor.observe(pose_at, t0, t1, rng), dtype=np.float64)
        for f, frng in zip(self.faults, self._rngs, strict=True):
            if f.kind == "blind":
                ev = self._drop(ev, _active(f, ev[:, 0]))
            elif f.kind == "clutter":
                ev = self._clutter(ev, f, frng, t0, t1)
        for index, f in self.removed:
            ev = self._drop(ev, _active(f, ev[:, 0]) & (ev[:, 2] == index))
        if self.delays:
            ev = np.column_stack([ev, ev[:, 0]])  # the stamp delivered: the measurement time so far
            for f in self.delays:
                ev = self._delay(ev, f, t1)
        return ev

    def _drop(self, ev: NDArray[np.float64], mask: NDArray[np.bool_]) -> NDArray[np.float64]:
        if not np.any(mask):
            return ev
        self.dropped += int(np.count_nonzero(mask))
        return ev[~mask]

    def _clutter(
        self, ev: NDArray[np.float64], f: FaultSpec, rng: np.random.Generator, t0: float, t1: float
    ) -> NDArray[np.float64]:
        lo, hi = max(t0, f.start_s), min(t1, f.end_s)
        if hi <= lo:
            return ev
        assert f.per_revolution is not None
        k = int(rng.poisson(f.per_revolution * self.rate_hz * (hi - lo)))
        if k == 0:
            return ev
        rows = np.full((k, ev.shape[1]), -1.0)
        rows[:, 0] = np.sort(lo + (hi - lo) * (1.0 - rng.random(k)))  # (lo, hi]
        rows[:, 1] = rng.uniform(-math.pi, math.pi, k)
        self.injected += k
        out = np.concatenate([ev, rows], axis=0)
        return out[np.argsort(out[:, 0], kind="stable")]

    def _delay(self, ev: NDArray[np.float64], f: FaultSpec, t1: float) -> NDArray[np.float64]:
        """Hold back the window's events ``delay_s``; return the others and those arriving by ``t1``.

        Column 0 becomes the arrival time (the engine orders and splits the odometry on
        it); the last column, the stamp delivered, stays the measurement time only when
        ``stamped``.
        """
        assert f.delay_s is not None
        late = _active(f, ev[:, 0])
        if np.any(late):
            held = ev[late].copy()
            held[:, 0] += f.delay_s
            if not f.stamped:
                held[:, -1] = held[:, 0]
            self._held = np.concatenate([self._held, held], axis=0)
            ev = ev[~late]
        due = self._held[:, 0] <= t1
        if not np.any(due):
            return ev
        out = np.concatenate([ev, self._held[due]], axis=0)
        self._held = self._held[~due]
        return out[np.argsort(out[:, 0], kind="stable")]

    def deliver(self, event: NDArray[np.float64]) -> None:
        """One event to the sensor's estimator; a delayed one with its delivered stamp (see the module docstring)."""
        if self.delays:
            estimator = self.sensor.estimator
            if estimator is None:
                return
            stamp = float(event[-1])
            try:
                estimator.update(stamp, float(event[1]))
            except ValueError:
                self.late_rejected += 1
            return
        self.sensor.deliver(event)


class FaultyPlant(WrappedPlant):
    """A plant whose :meth:`odometry` carries the scenario's odometry faults (see the module docstring).

    The other role methods are the plant's own bound methods (:class:`~agvnav.sim.wrapped.WrappedPlant`).
    """

    def __init__(self, plant: Plant, faults: Sequence[FaultSpec]) -> None:
        super().__init__(plant)
        self.faults = [f for f in faults if f.kind in PLANT_FAULTS]
        self.failure = plant.failure
        self._t1 = 0.0
        self._missed = (0.0, 0.0, 0.0)
        self._wrapped = False

    def advance(self, command: Sequence[float], t0: float, dt: float, rng: np.random.Generator) -> None:
        """Advance the plant; remember the step's end time for the fault windows."""
        self.plant.advance(command, t0, dt, rng)
        self._t1 = t0 + dt

    def odometry(self) -> tuple[float, float, float]:
        """The plant's odometry increment with the active faults applied."""
        dd, dth, dl = self.plant.odometry()
        t = self._t1
        for f in self.faults:
            on = f.start_s < t <= f.end_s + 1e-12
            if f.kind == "wheel_slip" and on:
                assert f.slip_fraction is not None
                dd *= 1.0 + f.slip_fraction
                dl *= 1.0 + f.slip_fraction
            elif f.kind == "encoder_dropout" and on:
                dd = dth = dl = 0.0
            elif f.kind == "odometry_lost":
                dd, dth, dl = self._lost(on, (dd, dth, dl))
            elif f.kind == "counter_wrap" and not self._wrapped and t > f.start_s:
                assert f.jump_m is not None
                dd += f.jump_m
                self._wrapped = True
        return dd, dth, dl

    def _lost(self, on: bool, inc: tuple[float, float, float]) -> tuple[float, float, float]:
        """Accumulate the increments while messages are lost; the first one after carries them."""
        m = self._missed
        total = (m[0] + inc[0], m[1] + inc[1], m[2] + inc[2])
        if on:
            self._missed = total
            return 0.0, 0.0, 0.0
        self._missed = (0.0, 0.0, 0.0)
        return total
