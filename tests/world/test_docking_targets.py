"""Issue 32: docking targets in the map; bad input refused with file, line and key."""

from __future__ import annotations

import math

import pytest

from agvnav.world.docking import DockingTarget, check_target, load_docking_targets, parse_docking_targets
from agvnav.world.map import WorldMap, load_map
from agvnav.world.strict import ScenarioError

TARGET = """reflectors: []
docking_targets:
  - id: PAL
    station: [4.0, 0.3, 90.0]
    reflectors:
      - {id: a, x: 0.0, y: -0.50}
      - {id: b, x: 0.0, y: 0.15}
      - {id: c, x: 0.0, y: 0.50}
    docking_pose: [1.0, 0.0, 0.0]
    approach_m: 3.0
    direction: reverse
"""


def test_shipped_map_holds_two_targets_and_loads_as_a_map():
    doc = load_docking_targets(load_map.__globals__["_maps_dir"]() / "docking_bay.yaml")
    assert [t.id for t in doc.docking_targets] == ["PAL", "CH"]
    t = DockingTarget.from_spec(doc.docking_targets[0])
    assert t.direction == -1 and t.station[2] == pytest.approx(math.pi / 2)
    assert len(load_map("docking_bay").reflectors) == 12  # the targets are not in the global map


def test_a_good_target_passes_the_checks():
    doc = parse_docking_targets(TARGET, "bay.yaml")
    t = check_target(doc, 0, 65535, 0.0)
    assert t.reflector_ids == ("a", "b", "c")


def _refused(text: str, line: int, key: str, words: str, **check: float) -> None:
    with pytest.raises(ScenarioError) as info:
        doc = parse_docking_targets(text, "bay.yaml")
        check_target(doc, 0, int(check.get("pulses", 65535)), check.get("turn_radius", 0.0))
    msg = str(info.value)
    assert msg.startswith(f"bay.yaml:{line}:"), msg
    assert key in msg and words in msg, msg


def test_fewer_than_two_reflectors_refused():
    text = TARGET.replace("      - {id: b, x: 0.0, y: 0.15}\n      - {id: c, x: 0.0, y: 0.50}\n", "")
    _refused(text, 5, "docking_targets[0].reflectors", "at least 2")


def test_reflectors_too_close_at_the_resolution_refused():
    text = TARGET.replace("{id: b, x: 0.0, y: 0.15}", "{id: b, x: 0.0, y: 0.47}")
    _refused(text, 8, "docking_targets[0].reflectors[2]", "tell them apart")
    parse_docking_targets(text)  # the schema alone accepts it; a coarse goniometer refuses even the good one:
    _refused(TARGET, 8, "reflectors[2]", "tell them apart", pulses=1000)


def test_unreachable_docking_pose_refused():
    text = TARGET.replace("approach_m: 3.0", "approach_m: 0.2")
    _refused(text, 9, "docking_targets[0].docking_pose", "unreachable", turn_radius=2.0)
    check_target(parse_docking_targets(text), 0, 65535, 0.0)  # a vehicle turning on the spot reaches it


def test_schema_errors_name_line_and_key():
    _refused(TARGET.replace("direction: reverse", "direction: sideways"), 11, "direction", "")
    _refused(TARGET.replace("approach_m: 3.0", "approach_m: 3.0\n    colour: red"), 11, "colour", "")


def test_world_map_accepts_the_targets_section():
    WorldMap.from_dict({"reflectors": [], "walls": [], "docking_targets": []})
