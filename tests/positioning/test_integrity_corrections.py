"""The correction-drift check of the integrity monitor (issue 12): Kalman corrections that add up.

A consistent filter's corrections ``K y`` are white with covariance ``P- - P+``; wheel slip
beyond the odometry model makes them add up along the motion. Known answers on the lab
map: exact bearings (every other check passes), corrections given per sighting.
"""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.positioning import bearing_model
from agvnav.positioning.integrity import IntegrityLimits, IntegrityMonitor
from agvnav.world import WorldMap, load_builtin_map

MOUNT = np.array([0.3, 0.0, 0.0])
POSE = np.array([4.0, 3.0, 0.3])
REV = 0.125
P_SMALL = np.diag([1e-4, 1e-4, 1e-5])


@pytest.fixture(scope="module")
def lab() -> WorldMap:
    return load_builtin_map("lab")


def _run(lab: WorldMap, corrections: np.ndarray, decrease: float = 1e-6) -> IntegrityMonitor:
    """Two windows of exact sightings with the given ``(n, 2)`` corrections (m), then a check."""
    mon = IntegrityMonitor(lab.reflector_xy, lab.reflector_radius, MOUNT, 1e-4, REV, IntegrityLimits())
    h, _, _ = bearing_model(POSE, MOUNT, lab.reflector_xy, lab.reflector_radius)
    n_refl = len(h)
    t = 0.0
    mon.check(t, POSE, P_SMALL, (0.0, 0.0, 0.0), False)  # the first check starts the clock
    for k, (cx, cy) in enumerate(corrections):
        t = (k + 1) / 72.0
        j = k % n_refl
        mon.accepted(t, 1.0, j, float(h[j]), (0.0, 0.0, 0.0), (float(cx), float(cy), decrease, 0.0, decrease))
    mon.check(t, POSE, P_SMALL, (0.0, 0.0, 0.0), False)
    return mon


def test_white_corrections_pass(lab: WorldMap) -> None:
    rng = np.random.default_rng(5)
    mon = _run(lab, rng.normal(0.0, 1e-3, (144, 2)))  # std sqrt(1e-6) = 1 mm: as expected
    assert "corrections" not in mon.reasons and mon.verdict == "ok"
    assert mon.correction_d2 != mon.correction_d2 or mon.correction_d2 < 13.8  # NaN (below the floor) or small


def test_a_steady_forward_drift_is_flagged_and_inflates(lab: WorldMap) -> None:
    # 0.5 mm per sighting, 72 sightings in the 1 s window: 36 mm against a 1.2 mm std sum
    mon = _run(lab, np.tile([5e-4, 0.0], (144, 1)), decrease=2e-8)
    assert "corrections" in mon.reasons and mon.verdict == "degraded"
    assert mon.correction_d2 == pytest.approx(0.036**2 / (72 * 2e-8), rel=0.05)


def test_a_drift_below_the_floor_passes(lab: WorldMap) -> None:
    # 0.2 mm per sighting: 14 mm over the window, under max_correction_m = 20 mm
    mon = _run(lab, np.tile([2e-4, 0.0], (144, 1)), decrease=2e-8)
    assert "corrections" not in mon.reasons

