"""bench fleet's layout and memory projection helpers (the timed rows are the benchmark's, not a test's)."""

import numpy as np
import pytest

from agvnav.bench.fleet import SIZES, _baseline_growth, fleet_text, slots
from agvnav.world.fleet import parse_fleet


def test_the_slots_hold_the_largest_fleet_apart_inside_the_hall() -> None:
    xy = np.array([(x, y) for x, y, _ in slots()])
    assert xy.shape[0] >= max(SIZES)
    d = np.hypot(*(xy[:, None, :] - xy[None, :, :]).T)
    np.fill_diagonal(d, np.inf)
    assert d.min() >= 1.5  # rows 1.5 m apart, 3.5 m along a row
    assert xy[:, 0].min() > 1.0 and xy[:, 0].max() + 1.5 + 0.45 + 1.5 < 60.0  # the line, the body, the fields
    assert xy[:, 1].min() > 1.0 and xy[:, 1].max() < 39.0
    fleet = parse_fleet(fleet_text(max(SIZES), 0, 1.0, 0.75), "bench.yaml")
    assert len(fleet.fleet.vehicles) == max(SIZES) and fleet.record_step_s == 0.75
    with pytest.raises(ValueError, match="at most"):
        fleet_text(len(slots()) + 1, 0, 1.0)


def test_the_memory_growth_is_that_of_the_floor_not_of_the_transients() -> None:
    t = np.linspace(0.0, 40.0, 101)
    floor = 1000.0 + 50.0 * t  # 50 bytes/s
    spikes = np.where(np.arange(t.size) % 3 == 0, 5.0e5, 0.0)  # a step's arrays on top, now and then
    samples = list(zip(t.tolist(), (floor + spikes).astype(int).tolist(), strict=True))
    assert _baseline_growth(samples, 40.0) == pytest.approx(50.0, rel=0.1)  # within a sample spacing
    assert _baseline_growth(samples[:10], 40.0) == 0.0  # no sample in the last quarters
