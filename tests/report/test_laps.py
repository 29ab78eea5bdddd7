"""The tracked-robot lap table (seed 004 Tables I-II) names its unit in every error column."""

from types import SimpleNamespace

import numpy as np
from rich.console import Console

from agvnav.report.laps import lap_table


def _result():
    laps = SimpleNamespace(per_lap_m=np.array([0.003, 0.012]), laps=2)
    rows = [
        {"lap": 1, "with_landmarks_per_lap_m": 0.003, "without_landmarks_per_lap_m": 0.481,
         "with_landmarks_from_start_m": 0.003, "without_landmarks_from_start_m": 0.481},
        {"lap": 2, "with_landmarks_per_lap_m": 0.012, "without_landmarks_per_lap_m": 0.456,
         "with_landmarks_from_start_m": 0.012, "without_landmarks_from_start_m": 0.937},
    ]
    scenario = SimpleNamespace(name="tracked_x", seed=0, route=SimpleNamespace(side_m=3.5),
                               vehicle=SimpleNamespace(terrain=SimpleNamespace(truth="concrete")))
    return SimpleNamespace(scenario=scenario, runs={True: SimpleNamespace(laps=laps),
                                                    False: SimpleNamespace(laps=laps)}, lap_rows=lambda: rows)


def test_the_lap_table_headers_carry_their_unit_and_the_values_are_in_it():
    console = Console(width=200, record=True, highlight=False)
    console.print(lap_table(_result()))
    text = console.export_text()
    for header in ("with landmarks (cm/lap)", "without landmarks (cm/lap)", "with: from start (cm)",
                   "without: from start (cm)"):
        assert header in text, text
    lap2 = next(line for line in text.splitlines() if line.strip("│ ").startswith("2 "))
    assert [c.strip() for c in lap2.split("│")[1:-1]] == ["2", "1.2", "45.6", "1.2", "93.7"]  # metres as cm
