"""Conflict zones: sound against the brute-force footprint check, and the API's contract."""

from __future__ import annotations

import math

import pytest
import shapely

from agvnav.routes.layouts import grid_network
from agvnav.routes.network import load_network, network_from_dict
from agvnav.traffic.zones import (
    ConflictZones,
    conflict_zones,
    find_missed_conflicts,
    missed_conflicts,
    model_footprint,
)
from agvnav.world.vehicle_specs import VEHICLE_MODELS

SHIPPED = ("hall_loop", "hall_loop_arcs", "warehouse", "warehouse_arcs")


@pytest.fixture(scope="module")
def hall() -> tuple[object, ConflictZones]:
    net = load_network("hall_loop")
    return net, conflict_zones(net, VEHICLE_MODELS)


def test_no_missed_conflict_on_the_hall_loop_for_every_model(hall: tuple[object, ConflictZones]) -> None:
    net, zones = hall
    assert missed_conflicts(net, VEHICLE_MODELS, zones, step_m=0.05) == 0  # type: ignore[arg-type]


@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED)
def test_no_missed_conflict_on_every_shipped_network(name: str) -> None:
    net = load_network(name)
    zones = conflict_zones(net, VEHICLE_MODELS)
    assert find_missed_conflicts(net, VEHICLE_MODELS, zones, step_m=0.02) == []


def test_the_check_finds_a_conflict_the_zones_leave_out(hall: tuple[object, ConflictZones]) -> None:
    net, zones = hall
    table = dict(zones.tables[("tricycle", "tricycle")])
    res = ("edge", "b2")
    table[res] = frozenset(r for r in table[res] if r != ("edge", "b2~r"))
    tables = dict(zones.tables)
    tables[("tricycle", "tricycle")] = table
    broken = ConflictZones(zones.network, zones.models, zones.margin_m, zones.shapes, zones.resources, tables,
                           zones.edge_ends)
    missed = find_missed_conflicts(net, ["tricycle"], broken, step_m=0.1)  # type: ignore[arg-type]
    assert ("tricycle", res, "tricycle", ("edge", "b2~r")) in missed


def test_conflicts_hold_the_resource_its_twin_and_its_end_nodes(hall: tuple[object, ConflictZones]) -> None:
    _, zones = hall
    c = zones.conflicts("tricycle", ("edge", "b2"), "differential")
    assert {("edge", "b2"), ("edge", "b2~r"), ("node", "S1"), ("node", "P")} <= c
    assert ("edge", "t1") not in c  # the top lane is 8 m away


def test_conflicts_are_symmetric_between_models(hall: tuple[object, ConflictZones]) -> None:
    _, zones = hall
    for ra, rb in zones.pairs("tricycle", "mecanum"):
        assert ra in zones.conflicts("mecanum", rb, "tricycle")


def test_a_spot_turning_model_occupies_the_disc_at_a_node(hall: tuple[object, ConflictZones]) -> None:
    _, zones = hall
    shape = zones.shapes["differential"][("node", "S1")]
    radius = math.hypot(*model_footprint("differential")[0])
    assert shape.contains(shapely.Point(8.0, 3.0).buffer(radius * (1.0 - 1e-9), quad_segs=32))


def test_backing_up_sweeps_the_footprint_turned_by_pi(hall: tuple[object, ConflictZones]) -> None:
    net, zones = hall
    # b1 (SW -> S1, heading 0) is driven both ways: the tricycle's 1.36 m nose reaches past either end
    x0, _, x1, _ = zones.shapes["tricycle"][("edge", "b1")].bounds
    sw = net.nodes["SW"].x  # type: ignore[attr-defined]
    assert x0 == pytest.approx(sw - 1.36) and x1 == pytest.approx(8.0 + 1.36)
    # the one-way r1 (heading 90 deg, forward only) has the nose ahead and 0.24 m behind
    _, y0, _, y1 = zones.shapes["tricycle"][("edge", "r1")].bounds
    assert y0 == pytest.approx(net.nodes["ES"].y - 0.24) and y1 == pytest.approx(7.0 + 1.36)  # type: ignore[attr-defined]


def test_bad_input_is_a_value_error(hall: tuple[object, ConflictZones]) -> None:
    net, zones = hall
    with pytest.raises(ValueError, match="unknown vehicle model 'bus'"):
        conflict_zones(net, ["bus"])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="not in these conflict zones"):
        zones.conflicts("tricycle", ("node", "S1"), "bus")
    with pytest.raises(ValueError, match="not in network"):
        zones.conflicts("tricycle", ("node", "nowhere"), "tricycle")
    with pytest.raises(ValueError, match="margin_m"):
        conflict_zones(net, ["tricycle"], margin_m=-1.0)  # type: ignore[arg-type]


def test_zones_group_parts_of_the_network_that_do_not_touch(hall: tuple[object, ConflictZones]) -> None:
    _, zones = hall
    groups = zones.zones()
    assert groups and all(len(g) >= 2 for g in groups)
    # the dock arc d1 (P -> D1) sweeps the tricycle's nose over the dock node D, which is not its end
    assert frozenset({("edge", "d1"), ("edge", "d1~r"), ("node", "D1"), ("node", "D")}) in groups
    assert not any(("edge", "t2") in g for g in groups)  # the NURBS bend on the top lane is alone


def test_a_grid_is_fast_and_its_far_lanes_do_not_conflict() -> None:
    net = network_from_dict(grid_network(6, spacing=5.0))
    zones = conflict_zones(net, ["tricycle", "differential"])
    c = zones.conflicts("tricycle", ("edge", "h0_0"), "tricycle")
    assert ("edge", "h0_2") not in c and ("node", "n1_0") in c
    assert missed_conflicts(net, ["tricycle", "differential"], zones, step_m=0.1) == 0  # type: ignore[arg-type]
