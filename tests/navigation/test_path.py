"""The generic PathAutopilot: runs of one direction between cusps, and stopping at a cusp before reversing."""

from types import SimpleNamespace

import numpy as np

from agvnav.actuators import SpeedProfile
from agvnav.guidance.follower import FollowErrors
from agvnav.guidance.paths import LineSegment, Path, path_from_moves
from agvnav.navigation.path import PathAutopilot
from agvnav.vehicles import UnicycleGeometry


class _Follower:
    def __init__(self):
        self.paths = []
        self.last_errors = None

    def set_path(self, path):
        self.paths.append(path)

    def command(self, pose, v, steering=0.0):
        self.last_errors = FollowErrors(0.0, 0.0, 0.0, 0.0, 0.0, 1, 0)
        return 0.0, 0.0


_PLANT = SimpleNamespace(family="unicycle", geometry=UnicycleGeometry(track=0.5, wheel_radius=0.1))


def _pilot(path):
    return PathAutopilot(_Follower(), path, SpeedProfile(cruise_speed=0.5, max_accel=0.5, max_decel=0.5), _PLANT)


def test_runs_end_at_every_cusp_and_carry_the_path_direction():
    path = path_from_moves(
        [0.0, 0.0, 0.0], [("line", 1.0), ("arc", 2.0, 0.5, -1), ("line", 0.5), ("line", 1.5, -1), ("arc", 1.0, -0.3)]
    )
    pilot = _pilot(path)
    starts = list(path.segment_starts[:-1])
    for s in np.linspace(0.0, path.length - 1e-9, 301):
        end, direction = pilot._run_from(float(s))
        assert direction == int(path.direction_at(s))
        assert end > s and all(path.direction_at(u) == direction for u in np.linspace(s, end - 1e-9, 7))
        if end < path.length:
            assert path.direction_at(end) != direction and min(abs(end - x) for x in starts) < 1e-12
    # the follower is handed the first run only (the reverse arc retraces nothing it could confuse)
    assert len(pilot.follower.paths) == 1 and pilot.follower.paths[0].length < path.length


def test_stops_at_the_cusp_then_drives_the_next_run_backwards():
    forward = LineSegment(np.array([0.0, 0.0]), 0.0, 1.0, 1)
    back = LineSegment(np.array([1.0, 0.0]), np.pi, 1.0, -1)  # the same line, driven backwards
    path = Path([forward, back])
    pilot = _pilot(path)
    x, dt, speeds = 0.0, 0.05, []
    for k in range(400):
        wr, wl = pilot.command(k * dt, SimpleNamespace(pose=np.array([x, 0.0, 0.0]), status="tracking"), _PLANT, dt)
        v = 0.5 * (wr + wl) * 0.1
        speeds.append(v)
        x += v * dt
        if pilot.finished:
            break
    speeds = np.array(speeds)
    first_back = int(np.flatnonzero(speeds < 0)[0])
    assert np.all(speeds[:first_back] >= 0.0)
    assert 0.0 in speeds[:first_back]  # stood still at the cusp before reversing
    assert abs(x) < 0.01 and pilot.finished  # back at the start, which is the path's end
    assert len(pilot.follower.paths) == 2  # one set_path per run
