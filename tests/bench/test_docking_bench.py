"""Issue 32: bench docking's records: the headline figures agree with the runs they summarise."""

from __future__ import annotations

import math

import pytest

from agvnav.bench import docking


def test_fault_cases_and_silent_failure_rule():
    cases = docking.fault_cases((0.0, 0.1), (0.0, -0.4), "b")
    assert set(cases) == {"missing", "moved_10mm", "clutter", "person", "person_walking"}
    assert cases["moved_10mm"]["moved"] == {"b": (0.0, 10.0)}
    assert cases["person"]["person"] == (0.3, -0.4)
    walk = cases["person_walking"]["person_walking"]
    assert walk.path == [(0.3, -1.9), (0.3, 1.1)] and walk.speed_m_s == docking.WALK_SPEED_M_S
    finished = {"docking_reported_finished": 1.0, "dock_error_m": 0.011, "dock_heading_error_rad": 0.0}
    assert docking._silent(finished)
    assert not docking._silent({**finished, "docking_reported_finished": 0.0})
    assert docking._silent({**finished, "dock_error_m": 0.001, "dock_heading_error_rad": math.radians(0.6)})


@pytest.mark.slow
def test_quick_bench_records():
    records = docking.run(quick=True, seed=0)
    assert [r["vehicle"] for r in records] == list(docking.VEHICLES)
    for r in records:
        assert r["station_offset_m"] == pytest.approx(0.02)
        assert r["silent_failures"] == 0
        assert r["target_met"] == (r["p95_error_m"] <= 0.003 and r["p95_heading_error_rad"] <= math.radians(0.1))
