"""report.plot_worker: the forked plotter writes the files write_plots writes, and reports failures."""

from __future__ import annotations

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


def test_forked_plots_equal_inline_plots(tmp_path: Path) -> None:
    inline = write_plots(*_args(tmp_path / "inline"))
    with PlotWorker() as worker:
        assert worker.forked == (threading.active_count() == 1)  # a threaded process draws inline
        forked = worker.submit(*_args(tmp_path / "forked"))()
    names = ["map.png", "errors.png", "positioning_histogram.png"]
    assert [p.name for p in forked] == [p.name for p in inline] == names
    for a, b in zip(inline, forked, strict=True):
        assert a.read_bytes() == b.read_bytes()  # same function, same data: the same PNG


def test_a_drawing_failure_is_raised_in_the_caller_with_its_type(tmp_path: Path) -> None:
    args = list(_args(tmp_path))
    args[0] = {"t": np.zeros(3)}  # no positions: write_plots raises KeyError, forked or inline
    with PlotWorker() as worker, pytest.raises(KeyError, match="x_tracked"):
        worker.submit(*args)()  # inline: raised by submit; forked: by the wait


def test_an_unused_worker_closes_at_once() -> None:
    worker = PlotWorker()
    worker.close()
    worker.close()  # twice is harmless
