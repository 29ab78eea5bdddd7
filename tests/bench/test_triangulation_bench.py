"""Benchmark pieces (accuracy and the C baseline's correctness; speed is never asserted)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from agvnav.bench import triangulation as bench
from agvnav.geometry import bearing_to


@pytest.mark.parametrize(("method", "limit"), [("least_squares", 1.1), ("absolute_angles", 1.5), ("total", 1.5)])
def test_grid_accuracy_against_the_crlb(method, limit):
    rng = np.random.default_rng(0)
    grid = bench._grid(quick=True, rng=rng)
    rec = bench._accuracy(method, bench.REFLECTORS_3, grid, rng)
    assert rec["valid_fraction"] == 1.0
    assert rec["rms_position_m"] < limit * rec["crlb_rms_position_m"]
    assert rec["rms_heading_rad"] < limit * rec["crlb_rms_heading_rad"]


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")
def test_c_baseline_compiles_and_solves(tmp_path):
    fn, note = bench._compile_c_total(tmp_path)
    assert fn is not None, note
    rng = np.random.default_rng(1)
    poses = bench._random_poses(2000, rng)
    bearings = bearing_to(poses[:, None, :], bench.REFLECTORS_3)
    call = bench._c_call(fn, bearings, poses, with_heading=True)  # checks the C solution (raises otherwise)
    with pytest.raises(RuntimeError, match="disagrees"):
        bench._c_call(fn, bearings + 0.01, poses, with_heading=True)
    assert bench.interleaved_best([call, call], rounds=2)[0] > 0.0


def test_interleaved_best_alternates_and_keeps_each_minimum():
    order: list[str] = []
    times = bench.interleaved_best([lambda: order.append("a"), lambda: order.append("b")], rounds=3)
    assert order == ["a", "b", "a", "b", "a", "b"] and len(times) == 2


def test_quick_run_reports_both_c_ratios():
    recs = bench.run(quick=True, seed=0)
    for r in recs:
        if r["c_total_ns_per_fix"] is not None:
            assert r["batch_over_c_position_only"] == pytest.approx(
                r["batch_ns_per_fix"] / r["c_total_position_only_ns_per_fix"])
            assert r["batch_over_c_total"] == pytest.approx(r["batch_ns_per_fix"] / r["c_total_ns_per_fix"])
