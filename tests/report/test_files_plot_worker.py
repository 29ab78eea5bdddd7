"""report.files with the plot worker: a failed save leaves no stray folder and no drawing process behind."""

from __future__ import annotations

import json
import multiprocessing
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest


def _fake_result() -> Any:
    """What save_result reads of a run, for the plots; the data files are made to fail before any is written."""
    n = 60
    t = np.linspace(0.0, 6.0, n)
    x, y = 0.5 * t, 0.02 * np.sin(t)
    series = {
        "t": t, "x_tracked": x, "y_tracked": y, "x": x, "y": y, "psi": np.zeros(n),
        "est_x": x + 0.003, "est_y": y - 0.002, "est_psi": np.full(n, 1e-3), "est_valid": np.ones(n),
        "lateral_error": y, "heading_error": 0.01 * np.cos(t),
    }
    world = SimpleNamespace(reflector_xy=np.array([[0.0, 2.0], [3.0, 2.0]]), wall_segments=np.zeros((0, 2, 2)))
    return SimpleNamespace(
        series=series, path_polyline=lambda spacing=0.05: np.column_stack([x, np.zeros(n)]), world=world,
        transient_end_s=1.0, scenario=SimpleNamespace(name="fake", mission=None), events={},
    )


def _own_processes() -> list[int]:
    """Every other process of this session (the fresh interpreter runs in its own session)."""
    me, sid = os.getpid(), os.getsid(0)
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == me:
            continue
        try:
            if os.getsid(int(entry.name)) == sid:
                found.append(int(entry.name))
        except OSError:
            continue
    return found


def _failed_save(root: Path) -> dict[str, Any]:
    """Run in a fresh interpreter: metrics.json fails to write once the worker has the job."""
    import agvnav.report.files as files
    import agvnav.report.plots as plots
    from agvnav.report.plot_worker import PlotWorker

    plots.warm_up()  # matplotlib ready before the fork: the children draw at once
    found: dict[str, Any] = {}

    def full_disk(result: Any) -> dict[str, Any]:
        raise OSError(28, "No space left on device", "metrics.json")

    files.metrics_document = full_disk  # the first data file fails, after the worker has its job
    with PlotWorker() as worker:
        found["forked"] = worker.forked
        try:
            files.save_result(_fake_result(), root / "run", plots=True, plotter=worker)
        except OSError as exc:
            found["error"] = exc.errno
        found["children_after_save"] = len(multiprocessing.active_children())
        found["processes_after_save"] = _own_processes()
    found["left"] = sorted(str(p.relative_to(root)) for p in root.rglob("*"))
    return found


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="no fork: plots drawn inline")
def test_a_failed_save_leaves_no_folder_and_no_drawing_process(tmp_path: Path) -> None:
    code = (
        "import importlib.util, json; from pathlib import Path\n"
        f"spec = importlib.util.spec_from_file_location('fw_checks', {str(Path(__file__))!r})\n"
        "m = importlib.util.module_from_spec(spec); spec.loader.exec_module(m)\n"
        f"print(json.dumps(m._failed_save(Path({str(tmp_path)!r}))))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False, start_new_session=True
    )
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found["forked"] and found["error"] == 28
    # the children had finished (or ended) before atomic_dir removed the temporary folder ...
    assert found["children_after_save"] == 0 and found["processes_after_save"] == []
    # ... so none created it again to put its PNGs in
    assert found["left"] == []
