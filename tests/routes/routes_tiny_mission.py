"""The tiny route network and mission scenario shared by the mission tests (one copy, not three)."""

from __future__ import annotations

from pathlib import Path

from agvnav.world.scenario import Scenario, parse_scenario

TINY_NET = """\
nodes:
  - {id: A, x: 0, y: 0, heading_deg: 0, kind: station}
  - {id: B, x: 4, y: 0, heading_deg: 0}
  - {id: C, x: 6, y: 2, heading_deg: 90, kind: station}
  - {id: D, x: 6, y: 5, kind: station}
edges:
  - {id: ab, from: A, to: B}
  - {id: bc, from: B, to: C, speed_m_s: 0.3, geometry: {type: arc, radius_m: 2, sweep_deg: 90}}
  - {id: cd, from: C, to: D, two_way: true, direction: both}
"""

SCENARIO = """\
name: tiny_mission
seed: 3
step_s: 0.05
vehicle: {model: differential, track_m: 0.5, wheel_radius_m: 0.08, encoder_counts_per_rev: 4096}
traction: {speed_m_s: 0.5, max_accel_m_s2: 0.3, max_decel_m_s2: 0.3}
map: {reflectors: [{id: R1, x: -5, y: -5}, {id: R2, x: 12, y: -5}, {id: R3, x: 0, y: 12}]}
positioning: {method: dead_reckoning, initial_std: [0.0, 0.0, 0.0]}
controller: {name: kanayama, params: {convergence_distance: 1.0}}
mission:
  network: tiny.yaml
  start: A
  jobs:
    - {action: pick, station: C, duration_s: 2.0}
    - {action: goto, station: D}
    - {action: reverse_into, station: C}
"""


def run_tiny(tmp_path: Path, text: str = SCENARIO) -> Scenario:
    (tmp_path / "tiny.yaml").write_text(TINY_NET)
    sc_path = tmp_path / "tiny_mission.yaml"
    sc_path.write_text(text)
    return parse_scenario(text, str(sc_path), tmp_path)
