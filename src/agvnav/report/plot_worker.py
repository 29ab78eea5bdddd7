"""Draw a run's plots in a second process that readies matplotlib while the run goes on.

Speed (issue 11, ``agvnav simulate`` end to end): importing matplotlib and readying its
fonts costs about 0.5 s of CPU and drawing the three run plots about 0.4 s, as much as
the default closed loop itself. :class:`PlotWorker` forks a child before the run starts;
the child imports matplotlib and draws a throw-away figure (fonts, Agg canvas) on the
second core while the parent runs the simulation, then draws the run's plots
(:func:`agvnav.report.plots.write_plots`, the same function, the same files) while the
parent writes the JSON and CSV files. Where ``fork`` is unavailable (Windows, macOS
defaults), the caller already runs threads (forking them is unsafe) or the child has died,
the plots are drawn in the calling process instead, so the files are the same either way.
"""

from __future__ import annotations

import multiprocessing
import threading
from collections.abc import Callable, Mapping
from multiprocessing.connection import Connection
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["PlotWorker"]


class PlotWorker:
    """A forked child that draws one run's plots (:func:`agvnav.report.plots.write_plots`).

    Start it as early as possible (before the run, before any thread starts: it forks),
    hand it the run's series with :meth:`submit`, collect the written paths by calling
    what :meth:`submit` returned. Use as a context manager so the child always ends.
    """

    def __init__(self) -> None:
        self._conn: Connection | None = None
        self._proc: Any = None
        self._submitted = False
        if "fork" not in multiprocessing.get_all_start_methods() or threading.active_count() > 1:
            return  # no fork, or forking a process with threads (unsafe): the plots are drawn inline
        ctx = multiprocessing.get_context("fork")
        parent, child = ctx.Pipe()
        proc = ctx.Process(target=_serve, args=(child,), daemon=True, name="agvnav-plots")
        proc.start()
        child.close()
        self._conn, self._proc = parent, proc

    @property
    def forked(self) -> bool:
        """Whether a child draws the plots (False: :meth:`submit` draws them in this process)."""
        return self._proc is not None

    def submit(
        self,
        series: Mapping[str, NDArray[np.float64]],
        path_xy: NDArray[np.float64],
        reflector_xy: NDArray[np.float64],
        wall_segments: NDArray[np.float64],
        out_dir: str | Path,
        transient_end_s: float | None = None,
        title: str = "",
    ) -> Callable[[], list[Path]]:
        """Start drawing map.png, errors.png and positioning_histogram.png into ``out_dir``.

        Arguments as :func:`agvnav.report.plots.write_plots`. Returns a function that waits
        for the files and returns their paths (it raises what drawing raised).
        """
        args = (dict(series), path_xy, reflector_xy, wall_segments, Path(out_dir), transient_end_s, title)
        self._submitted = True
        conn = self._conn
        if conn is not None:
            try:
                conn.send(args)
            except (OSError, ValueError):  # the child has gone: draw here
                conn = None
        if conn is None:
            from agvnav.report.plots import write_plots  # noqa: PLC0415  (lazy: matplotlib)

            paths = write_plots(*args)
            return lambda: paths

        def wait() -> list[Path]:
            try:
                status, value = conn.recv()
            except (EOFError, OSError):  # the child died while drawing: draw here
                from agvnav.report.plots import write_plots  # noqa: PLC0415

                return write_plots(*args)
            if status != "ok":
                raise RuntimeError(f"drawing the plots failed: {value}")
            return [Path(p) for p in value]

        return wait

    def close(self) -> None:
        """End the child: it ends by itself once its one job is done; one never given a job is stopped."""
        if self._conn is not None:
            self._conn.close()
            self._conn = None
        if self._proc is not None:
            if not self._submitted:  # e.g. a route scenario or a user error: do not wait for its warm-up
                self._proc.terminate()
            self._proc.join(timeout=5.0)
            if self._proc.is_alive():
                self._proc.terminate()
                self._proc.join()
            self._proc = None

    def __enter__(self) -> PlotWorker:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def _serve(conn: Connection) -> None:
    """The child: ready matplotlib, wait for one job, draw it, send back the paths or the error."""
    try:
        from agvnav.report.plots import warm_up, write_plots  # noqa: PLC0415  (the child's own imports)

        warm_up()
        args = conn.recv()
    except (EOFError, OSError, KeyboardInterrupt):
        return
    try:
        paths = write_plots(*args)
        conn.send(("ok", [str(p) for p in paths]))
    except Exception as exc:  # reported to the parent, which raises it
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
    finally:
        conn.close()
