"""``agvnav bench vda5050``: its parts on small sizes, and the total row agreeing with the scenario rows."""

from __future__ import annotations

import math

from agvnav.bench import vda5050 as bench


def test_conformance_small_run_all_valid() -> None:
    rec = bench.conformance("3.0.0", 1, 10.0, 0)
    assert rec["checked"] > 10 and rec["failed"] == 0 and rec["verdict"] == "met"


def test_fault_scenarios_give_their_faults_to_the_hall() -> None:
    faults = bench.fault_scenario_faults("fault_reflectors")
    assert {f["reflector"] for f in faults} == {"S2", "S3"}  # lab R3, R8 -> hall
    rep = bench._repeated([{"kind": "blind", "start_s": 4.0, "duration_s": 12.0}, {"kind": "clutter",
                                                                                  "per_revolution": 3.0}], 130.0)
    assert [f.get("start_s") for f in rep] == [4.0, 64.0, 124.0, None]


def test_total_row_agrees_with_scenario_rows() -> None:
    rows = [{"checked": 60_000, "failed": 30, "localized_while_lost": 0, "states": 61_000},
            {"checked": 50_000, "failed": 80, "localized_while_lost": 0, "states": 50_000}]
    tot = bench._deviation_total(rows)
    assert tot["checked"] == 110_000 and tot["failed"] == 110 and math.isclose(tot["rate"], 1e-3)
    assert tot["verdict"] == "met"
    rows[1]["failed"] = 81
    assert bench._deviation_total(rows)["verdict"].startswith("MISSED: miss rate")
    rows[0]["localized_while_lost"] = 1
    assert "localized while lost" in bench._deviation_total(rows)["verdict"]
    assert "10^5" in bench._deviation_total(rows[:1])["verdict"]


def test_total_row_states_the_median_bound_over_all_states_and_says_when_it_is_useless() -> None:
    rows = [{"checked": 3, "failed": 0, "localized_while_lost": 0, "states": 3, "_ranges": [0.02, 0.03, 0.04]},
            {"checked": 2, "failed": 0, "localized_while_lost": 0, "states": 2, "_ranges": [1.0, 2.0]}]
    tot = bench._deviation_total(rows)
    assert tot["median_range_m"] == 0.04 and tot["bound"] == "useful"
    assert all("_ranges" not in r for r in rows)  # private: popped before the rows are printed
    assert bench._usefulness([1.0, 2.0]).startswith("USELESS (median 1.50 m")
    assert bench._usefulness([]) == "none stated"
