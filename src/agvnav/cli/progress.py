"""The one progress bar of the command line: simulated time, laps or runs done, and an ETA, on stderr.

Library code never imports this: it accepts a plain callback (``progress(t)`` of
:func:`agvnav.sim.simulate`, ``progress(finished, total)`` of
:func:`agvnav.campaign.run_campaign`, ``progress(done, total)`` of a benchmark's
``run`` that takes one) and the commands pass :meth:`RunProgress.update` or
:meth:`RunProgress.runs`. A step that reports nothing (a benchmark, the layout
planner, a log being localised) runs under :meth:`RunProgress.update` never
being called: the bar then shows the elapsed time against the wall time the same
step took last time (remembered in ``$XDG_CACHE_HOME/agvnav/durations.json``), or
a pulse and the elapsed time the first time.

The bar is transient and drawn only when stderr is a terminal: piped or captured
output (scripts, CI, ``--json``) stays clean.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import sys
import threading
import time
from pathlib import Path
from types import TracebackType
from typing import Any

__all__ = ["RunProgress", "expected_sim_time", "stderr_is_terminal"]


def stderr_is_terminal() -> bool:
    """True when stderr is an interactive terminal (a progress bar would be seen)."""
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # replaced or closed stream
        return False


def expected_sim_time(sc: Any, built: Any) -> float:
    """Simulated seconds (s) the run of scenario ``sc`` (wired as ``built``) should take: the bar's total.

    A path: each run of segments driven in one direction (the vehicle stops at every cusp)
    at cruise speed, from and to rest at the acceleration limits, then the end hold. A
    mission: each leg's speed limit (the edge's, the curvature's and the creep before the
    station: :func:`agvnav.routes.mission.speed_limits`) driven from and to rest at every
    cusp, the turns on the spot at ``mission.turn_rate_deg_s``, the stops (``duration_s``),
    the fine positioning of a spot-turning vehicle at each station (:func:`_fine_s`) and the
    end hold. What it leaves out (waiting for a fix, slowing when positioning degrades)
    makes a run longer: the bar's total grows
    when the run passes it, and the bar is finished when the run ends. At most the run's
    time limit ``built.duration``.
    """
    tc = sc.traction
    accel, decel = float(tc.max_accel_m_s2), float(tc.max_decel_m_s2)
    if built.mission is not None:
        expected = _mission_time(sc, built, accel, decel)
    else:
        v = abs(float(tc.speed_m_s))
        expected = sum(_trapezoid_time(length, v, accel, decel) for length in _run_lengths(built.path.segments))
    expected += float(sc.end_hold_s)
    limit = float(built.duration)
    return min(limit, expected) if math.isfinite(expected) and expected > 0.0 else limit


def _run_lengths(segments: Any) -> list[float]:
    """Lengths (m) of the runs of consecutive segments driven in the same direction."""
    runs: list[float] = []
    last = 0
    for seg in segments:
        if runs and seg.direction == last:
            runs[-1] += float(seg.length)
        else:
            runs.append(float(seg.length))
        last = seg.direction
    return runs


def _trapezoid_time(length: float, v: float, accel: float, decel: float) -> float:
    """Time (s) to drive ``length`` m from rest to rest at cruise ``v`` (m/s) and the ramps (m/s^2)."""
    if length <= 0.0 or v <= 0.0:
        return 0.0
    ramps = v * v / (2.0 * accel) + v * v / (2.0 * decel)
    if length >= ramps:
        return length / v + v / (2.0 * accel) + v / (2.0 * decel)
    peak = math.sqrt(2.0 * length * accel * decel / (accel + decel))  # never reaches cruise
    return peak / accel + peak / decel


def _mission_time(sc: Any, built: Any, accel: float, decel: float) -> float:
    """Drive, spot turns, stops and fine positioning (s) of a planned mission (:func:`expected_sim_time`)."""
    import numpy as np

    from agvnav.geometry.angles import wrap_angle
    from agvnav.guidance.paths import Path as GuidePath
    from agvnav.navigation.mission import sub_path
    from agvnav.routes.mission import speed_limits

    m, plan = sc.mission, built.mission
    total = sum(float(leg.dwell_s) for leg in plan.legs)
    for k, leg in enumerate(plan.legs):
        if leg.route is None or not leg.route.traversals:
            continue
        segs, idx = sub_path(plan, float(plan.leg_bounds[k, 0]), float(plan.leg_bounds[k, 1]))
        s, cap = speed_limits(GuidePath(segs), plan.seg_speed[idx], abs(float(sc.traction.speed_m_s)),
                              m.lateral_accel_m_s2, decel, m.creep_distance_m, m.creep_speed_m_s)
        starts = np.cumsum([0.0, *(float(g.length) for g in segs)])
        cusps = [0.0, *(float(starts[i]) for i in range(1, len(segs)) if segs[i].direction != segs[i - 1].direction)]
        cusps.append(float(starts[-1]))
        for a, b in itertools.pairwise(cusps):
            inside = (s >= a - 1e-9) & (s <= b + 1e-9)
            total += _profile_time(s[inside], cap[inside], accel, decel)
    rate = math.radians(float(m.turn_rate_deg_s))
    body = [float(g.heading) + (math.pi if g.direction < 0 else 0.0) for g in plan.path.segments]
    body_end = [float(g.end_heading) + (math.pi if g.direction < 0 else 0.0) for g in plan.path.segments]
    turns = [abs(float(wrap_angle(b - a))) for a, b in zip(body_end[:-1], body[1:], strict=True)]
    total += sum(t for t in turns if t > 1e-3) / rate  # turns on the spot (tolerance-snapped joints are 0)
    if built.plant.family in ("unicycle", "holonomic") and m.align_heading:  # fine positioning at each stop
        total += sum(1 for leg in plan.legs if leg.route is not None and leg.route.traversals) * _fine_s(sc)
    return total


def _fine_s(sc: Any) -> float:
    """Expected fine positioning at one station stop (s): one settle at the :class:`FinePositioner`'s
    ``settle_timeout`` and one more settle window (``settle_revolutions`` goniometer revolutions)."""
    import inspect

    from agvnav.guidance import FinePositioner
    from agvnav.world.scenario import GoniometerSpec

    defaults = inspect.signature(FinePositioner).parameters
    revolution = 1.0 / (sc.goniometer or GoniometerSpec()).rate_hz
    return float(defaults["settle_timeout"].default) + defaults["settle_revolutions"].default * revolution


def _profile_time(s: Any, cap: Any, accel: float, decel: float) -> float:
    """Time (s) along the grid ``s`` (m) under the speed limit ``cap`` (m/s), from and to rest."""
    if len(s) < 2:
        return 0.0
    v = [float(c) for c in cap]
    v[0] = v[-1] = 0.0
    ds = [float(b - a) for a, b in itertools.pairwise(s)]
    for i in range(len(v) - 2, -1, -1):
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2.0 * decel * ds[i]))
    for i in range(1, len(v)):
        v[i] = min(v[i], math.sqrt(v[i - 1] ** 2 + 2.0 * accel * ds[i - 1]))
    return sum(2.0 * d / (a + b) for d, a, b in zip(ds, v[:-1], v[1:], strict=True) if a + b > 0.0)


def _cache_file() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "agvnav" / "durations.json"


def _remembered(key: str) -> float | None:
    try:
        value = json.loads(_cache_file().read_text(encoding="utf-8")).get(key)
    except (OSError, ValueError, AttributeError):
        return None
    return float(value) if isinstance(value, int | float) and value > 0 else None


def _remember(key: str, seconds: float) -> None:
    path = _cache_file()
    try:
        data = json.loads(path.read_text(encoding="utf-8")) if path.is_file() else {}
        if not isinstance(data, dict):
            data = {}
        data[key] = round(seconds, 3)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(data, indent=1, sort_keys=True), encoding="utf-8")
    except (OSError, ValueError):
        pass  # a progress estimate is never worth failing a command for


class RunProgress:
    """A transient progress bar on stderr for one long step of a command.

    Parameters
    ----------
    label
        What runs (a scenario, a benchmark name).
    total
        The amount of work in ``unit`` (simulated seconds, laps, runs), if known.
    unit
        How ``done`` and ``total`` read: ``"s simulated"``, ``"runs"``, ``"laps"``.
    key
        For steps that report nothing: the name under which the step's wall time is
        remembered, so that the next run shows a bar against it.
    enabled
        Draw the bar; default: when stderr is a terminal.

    ``update(done)`` may restart from zero (a second pass, e.g. the seed-004 run
    without landmarks after the one with them): the passes then add up.
    """

    def __init__(
        self, label: str, total: float | None = None, unit: str = "s simulated", key: str | None = None,
        enabled: bool | None = None,
    ) -> None:
        self.label = label
        self.total = total
        self.unit = unit
        self.key = key
        self.enabled = stderr_is_terminal() if enabled is None else enabled
        self.done = 0.0
        self._offset = 0.0
        self._last = 0.0
        self._bar: Any = None
        self._task: Any = None
        self._t0 = 0.0
        self._reported = False
        self._timed = False
        self._stop = threading.Event()
        self._ticker: threading.Thread | None = None

    def __enter__(self) -> RunProgress:
        self._t0 = time.perf_counter()
        if not self.enabled:
            return self
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

        total = self.total
        columns: list[Any] = [TextColumn(f"[bold]{self.label}[/bold]", markup=True), BarColumn()]
        if total is None and self.key is not None:
            expected = _remembered(self.key)
            if expected is not None:
                total, self.unit = expected, "s (as last time)"
        if total is not None:
            columns.append(TextColumn("{task.completed:,.1f}/{task.total:,.1f} " + self.unit, markup=False))
        elif self.key is None:
            columns.append(TextColumn("{task.completed:,.1f} " + self.unit, markup=False))
        columns += [TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn()]
        self._bar = Progress(*columns, console=Console(stderr=True), transient=True, refresh_per_second=8)
        self._task = self._bar.add_task(self.label, total=total)
        self._timed = self.total is None and self.key is not None and total is not None
        self._bar.start()
        if self._timed:  # nobody reports: a thread moves the bar with the clock
            self._stop = threading.Event()
            self._ticker = threading.Thread(target=self._tick_until_stopped, daemon=True)
            self._ticker.start()
        return self

    def _tick_until_stopped(self) -> None:
        while not self._stop.wait(0.25):
            self.tick()

    def update(self, done: float, total: float | None = None) -> None:
        """The work done so far (and the total when it changes); a drop below the last value starts a pass."""
        done = float(done)
        if done < self._last:
            self._offset += self._last
        self._last = done
        self.done = self._offset + done
        self._reported = True
        if total is not None:
            self.total = float(total)
        if self.total is not None and self.done > self.total:  # past the estimate: the total follows the run
            self.total = self.done
        if self._bar is not None:
            fields: dict[str, Any] = {"completed": self.done}
            if self.total is not None:
                fields["total"] = self.total
            self._bar.update(self._task, **fields)

    def finish(self) -> None:
        """The step ended: the bar is drawn full whatever the estimate was.

        The total becomes the amount done (a run that ended before its expected time, or
        after it) when progress was reported; a bar moved by the clock is filled.
        """
        if self._reported:
            self.total = self.done
        elif self.total is not None:
            self.done = self.total
        if self._bar is not None:
            task_total = self.total if self.total is not None else self._bar.tasks[0].total
            if task_total is not None:
                self._bar.update(self._task, total=task_total, completed=task_total)
                self._bar.refresh()

    @property
    def fraction(self) -> float | None:
        """Share of the total done (0 to 1), or None without a total."""
        if not self.total:
            return None
        return min(self.done / self.total, 1.0)

    def runs(self, finished: int, total: int) -> None:
        """Campaign-style callback: ``finished`` of ``total`` runs are done."""
        self.update(float(finished), float(total))

    def tick(self) -> None:
        """For a step that reports nothing: advance a remembered-duration bar to the elapsed time."""
        if self._bar is not None and self._timed:
            total = self._bar.tasks[0].total or 0.0
            self._bar.update(self._task, completed=min(time.perf_counter() - self._t0, 0.99 * total))

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if self._ticker is not None:
            self._stop.set()
            self._ticker.join()
        if kind is None:
            self.finish()
        if self._bar is not None:
            self._bar.stop()
        if kind is None and self.key is not None and self.enabled and not self._reported:
            _remember(self.key, time.perf_counter() - self._t0)
