"""``agvnav bench integrity``: its cases cover every fault kind and build; rows summarise runs honestly."""

import pytest

from agvnav.bench.integrity import MODELS, fault_cases, scenario_text, summarise
from agvnav.sim.build import build
from agvnav.world.scenario import FAULT_KINDS, parse_scenario


@pytest.mark.parametrize("model", list(MODELS))
def test_cases_cover_every_kind_at_two_severities_and_build(model):
    cases = fault_cases(MODELS[model][2])
    assert cases[0][0] == "none"
    for kind in FAULT_KINDS:
        assert sorted(s for k, s, _ in cases if k == kind) == ["mild", "severe"]
    for kind, severity, faults in cases:
        sc = parse_scenario(scenario_text(model, faults, 3), f"{model}_{kind}_{severity}")
        assert sc.seed == 3 and len(sc.faults) == len(faults)
        build(sc)


def test_summary_counts():
    runs = [
        {"outcome": "completed", "silent": False, "stop_demanded": False, "stopped_safely": False,
         "stop_distance_m": None, "max_true_lateral_m": 0.02, "nees_mean": 2.0},
        {"outcome": "positioning_lost", "silent": True, "stop_demanded": True, "stopped_safely": True,
         "stop_distance_m": 0.3, "max_true_lateral_m": 0.5, "nees_mean": 4.0},
    ]
    row = summarise("blind", "severe", "tricycle", runs)
    assert row["runs"] == 2 and row["silent_failures"] == 1
    assert row["stop_demands"] == 1 and row["stopped_safely"] == 1 and row["max_stop_distance_m"] == 0.3
    assert row["max_true_lateral_m"] == 0.5 and row["nees_mean"] == 3.0
    assert row["outcomes"] == "completed 1, positioning_lost 1"
