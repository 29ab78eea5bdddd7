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

import json
import os
import sys
import threading
import time
from pathlib import Path
from types import TracebackType
from typing import Any

__all__ = ["RunProgress", "stderr_is_terminal"]


def stderr_is_terminal() -> bool:
    """True when stderr is an interactive terminal (a progress bar would be seen)."""
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # replaced or closed stream
        return False


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
        if self._bar is not None:
            fields: dict[str, Any] = {"completed": self.done}
            if total is not None:
                fields["total"] = float(total)
            self._bar.update(self._task, **fields)

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
        if self._bar is not None:
            self._bar.stop()
        if kind is None and self.key is not None and self.enabled and not self._reported:
            _remember(self.key, time.perf_counter() - self._t0)
