"""Draw a run's plots in a second process that readies matplotlib while the run goes on.

Speed (issue 11, ``agvnav simulate`` end to end): importing matplotlib and readying its
fonts costs about 0.5 s of CPU and drawing the three run plots about 0.4 s, as much as
the default closed loop itself. :class:`PlotWorker` forks a child before the run starts;
the child imports matplotlib and draws a throw-away figure (fonts, Agg canvas) on the
second core while the parent runs the simulation, forks its helper, and each readies the empty
figures of its share (:func:`agvnav.report.plots.prepare`: axes, ticks, about a fifth of the
drawing), then draws the run's plots
(:func:`agvnav.report.plots.write_plots`, the same function, the same files) while the
parent writes the JSON and CSV files. Where ``fork`` is unavailable (Windows, macOS
defaults), the caller already runs threads (forking them is unsafe) or the child has died,
the plots are drawn in the calling process instead, so the files are the same either way.

Failures behave as inline too: the exception a drawing raised in a child is sent back
(pickled) and raised again by the caller with its own type (a full disk stays an
``OSError``, one line from the CLI); only an exception that cannot cross a pipe becomes a
``RuntimeError`` naming it. A failing warm-up is reported the same way when the plots are
collected, not printed mid-run. The children never create folders (the caller does, in
:meth:`PlotWorker.submit`), so a folder removed while they draw, e.g. an atomic output
folder cleaned up after an error, is not created again.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import pickle
import signal
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
        self._conns: list[Connection] = []
        self._proc: Any = None
        self._submitted = False
        if "fork" not in multiprocessing.get_all_start_methods() or threading.active_count() > 1:
            return  # no fork, or forking a process with threads (unsafe): the plots are drawn inline
        ctx = multiprocessing.get_context("fork")
        pipes = [ctx.Pipe() for _ in _SHARES]
        proc = ctx.Process(
            target=_serve, args=([c for _, c in pipes], [p for p, _ in pipes]), daemon=True, name="agvnav-plots"
        )
        proc.start()
        for _, c in pipes:
            c.close()
        self._conns, self._proc = [p for p, _ in pipes], proc

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

        Arguments as :func:`agvnav.report.plots.write_plots`; ``out_dir`` is created here, in
        this process. Returns a function that waits for every share of the drawing, then returns
        the paths or raises what drawing raised (the first error, with its type).
        """
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)  # here, not in a child (see the module docstring)
        job: dict[str, Any] = {
            "series": dict(series), "path_xy": path_xy, "reflector_xy": reflector_xy,
            "wall_segments": wall_segments, "out_dir": out, "transient_end_s": transient_end_s,
            "title": title, "make_dir": False,
        }
        self._submitted = True
        sent: list[Connection | None] = []
        for k in range(len(_SHARES)):
            conn: Connection | None = self._conns[k] if self._conns else None
            try:
                if conn is not None:
                    conn.send(job)
            except (OSError, ValueError):  # that child has gone: its share is drawn here
                conn = None
            sent.append(conn)

        def wait() -> list[Path]:
            from agvnav.report.plots import write_plots  # noqa: PLC0415  (lazy: matplotlib)

            paths: list[Path] = []
            error: BaseException | None = None
            for conn, share in zip(sent, _SHARES, strict=True):  # every share answers before anything is raised
                if conn is None:
                    if error is None:
                        try:
                            paths += write_plots(**job, only=share)
                        except Exception as exc:  # raised below, once every child is done
                            error = exc
                    continue
                try:
                    status, value = conn.recv()
                except (EOFError, OSError):  # the child died while drawing: draw its share here
                    status, value = "redraw", None
                if status == "redraw" and error is None:
                    try:
                        paths += write_plots(**job, only=share)
                    except Exception as exc:
                        error = exc
                elif status == "ok":
                    paths += [Path(p) for p in value]
                elif status == "error" and error is None:
                    error = value  # the child's exception, its type kept
                elif status == "error_text" and error is None:
                    error = RuntimeError(f"drawing the plots failed: {value}")
            if error is not None:
                raise error
            return paths

        if not self._conns:  # no child: draw now, as the caller expects the work to be under way
            done = wait()
            return lambda: done
        return wait

    def close(self) -> None:
        """End the child: it ends by itself once its one job is done; one never given a job is stopped."""
        for conn in self._conns:
            conn.close()
        self._conns = []
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


