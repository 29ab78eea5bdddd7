"""``agvnav bench traffic``: each row judged against the issue's targets, the judgement agreeing with the figures."""

from __future__ import annotations

from typing import Any

import pytest

from agvnav.bench import traffic


def _row(**kw: Any) -> dict[str, Any]:
    row = {"collisions": 0, "deadlocks": 0, "missed_conflicts": 0, "zone_missed": 0, "unserved": 0,
           "baseline_saturates": False, "gain_pct": 0.0, "plan_ms": 0.3, "replan_ms": 50.0}
    row.update(kw)
    return row


def test_a_row_meeting_every_target_says_so() -> None:
    assert traffic.judge(_row()) == "-"
    assert traffic.judge(_row(baseline_saturates=True, gain_pct=25.0)) == "-"


@pytest.mark.parametrize(("change", "named"), [
    ({"collisions": 1}, "collisions"), ({"deadlocks": 2}, "deadlocks"), ({"zone_missed": 1}, "zone_missed"),
    ({"missed_conflicts": 1}, "missed_conflicts"), ({"unserved": 3}, "unserved"),
    ({"baseline_saturates": True, "gain_pct": 19.9}, "gain<20%"), ({"plan_ms": 1.2}, "plan>1ms"),
    ({"replan_ms": 150.0}, "replan>100ms"),
])
def test_each_target_missed_is_named(change: dict[str, Any], named: str) -> None:
    assert traffic.judge(_row(**change)).split(",") == [named]


def test_a_gain_under_target_away_from_saturation_is_not_judged() -> None:
    assert traffic.judge(_row(gain_pct=-50.0)) == "-"


@pytest.mark.slow
def test_the_quick_bench_rows_are_judged_from_their_own_figures() -> None:
    rows = traffic.run(quick=True)
    assert {r["case"] for r in rows} == {"lane_swap", *traffic.NETWORKS, traffic.HALL, traffic.TOTAL}
    total = next(r for r in rows if r["case"] == traffic.TOTAL)
    assert total["runs"] == traffic.QUICK_RUNS * (len(traffic.SWAP_SIZES) + 2 * len(traffic.NETWORKS))
    for r in rows:
        assert r["missed_targets"] == traffic.judge(r)
        assert r["collisions"] == 0 and r["deadlocks"] == 0 and r["zone_missed"] == 0


def test_the_hall_rows_pair_our_layout_with_the_baseline_s_and_mark_its_peak() -> None:
    rows = []
    for n, ours, base_grid, base_oneway in ((5, 70.0, 10.0, 40.0), (10, 130.0, 3.0, 80.0), (20, 150.0, 0.0, 75.0)):
        rows.append(_row(case=traffic.OURS_LAYOUT, vehicles=n, deliveries_per_h=ours,
                         baseline_deliveries_per_h=base_grid, baseline_deadlocks=2))
        rows.append(_row(case=traffic.BASELINE_LAYOUT, vehicles=n, deliveries_per_h=ours / 2,
                         baseline_deliveries_per_h=base_oneway, baseline_deadlocks=0))
    rows += traffic._hall_rows(rows)
    traffic._saturation(rows)
    hall = [r for r in rows if r["case"] == traffic.HALL]
    assert [(r["deliveries_per_h"], r["baseline_deliveries_per_h"], r["baseline_deadlocks"]) for r in hall] == [
        (70.0, 40.0, 0), (130.0, 80.0, 0), (150.0, 75.0, 0)]
    assert [r["baseline_saturates"] for r in hall] == [False, True, False]
    assert hall[1]["gain_pct"] == pytest.approx(62.5)
    assert traffic.judge(hall[1]) == "-"
    layout = [r for r in rows if r["case"] != traffic.HALL]  # their peak shown, the target judged on the hall
    assert not any(r["baseline_saturates"] for r in layout)
    assert [r["baseline_peak"] for r in layout] == [True, False, False, True, False, False]


def test_the_default_bench_makes_the_issue_s_thousand_runs() -> None:
    """Ten Monte Carlo rows (lane swap 4 and 8, both layouts at 5-30 vehicles) of 100 runs: 1,000."""
    n_rows = len(traffic.SWAP_SIZES) + len(traffic.NETWORKS) * len(traffic.SIZES)
    assert n_rows == 10
    assert traffic.runs_per_row() * n_rows >= traffic.TOTAL_RUNS == 1000
    assert traffic.runs_per_row(quick=True) == traffic.QUICK_RUNS
    with pytest.raises(ValueError, match="runs per row"):
        traffic.run(runs=0)


def test_the_total_row_sums_the_monte_carlo_rows_not_the_hall_rows() -> None:
    """The headline ``all_runs`` row agrees with the rows it sums; the hall rows (the same runs paired) are left out."""
    rows = []
    for case, n, col, dead in (("lane_swap", 4, 0, 0), ("lane_swap", 8, 1, 0), (traffic.OURS_LAYOUT, 5, 0, 2),
                               (traffic.BASELINE_LAYOUT, 5, 0, 1)):
        rows.append(_row(case=case, vehicles=n, runs=100, collisions=col, deadlocks=dead, conflict_violations=col,
                         replans=3, replans_tried=4, deliveries_per_h=10.0, baseline_deliveries_per_h=5.0))
    rows += traffic._hall_rows(rows)
    total = traffic._total_row(rows)
    assert total["case"] == traffic.TOTAL and total["vehicles"] == "4-8"
    assert (total["runs"], total["collisions"], total["deadlocks"], total["replans"]) == (400, 1, 3, 12)
    assert traffic.judge(total) == "collisions,deadlocks"
