"""Path progress and completion of the tricycle autopilot (review finding: false ``path_completed``)."""

import math
from types import SimpleNamespace

import pytest
from tests.sim.conftest import scenario_text

from agvnav.actuators import SpeedProfile
from agvnav.guidance.paths import path_from_moves
from agvnav.navigation.path import PathAutopilot
from agvnav.sim import simulate
from agvnav.world.scenario import ScenarioError, parse_scenario

# A U turn: 3 m east, half circle of radius 1 m to the left, 3 m west. Its end is 2 m left of its start.
U_SEGMENTS = (
    "    - {type: arc, radius_m: 1.24, sweep_deg: 90.0}\n    - {type: line, length_m: 3.0}",
    ("    - {type: line, length_m: 3.0}\n    - {type: arc, radius_m: 1.0, sweep_deg: 180.0}\n"
    "    - {type: line, length_m: 3.0}"),
)


class _Estimator:
    status = "tracking"

    def __init__(self, pose):
        self.pose = pose


class _Plant:
    family = "steered"
    geometry = None
    gamma_meas = 0.0


class _Controller:
    """Projects C globally, as a controller does on its first call: the end of a U path for this start."""

    def __init__(self, path):
        self.path = path
        self.last_errors = None

    def command(self, pose, v, steering=0.0):
        pr = self.path.project_point(pose[0] + math.cos(pose[2]), pose[1] + math.sin(pose[2]))
        self.last_errors = SimpleNamespace(s=pr.s, eps_c=pr.lateral, xi_r=0.0)
        return 0.0, 0.0

    def drive_speed(self, v, steering):
        return v


def test_start_at_the_path_end_does_not_jump_there():
    """C placed on the end point of a U path, 2 m left of its start: progress stays at the start."""
    path = path_from_moves([0.0, 0.0, 0.0], [("line", 3.0), ("arc", 1.0, math.pi), ("line", 3.0)])
    profile = SpeedProfile(cruise_speed=0.2, max_accel=0.3, max_decel=0.3)
    pilot = PathAutopilot(_Controller(path), path, profile, _Plant(), point_offset=1.0)
    est = _Estimator((-1.0, 2.0, 0.0))  # O one wheelbase behind C = (0, 2), the path end
    for k in range(50):
        v, _ = pilot.command(0.05 * k, est, _Plant(), 0.05)
    assert pilot.follower.last_errors.s == pytest.approx(path.length)  # the trap
    assert pilot.signals()[pilot.signal_names.index("s_est")] < 1.0  # s near the start, not path.length
    assert v > 0.0 and not pilot.finished


def test_far_start_on_a_u_path_completes_only_by_driving_it():
    text = scenario_text(**{U_SEGMENTS[0]: U_SEGMENTS[1], "lateral_offset_m: 0.110": "lateral_offset_m: 1.0"})
    r = simulate(parse_scenario(text, "u.yaml"))
    end = r.path.end_pose
    gap = math.hypot(r.series["x_C"][-1] - end[0], r.series["y_C"][-1] - end[1])
    if r.metrics.path_completed:
        assert r.series["distance_C"][-1] > r.path.length - 1.5
        assert gap < 0.15
        assert r.metrics.max_abs_lateral_error_m is not None
    else:
        assert gap > 0.1 or r.series["distance_C"][-1] < r.path.length - 1.5


def test_start_50_m_off_the_path_is_refused_with_key_and_line():
    text = scenario_text(**{"lateral_offset_m: 0.110": "lateral_offset_m: 50.0"})
    with pytest.raises(ScenarioError) as info:
        simulate(parse_scenario(text, "far.yaml"))
    msg = str(info.value)
    line = next(i + 1 for i, ln in enumerate(text.splitlines()) if "lateral_offset_m: 50.0" in ln)
    assert "\n" not in msg
    assert ": start.lateral_offset_m: " in msg and "too far" in msg
    assert info.value.line == line


def test_reaching_the_end_of_s_far_from_the_end_point_is_not_completion():
    """Progress at the path end but the tracked point 0.5 m beside it: stopped, not completed."""
    path = path_from_moves([0.0, 0.0, 0.0], [("line", 3.0)])
    profile = SpeedProfile(cruise_speed=0.2, max_accel=0.3, max_decel=0.3)
    pilot = PathAutopilot(_Controller(path), path, profile, _Plant(), point_offset=1.0)
    pilot._s = path.length
    v, _ = pilot.command(0.0, _Estimator((2.0, 0.5, 0.0)), _Plant(), 0.05)
    assert v == 0.0 and not pilot.finished
    v, _ = pilot.command(0.05, _Estimator((2.0, 0.01, 0.0)), _Plant(), 0.05)
    assert v == 0.0 and pilot.finished


def test_progress_holds_while_the_estimator_is_lost():
    """A lost estimate wandering along the path does not carry the progress with it."""
    path = path_from_moves([0.0, 0.0, 0.0], [("line", 6.0)])
    profile = SpeedProfile(cruise_speed=0.2, max_accel=0.3, max_decel=0.3)
    pilot = PathAutopilot(_Controller(path), path, profile, _Plant(), point_offset=1.0)
    est = _Estimator((0.0, 0.0, 0.0))
    s_est = pilot.signal_names.index("s_est")
    for k in range(40):  # the lost estimate runs ahead 0.1 m a step
        est.status, est.pose = "lost", (0.1 * k, 0.0, 0.0)
        pilot.command(0.05 * k, est, _Plant(), 0.05)
    assert pilot.signals()[s_est] == pytest.approx(0.0)
    est.status = "tracking"  # the same pose, trusted: the progress follows again
    pilot.command(2.0, est, _Plant(), 0.05)
    assert pilot.signals()[s_est] > 0.5


def test_progress_is_projected_again_when_positioning_recovers():
    """A wrong relocalisation briefly trusted carries s to the path end; once lost and then re-acquired on the
    true pose, s comes back to the vehicle, which drives on (integrity bench: differential clutter, seed 19)."""
    path = path_from_moves([0.0, 0.0, 0.0], [("line", 6.0)])
    profile = SpeedProfile(cruise_speed=0.2, max_accel=0.3, max_decel=0.3)
    pilot = PathAutopilot(_Controller(path), path, profile, _Plant(), progress_window=1.0)
    est = _Estimator((0.0, 0.0, 0.0))
    s_est = pilot.signal_names.index("s_est")
    for k in range(60):  # a trusted estimate walking ahead to the path end
        est.status, est.pose = "tracking", (min(0.1 * k, 6.0), 0.0, 0.0)
        pilot.command(0.05 * k, est, _Plant(), 0.05)
    assert pilot.signals()[s_est] == pytest.approx(5.9)
    est.status = "lost"
    pilot.command(3.0, est, _Plant(), 0.05)
    est.status, est.pose = "tracking", (5.2, 0.0, 0.0)  # re-acquired where the vehicle really is
    pilot.command(3.05, est, _Plant(), 0.05)
    assert pilot.signals()[s_est] == pytest.approx(5.2)
    assert not pilot.finished
    while_tracking = SimpleNamespace(status="tracking", pose=(5.1, 0.0, 0.0))  # no loss: s never moves back
    pilot.command(3.1, while_tracking, _Plant(), 0.05)
    assert pilot.signals()[s_est] == pytest.approx(5.2)