#: How the three run plots are shared out: the map in the child, errors and histogram in the
#: grandchild it forks once matplotlib is ready (each about half of the drawing), so both
#: cores draw once the run is over.
_SHARES: tuple[tuple[str, ...], ...] = (("map",), ("errors", "histogram"))


def _serve(conns: list[Connection], parent_ends: list[Connection]) -> None:
    """The child: ready matplotlib, fork one helper per further share, each draws its share of one job.

    The parent's ends of the pipes, inherited through the fork, are closed first: once the
    parent closes its own, a child waiting for a job then sees the end of the pipe and leaves.
    """
    for end in parent_ends:
        end.close()
    try:
        from agvnav.report.plots import warm_up  # noqa: PLC0415  (the child's own imports)

        warm_up()
    except KeyboardInterrupt:
        return
    except Exception as exc:  # no traceback mid-run: reported when the plots are collected
        for conn in conns:
            try:
                conn.recv()
            except (EOFError, OSError, KeyboardInterrupt):
                continue
            _reply(conn, exc)
            conn.close()
        return
    helpers: list[int] = []
    mine = 0
    for k in range(1, len(conns)):  # helpers forked from a warm, single-threaded process: nothing to import
        pid = os.fork()
        if pid == 0:
            mine = k
            helpers = []
            break
        helpers.append(pid)
    for k, conn in enumerate(conns):
        if k != mine:
            conn.close()
    if not mine and helpers:  # terminated (PlotWorker.close): the helpers end too, none draws on alone
        signal.signal(signal.SIGTERM, lambda signum, frame: _end(helpers))
    try:
        _draw_one(conns[mine], _SHARES[mine])
    finally:
        if mine:  # a helper: leave at once (no atexit handlers, no flushing of the parent's buffers)
            os._exit(0)
        for pid in helpers:
            os.waitpid(pid, 0)


def _draw_one(conn: Connection, share: tuple[str, ...]) -> None:
    """Ready the empty figures of ``share``, wait for one job on ``conn``, draw ``share`` of it, send back
    the paths or the error."""
    from agvnav.report.plots import prepare, write_plots  # noqa: PLC0415

    # the empty figures while the run goes on; should that fail, drawing makes its own (and reports)
    with contextlib.suppress(Exception, KeyboardInterrupt):
        prepare(share)
    try:
        job: dict[str, Any] = conn.recv()
    except (EOFError, OSError, KeyboardInterrupt):
        return
    try:
        try:
            paths = write_plots(**job, only=share)
        except Exception as exc:  # reported to the parent, which raises it
            _reply(conn, exc)
        else:
            _send(conn, ("ok", [str(p) for p in paths]))
    finally:
        conn.close()


def _reply(conn: Connection, exc: BaseException) -> None:
    """Send ``exc`` itself when it survives pickling both ways, else its type and text."""
    try:
        pickle.loads(pickle.dumps(exc))
    except Exception:  # any failure to cross the pipe: send the text
        _send(conn, ("error_text", f"{type(exc).__name__}: {exc}"))
    else:
        _send(conn, ("error", exc))


def _send(conn: Connection, message: tuple[str, Any]) -> None:
    """Send ``message``; a parent that has stopped listening is not an error of the child."""
    with contextlib.suppress(OSError, ValueError):
        conn.send(message)


def _end(helpers: list[int]) -> None:
    """SIGTERM in the child: end its helpers, wait for them, leave."""
    for pid in helpers:
        try:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        except OSError:
            pass
    os._exit(1)
