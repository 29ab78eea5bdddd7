"""The vehicle kinds' registry: one spec class per kind states its facts; every reader takes them from there."""

from __future__ import annotations

import typing

import numpy as np
import pytest

from agvnav.guidance import FAMILIES
from agvnav.routes.planning import VehicleLimits
from agvnav.vehicles import PLANT_BUILDERS, build_plant
from agvnav.world.vehicle_specs import VEHICLE_KINDS, VEHICLE_MODELS, VehicleKindSpec, VehicleSpec, vehicle_kind


def _spec(model: str) -> VehicleKindSpec:
    """The default spec of ``model``, as a scenario's ``vehicle: {model: ...}`` gives it."""
    return vehicle_kind(model).model_validate({"model": model})


def test_the_registry_is_the_scenario_union() -> None:
    members = typing.get_args(typing.get_args(VehicleSpec)[0])
    assert tuple(VEHICLE_KINDS.values()) == members
    assert tuple(VEHICLE_KINDS) == VEHICLE_MODELS and len(VEHICLE_MODELS) == 9


@pytest.mark.parametrize("model", VEHICLE_MODELS)
def test_every_kind_states_its_facts_and_builds_a_plant_of_its_family(model: str) -> None:
    kind = vehicle_kind(model)
    assert kind.family in FAMILIES
    assert isinstance(kind.reverses, bool) and isinstance(kind.turns_on_spot, bool)
    assert kind in PLANT_BUILDERS
    spec = _spec(model)
    plant = build_plant(spec, [0.0, 0.0, 0.0, 0.0])
    assert plant.family == kind.family
    np.testing.assert_array_equal(plant.pose, [0.0, 0.0, 0.0])


def test_the_planner_reads_the_kinds_facts() -> None:
    for model, kind in VEHICLE_KINDS.items():
        limits = VehicleLimits(model)
        assert (limits.turns_on_spot, limits.reverses) == (kind.turns_on_spot, kind.reverses)
    assert {m for m, k in VEHICLE_KINDS.items() if k.turns_on_spot} == {"differential", "tracked", "mecanum"}
    assert [m for m, k in VEHICLE_KINDS.items() if not k.reverses] == ["tractor_trailer"]


def test_an_unknown_kind_is_refused_naming_the_valid_ones() -> None:
    with pytest.raises(ValueError, match="unknown vehicle model 'hovercraft'; valid models: tricycle, "):
        vehicle_kind("hovercraft")
    with pytest.raises(ValueError, match="unknown vehicle model 'hovercraft'"):
        VehicleLimits("hovercraft")
