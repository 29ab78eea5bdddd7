"""``agvnav bench speed``: record shapes on tiny configurations (the timings are printed, never asserted)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.bench import speed
from agvnav.world import WorldMap

CASE_KEYS = {"case", "real_time_factor_cpu", "us_per_step", "steps", "simulated_s", "peak_mib", "timed"}


@pytest.mark.parametrize("n", [3, 16, 256])
def test_reflector_map_spreads_n_reflectors_inside_the_lab_walls(n: int) -> None:
    world = WorldMap.from_dict(speed.reflector_map(n))
    xy = world.reflector_xy
    assert xy.shape == (n, 2)
    assert np.all((xy > 0.0) & (xy < np.array(speed.LAB_SIZE)))
    # 5 cm inside the outer rectangle: every reflector is on one of its four sides
    near = np.minimum.reduce([xy[:, 0], xy[:, 1], speed.LAB_SIZE[0] - xy[:, 0], speed.LAB_SIZE[1] - xy[:, 1]])
    np.testing.assert_allclose(near, 0.05, atol=1e-9)
    assert len({tuple(p) for p in np.round(xy, 6)}) == n
    with pytest.raises(ValueError, match="at least 3"):
        speed.reflector_map(2)


def test_case_names_cover_the_issue_list() -> None:
    quick = speed.case_scenarios(True)
    assert list(quick) == ["default", "reflectors_16", "reflectors_64", "reflectors_256"]
    full = speed.case_scenarios(False)
    assert {"positioning_validation", "tracked", "differential_loop", "mecanum_loop"} <= set(full)


def test_case_record_shape_on_a_short_run() -> None:
    rec = speed.case_record("default", speed.case_scenarios(True)["default"](), repeat=1, max_duration=1.0)
    assert set(rec) == CASE_KEYS
    assert rec["case"] == "default" and rec["timed"] == "loop"
    assert rec["steps"] == 20 and math.isclose(rec["simulated_s"], 1.0)
    assert rec["real_time_factor_cpu"] > 0 and rec["us_per_step"] > 0 and rec["peak_mib"] > 0
    # the factor and the step cost describe the same CPU time
    cpu = rec["simulated_s"] / rec["real_time_factor_cpu"]
    assert math.isclose(cpu, rec["us_per_step"] * 1e-6 * rec["steps"], rel_tol=0.05)


def test_case_in_process_gives_the_same_record_shape_or_the_error() -> None:
    rec = speed.case_in_process("default", True, 1, 0.5)
    assert set(rec) == CASE_KEYS and rec["steps"] == 10
    bad = speed.case_in_process("no_such_case", True, 1, 0.5)
    assert bad["case"] == "no_such_case" and "KeyError" in bad["error"]


def test_memory_record_shape() -> None:
    rec = speed.memory_record(0.01)  # 36 s simulated in a fresh process
    assert set(rec) == {"case", "simulated_h", "peak_rss_mib", "recorded_rows", "events", "real_time_factor_cpu"}
    assert rec["case"] == "memory_24h" and rec["simulated_h"] == pytest.approx(0.01, abs=1e-3)
    assert rec["recorded_rows"] == 721 and rec["events"] > 0 and rec["peak_rss_mib"] > 10


def test_startup_records_shape() -> None:
    recs = speed.startup_records(repeat=1)
    assert [r["case"] for r in recs] == ["startup_help", "startup_simulate"]
    assert all(r["startup_s"] > 0 for r in recs)
    assert all(r["cpu_s"] > 0 for r in recs)  # the command's own CPU (simulate: with its plot child)


def test_campaign_record_shape() -> None:
    recs = speed.campaign_records(2, workers=(1,))
    assert len(recs) == 1
    rec = recs[0]
    assert set(rec) == {"case", "runs", "workers", "startup_s", "wall_s", "runs_per_s", "cpu_s_per_run", "est_10000_s"}
    assert rec["case"] == "campaign" and rec["runs"] == 2 and rec["workers"] == 1
    assert rec["startup_s"] > 0 and rec["wall_s"] > 0 and rec["cpu_s_per_run"] > 0
    assert rec["runs_per_s"] == pytest.approx(2 / rec["wall_s"], rel=0.05, abs=0.006)  # printed to 0.01 run/s
    # wall_s is printed to 0.01 s: up to 0.005 s of it is rounding, 25 s of the 10,000-run estimate from 2 runs
    assert rec["est_10000_s"] == pytest.approx(10_000 * rec["wall_s"] / 2, abs=10_000 * 0.005 / 2 + 1)
