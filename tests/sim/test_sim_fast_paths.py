"""The autopilot's scalar fast paths equal the package functions they mirror (the plant's: tests/vehicles)."""

from __future__ import annotations

import numpy as np

from agvnav.guidance.paths import path_from_moves
from agvnav.sim.tricycle import TricycleAutopilot


def test_autopilot_direction_equals_path_direction_at() -> None:
    path = path_from_moves(
        [0.0, 0.0, 0.0], [("line", 1.0), ("arc", 2.0, 0.5, -1), ("line", 0.5), ("line", 1.5, -1), ("arc", 1.0, -0.3)]
    )
    pilot = TricycleAutopilot(controller=None, path=path, profile=None, wheelbase=1.0)
    starts = path.segment_starts
    probes = np.concatenate([np.linspace(-1.0, path.length + 1.0, 401), starts, np.nextafter(starts, -np.inf)])
    for s in probes:
        assert pilot._direction(float(s)) == int(path.direction_at(s)), s
