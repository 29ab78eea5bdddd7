"""Summary statistics against hand-computed values (Student t interval)."""

import math

import numpy as np
import pyarrow as pa

from agvnav.campaign import describe, summarize


def test_describe_matches_hand_values():
    s = describe(np.array([1.0, 2.0, 3.0, 4.0, np.nan]))
    assert s["n"] == 4 and s["mean"] == 2.5 and s["median"] == 2.5
    std = math.sqrt(5.0 / 3.0)
    assert math.isclose(s["std"], std)
    half = 3.182446305284263 * std / 2.0  # t(0.975, 3)
    assert np.allclose(s["ci95"], [2.5 - half, 2.5 + half], rtol=1e-12)
    assert math.isclose(s["q05"], 1.15) and math.isclose(s["q95"], 3.85)


def test_describe_small_samples():
    assert describe(np.array([np.nan]))["mean"] is None
    one = describe(np.array([2.0]))
    assert one["mean"] == 2.0 and one["std"] is None and one["ci95"] is None


def test_summarize_groups_and_counts_only_completed():
    table = pa.table({
        "run": [0, 1, 2, 3],
        "outcome": ["completed", "completed", "failed", "completed"],
        "param.v": [0.2, 0.2, 0.3, 0.3],
        "metric.e": [1.0, 3.0, 100.0, 5.0],
    })
    s = summarize(table, ["v"])
    assert s["metrics"] == ["e"] and [g["params"] for g in s["groups"]] == [{}, {"v": 0.2}, {"v": 0.3}]
    assert s["groups"][0]["metrics"]["e"]["mean"] == 3.0
    assert s["groups"][1]["metrics"]["e"]["mean"] == 2.0
    assert s["groups"][2]["outcomes"] == {"completed": 1, "failed": 1, "error": 0}
    assert s["groups"][2]["metrics"]["e"]["n"] == 1
