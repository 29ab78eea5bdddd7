"""Mission plots: the route coloured by lateral error and the per-station stop chart are written; bad shapes named."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from agvnav.report.routes import plot_mission_route, plot_station_stops
from agvnav.routes.layouts import hall_loop
from agvnav.routes.mission import Job, chain_mission, plan_legs
from agvnav.routes.network import network_from_dict
from agvnav.routes.planning import Planner, VehicleLimits


def test_mission_plots_are_written(tmp_path: Path) -> None:
    net = network_from_dict(hall_loop())
    legs = plan_legs(Planner(net, VehicleLimits("tricycle")), "S1", [Job("goto", "S2"), Job("goto", "S3")])
    plan = chain_mission(legs, np.array([8.0, 3.0]), math.radians(0.5))
    s = np.linspace(0.0, plan.path.length, 300)
    driven = np.asarray(plan.path.point_at(s))
    out = plot_mission_route(net, plan, driven, 0.01 * np.sin(s), tmp_path / "route.png")
    assert out.stat().st_size > 10_000
    out = plot_station_stops(["S2", "S3"], [0.004, 0.012], [0.001, 0.01], tmp_path / "stops.png")
    assert out.stat().st_size > 5_000
    with pytest.raises(ValueError, match="driven_xy must be"):
        plot_mission_route(net, plan, driven, np.zeros(3), tmp_path / "bad.png")
    with pytest.raises(ValueError, match="one station name per stop"):
        plot_station_stops(["S2"], [0.004, 0.012], [0.001, 0.01], tmp_path / "bad.png")
