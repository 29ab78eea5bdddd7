"""deviationRange in the state: the deviation watch's bound, fed every loop step (the covariance bound
standing among the hall's reflectors, small enough for finePositioning), none while not localized."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.positioning.deviation import covariance_radius
from agvnav.positioning.estimator import StreamingEstimator
from agvnav.vda5050.bus import InProcessBus
from agvnav.vda5050.vehicle import VdaVehicle, VehicleConfig
from agvnav.world.scenario import builtin_scenario, load_scenario


def test_deviation_range_is_the_watch_bound_and_none_while_not_localized(monkeypatch: pytest.MonkeyPatch) -> None:
    v = VdaVehicle(load_scenario(builtin_scenario("mission_hall_differential")),
                   VehicleConfig("M", "S", "2.1.0", state_period_s=5.0, deviation_max_speed_m_s=0.5))
    bus = InProcessBus({"S": v}, "2.1.0")
    while v.t < 1.0:
        bus.step()
    est = v.estimator
    watch = v._deviation
    assert isinstance(est, StreamingEstimator) and watch is not None
    r = v.deviation_range()
    assert r is not None and r == pytest.approx(covariance_radius(np.asarray(est.covariance)[:2, :2], 4.5))
    assert r < 0.01  # standing among the hall's reflectors: a few mm, finePositioning's 10 mm stays reachable
    assert watch.trusted and not watch.in_doubt and watch.anchor is not None
    assert watch.anchor.t == pytest.approx(v.t) and watch.max_speed == 0.5
    monkeypatch.setattr(type(est), "status", property(lambda self: "lost"))
    v._range_t = float("nan")
    assert v.deviation_range() is None
    with pytest.raises(ValueError, match="deviation_max_speed_m_s"):
        VehicleConfig("M", "S", deviation_max_speed_m_s=0.0)
