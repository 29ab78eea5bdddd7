"""Issue 10: the wall landmarks are an estimator input, so a Kanayama follower on the tracked robot uses them too."""

import numpy as np

from agvnav.sim import simulate
from agvnav.world.scenario import load_scenario

# Odometry believes the right track slips 3.5 % instead of 2 %: its dead reckoning curves.
SCENARIO = """
name: tracked_kanayama_wall
step_s: 0.05
seed: 3
vehicle:
  model: tracked
  terrain:
    truth: concrete
    odometry: {slip_left: 0.02, slip_right: 0.035, icr_left: 1.15, icr_right: 1.15}
ultrasonic: {}
traction: {speed_m_s: 0.15}
map: {walls: WALLS}
path:
  start: [0.0, 0.0, 0.0]
  segments:
    - {type: line, length_m: 4.0}
controller: {name: kanayama, params: {convergence_distance: 0.5}}
"""
WALL = "[{id: side, points: [[-0.5, -0.5], [4.5, -0.5]]}]"  # 0.3 m right of the right rangers


def _run(tmp_path, walls):
    p = tmp_path / "k.yaml"
    p.write_text(SCENARIO.replace("WALLS", walls))
    return simulate(load_scenario(p))


def test_kanayama_with_a_wall_alongside_stays_on_the_line_where_dead_reckoning_drifts(tmp_path):
    dead = _run(tmp_path, "[]")
    fused = _run(tmp_path, WALL)
    dead_lat, fused_lat = np.abs(dead.series["lateral_error"]), np.abs(fused.series["lateral_error"])
    assert dead_lat.max() > 0.2  # the odometry's curve, followed faithfully
    assert fused.completed and fused_lat.max() < 0.01  # the side pair fixes heading and offset
    s = fused.series
    assert np.max(np.abs(s["est_y"] - s["y"])) < 0.01
