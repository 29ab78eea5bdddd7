"""report.plot_worker: the forked plotter writes the files write_plots writes, and reports failures."""

from __future__ import annotations

import json
import multiprocessing
import os
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from agvnav.report.plot_worker import PlotWorker
from agvnav.report.plots import write_plots


def _series(n: int = 60) -> dict[str, np.ndarray]:
    t = np.linspace(0.0, 6.0, n)
    x, y = 0.5 * t, 0.02 * np.sin(t)
    return {
        "t": t, "x_tracked": x, "y_tracked": y, "x": x, "y": y, "psi": np.zeros(n),
        "est_x": x + 0.003, "est_y": y - 0.002, "est_psi": np.full(n, 1e-3), "est_valid": np.ones(n),
        "lateral_error": y, "heading_error": 0.01 * np.cos(t),
    }


def _args(out: Path) -> tuple[Any, ...]:
    path = np.column_stack([np.linspace(0, 3, 20), np.zeros(20)])
    refl = np.array([[0.0, 2.0], [3.0, 2.0], [1.5, -2.0]])
    walls = np.array([[[-1.0, -3.0], [4.0, -3.0]], [[4.0, -3.0], [4.0, 3.0]]])
    return (_series(), path, refl, walls, out, 2.5, "test")


def _forked_checks(out: Path) -> dict[str, Any]:
    """Run in a fresh single-threaded interpreter (see :func:`_in_fresh_process`): what the forked worker does."""
    import agvnav.report.plots as plots

    found: dict[str, Any] = {"threads": threading.active_count()}
    inline = write_plots(*_args(out / "inline"))  # matplotlib imported here: the children below start warm
    with PlotWorker() as worker:
        found["forked"] = worker.forked
        forked = worker.submit(*_args(out / "forked"))()
    found["names"] = [p.name for p in forked]
    found["same_bytes"] = [a.read_bytes() == b.read_bytes() for a, b in zip(inline, forked, strict=True)]

    def raised(args: list[Any]) -> BaseException | None:
        with PlotWorker() as worker:
            assert worker.forked
            wait = worker.submit(*args)
            try:
                wait()
            except Exception as exc:  # the test looks at it
                return exc
        return None

    no_positions = list(_args(out / "keyerror"))
    no_positions[0] = {"t": np.zeros(3)}
    found["keyerror"] = type(raised(no_positions)).__name__
    map_fails = list(_args(out / "first_share"))  # the map (child) fails at once, the helper draws on
    map_fails[0] = {k: v for k, v in _series().items() if k != "x_tracked"}
    exc = raised(map_fails)
    found["first_share"] = type(exc).__name__
    found["helper_done_before_raise"] = sorted(p.name for p in (out / "first_share").iterdir())

    save = plots._save

    def full_disk(fig: Any, out: str | Path, make_dir: bool = True) -> Path:
        raise OSError(28, "No space left on device", str(out))

    plots._save = full_disk  # before the fork: the children inherit it
    exc = raised(list(_args(out / "full")))
    found["full_disk"] = [type(exc).__name__, getattr(exc, "errno", None)]

    class Unpicklable(Exception):  # a local class: pickle cannot find it by name
        pass

    def odd(fig: Any, out: str | Path, make_dir: bool = True) -> Path:
        raise Unpicklable("odd failure")

    plots._save = odd
    exc = raised(list(_args(out / "odd")))
    found["unpicklable"] = [type(exc).__name__, str(exc)]
    plots._save = save

    def no_fonts() -> None:
        raise ValueError("no fonts")

    plots.warm_up = no_fonts
    exc = raised(list(_args(out / "warm")))
    found["warm_up"] = [type(exc).__name__, str(exc)]
    return found


def _in_fresh_process(tmp_path: Path) -> dict[str, Any]:
    """:func:`_forked_checks` in a new interpreter: single-threaded whatever the test runner runs (threads, xdist)."""
    code = (
        "import importlib.util, json, sys; from pathlib import Path\n"
        f"spec = importlib.util.spec_from_file_location('pw_checks', {str(Path(__file__))!r})\n"
        "m = importlib.util.module_from_spec(spec); spec.loader.exec_module(m)\n"
        f"print(json.dumps(m._forked_checks(Path({str(tmp_path)!r}))))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    found: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    found["stderr"] = done.stderr
    return found


needs_fork = pytest.mark.skipif(
    "fork" not in multiprocessing.get_all_start_methods(), reason="no fork on this platform: plots are drawn inline"
)


@needs_fork
def test_forked_worker_draws_like_inline_and_raises_like_inline(tmp_path: Path) -> None:
    found = _in_fresh_process(tmp_path)
    assert found["threads"] == 1 and found["forked"]  # a real fork: the comparison is not inline vs inline
    assert found["names"] == ["map.png", "errors.png", "positioning_histogram.png"]
    assert found["same_bytes"] == [True, True, True]  # same function, same data: the same PNG
    assert found["keyerror"] == "KeyError"  # the drawing's own exception, as inline (was RuntimeError)
    assert found["full_disk"] == ["OSError", 28]  # one line from the CLI (cli.errors), as inline
    assert found["unpicklable"][0] == "RuntimeError" and "Unpicklable: odd failure" in found["unpicklable"][1]
    assert found["warm_up"] == ["ValueError", "no fonts"]  # reported when the plots are collected ...
    assert "Traceback" not in found["stderr"]  # ... never printed by a child mid-run
    assert found["first_share"] == "KeyError"
    # raised only once the helper had finished its share: nothing still writes into the folder
    assert found["helper_done_before_raise"] == ["errors.png", "positioning_histogram.png"]


def test_forked_plots_equal_inline_plots(tmp_path: Path) -> None:
    """In this process: forked or inline (a threaded runner), the same files."""
    inline = write_plots(*_args(tmp_path / "inline"))
    with PlotWorker() as worker:
        forked = worker.submit(*_args(tmp_path / "forked"))()
    for a, b in zip(inline, forked, strict=True):
        assert a.read_bytes() == b.read_bytes()


def test_a_drawing_failure_is_raised_in_the_caller_with_its_type(tmp_path: Path) -> None:
    args = list(_args(tmp_path))
    args[0] = {"t": np.zeros(3)}  # no positions: write_plots raises KeyError, forked or inline
    with PlotWorker() as worker, pytest.raises(KeyError, match="x_tracked"):
        worker.submit(*args)()  # inline: raised by submit; forked: by the wait


def test_an_unused_worker_closes_at_once() -> None:
    worker = PlotWorker()
    pid = worker._proc.pid if worker.forked else None  # the test looks inside
    worker.close()
    # this worker's child only: another test in the same pytest process may still own children of its own
    assert pid not in {p.pid for p in multiprocessing.active_children()}
    if pid is not None:
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)  # reaped: gone, not a zombie
    worker.close()  # twice is harmless
    assert pid not in {p.pid for p in multiprocessing.active_children()}
