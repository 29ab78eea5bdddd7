"""Fleet documents (issue 28): shared keys, a vehicle's own keys, located errors, seeds."""

from __future__ import annotations

import pytest

from agvnav.world.fleet import load_fleet, parse_fleet, vehicle_seed
from agvnav.world.scenario import ScenarioError, parse_scenario

FLEET = """\
name: pair
seed: 7
step_s: 0.05
map: lab
goniometer: {mount: [0.1, 0.0, 0.0]}
vehicle: {model: differential}
fleet:
  vehicles:
    - id: a
      path: {start: [3.0, 2.0, 0.0], segments: [{type: line, length_m: 2.0}]}
    - id: b
      goniometer: {mount: [0.0, 0.0, 0.0]}
      path: {start: [3.0, 8.0, 0.0], segments: [{type: line, length_m: 2.0}]}
"""


def test_vehicles_take_shared_keys_unless_they_give_their_own() -> None:
    fleet = parse_fleet(FLEET, "pair.yaml")
    a, b = fleet.vehicle_scenarios()
    assert (a.name, b.name) == ("pair.a", "pair.b")
    assert a.goniometer is not None and a.goniometer.mount == (0.1, 0.0, 0.0)
    assert b.goniometer is not None and b.goniometer.mount == (0.0, 0.0, 0.0)
    assert a.vehicle.model == b.vehicle.model == "differential"
    assert a.seed == 7 and b.seed == vehicle_seed(7, 1) != 7


def test_vehicle_seeds_differ_and_vehicle_zero_keeps_the_fleet_seed() -> None:
    seeds = [vehicle_seed(3, i) for i in range(5)]
    assert seeds[0] == 3 and len(set(seeds)) == 5


def test_duplicate_ids_are_refused_with_line_and_key() -> None:
    text = FLEET.replace("- id: b", "- id: a")
    with pytest.raises(ScenarioError) as err:
        parse_fleet(text, "pair.yaml")
    assert "duplicate vehicle id 'a'" in str(err.value)
    assert str(err.value).startswith("pair.yaml:11: fleet.vehicles[1].id: duplicate vehicle id")


def test_a_vehicle_error_names_the_fleet_file_line_and_key() -> None:
    text = FLEET.replace("goniometer: {mount: [0.0, 0.0, 0.0]}", "goniometer: {mount: [0.0, 0.0, 0.0], rate: 3}")
    with pytest.raises(ScenarioError) as err:
        parse_fleet(text, "pair.yaml")
    assert str(err.value).startswith("pair.yaml:12: fleet.vehicles[1].goniometer.rate: unknown key")


def test_a_vehicle_without_mission_or_path_is_refused() -> None:
    text = FLEET.replace("      path: {start: [3.0, 2.0, 0.0], segments: [{type: line, length_m: 2.0}]}\n", "", 1)
    with pytest.raises(ScenarioError, match=r"pair.yaml:9: fleet.vehicles\[0\]: vehicle 'a' has no mission or path"):
        parse_fleet(text, "pair.yaml")


def test_a_fleet_is_not_a_single_vehicle_scenario() -> None:
    with pytest.raises(ScenarioError, match=r"pair.yaml:7: fleet: a fleet scenario"):
        parse_scenario(FLEET, "pair.yaml")


def test_the_shipped_fleet_loads() -> None:
    fleet = load_fleet("warehouse_fleet")
    scenarios = fleet.vehicle_scenarios()
    assert len(scenarios) >= 3
    assert len({s.vehicle.model for s in scenarios}) >= 2
    assert all(s.mission is not None for s in scenarios)
