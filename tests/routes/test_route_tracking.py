"""The mission's lateral error measures tracking: known offsets come back exactly, also where a reverse
run retraces a forward one (the projection must not jump to the other run)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from routes_tiny_mission import run_tiny

from agvnav.navigation.mission import run_bounds
from agvnav.sim.mission import mission_figures, near_line_curve_joints, plan_mission, route_tracking


def synthetic_series(tmp_path: Path, offsets: dict[int, float]) -> tuple[dict[str, np.ndarray], object]:
    """A drive of the tiny mission exactly along its plan, the guided point ``offsets[run]`` m left of it."""
    plan = plan_mission(run_tiny(tmp_path))
    bounds = run_bounds(plan)
    s = np.concatenate([np.linspace(bounds[r], bounds[r + 1], 200) for r in range(len(bounds) - 1)])
    run = np.concatenate([np.full(200, r) for r in range(len(bounds) - 1)])
    off = np.array([offsets.get(int(r), 0.0) for r in run])
    h = plan.path.heading_at(s)
    pts = plan.path.point_at(s) + off[:, None] * np.column_stack([-np.sin(h), np.cos(h)])
    psi = h + np.where(plan.path.direction_at(s) < 0, math.pi, 0.0)
    series = {"t": np.arange(len(s)) * 0.05, "x": pts[:, 0], "y": pts[:, 1], "psi": psi,
              "x_tracked": pts[:, 0].copy(), "y_tracked": pts[:, 1].copy(), "s_est": s,
              "v_cmd": np.where(plan.path.direction_at(s) < 0, -0.3, 0.3)}
    return series, plan


def test_known_offsets_come_back_on_every_run(tmp_path: Path) -> None:
    # runs: leg 0 A->C, leg 1 C->D, leg 2 D->C backing up along the same line (retraced)
    series, plan = synthetic_series(tmp_path, {0: 0.0, 1: 0.05, 2: -0.12})
    assert len(run_bounds(plan)) - 1 == 3  # type: ignore[arg-type]
    s, lat = route_tracking(series, plan)  # type: ignore[arg-type]
    assert s == pytest.approx(series["s_est"], abs=1e-9)
    want = np.concatenate([np.zeros(200), np.full(200, 0.05), np.full(200, -0.12)])
    inner = np.ones(600, dtype=bool)
    inner[[0, 199, 200, 399, 400, 599]] = False  # at the run ends the tangent of the next run also counts
    assert lat[inner] == pytest.approx(want[inner], abs=1e-9)
    fig = mission_figures(series, plan, [])  # type: ignore[arg-type]
    assert fig["max_lateral_m.line"] == pytest.approx(0.12, abs=1e-9)  # the metric can come out high
    assert fig["max_lateral_m.arc"] == pytest.approx(0.0, abs=1e-9)


def test_a_projection_on_the_whole_path_would_jump(tmp_path: Path) -> None:
    # the reverse run C<-D retraces C->D: projecting onto the whole path finds the forward run
    series, plan = synthetic_series(tmp_path, {2: 0.1})
    path = plan.path  # type: ignore[attr-defined]
    pts = np.column_stack([series["x"], series["y"]])[400:]
    whole = path.project(pts)
    assert np.any(np.abs(whole.s - series["s_est"][400:]) > 0.5)  # lands on the forward run
    s, lat = route_tracking(series, plan)  # type: ignore[arg-type]
    assert s[400:] == pytest.approx(series["s_est"][400:], abs=1e-9)
    assert np.abs(lat[401:599]) == pytest.approx(np.full(198, 0.1), abs=1e-9)


def test_joint_windows_are_the_same_around_every_forward_line_curve_joint(tmp_path: Path) -> None:
    # forward joints: A-B line -> B-C arc at s = 4, arc -> C-D line at s = 4 + pi; the run back is reverse
    series, plan = synthetic_series(tmp_path, {1: 0.05})
    j1, j2 = 4.0, 4.0 + math.pi
    s = np.array([3.4, 3.6, 5.4, 5.6, j2 - 0.6, j2 - 0.4, j2 + 1.4, j2 + 1.6])
    assert near_line_curve_joints(plan, s).tolist() == [False, True, True, False, False, True, True, False]  # type: ignore[arg-type]
    assert near_line_curve_joints(plan, np.array([j1, j2])).all()  # type: ignore[arg-type]
    fig = mission_figures(series, plan, [])  # type: ignore[arg-type]
    assert fig["max_lateral_m.line_curve_joints"] == pytest.approx(0.05, abs=1e-9)  # C-D after the arc
