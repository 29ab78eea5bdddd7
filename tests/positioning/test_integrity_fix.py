"""The monitor's evidence for the stated bound (issue 31): one revolution's snapshot fix
(:meth:`IntegrityMonitor.fix`) against a known offset by Monte Carlo, and the reflectors in sight
it explained (:meth:`IntegrityMonitor.explained`) against a brute-force count."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.positioning.deviation import radius_k, snapshot_radius
from agvnav.positioning.integrity import IntegrityLimits, IntegrityMonitor, reflectors_in_sight
from agvnav.world import load_builtin_map

MOUNT = np.array([0.3, 0.0, 0.0])
STD = 1e-3  # rad
REV = 0.125


def _monitor() -> IntegrityMonitor:
    lab = load_builtin_map("lab")
    return IntegrityMonitor(lab.reflector_xy, lab.reflector_radius, MOUNT, STD, REV, IntegrityLimits(max_latency_s=1.0),
                            walls=lab.wall_segments)


def test_the_snapshot_fix_recovers_the_offset_within_its_covariance() -> None:
    """Innovations ``y = H dx + noise`` of eight reflectors in one revolution: the fit's error is
    chi-square with 3 dof under its covariance, and the snapshot bound misses ``|dx|`` no more often
    than ``exp(-k^2/2)``."""
    rng = np.random.default_rng(5)
    dx = np.array([0.03, -0.02, 0.004])
    k = radius_k(0.05)
    d2, misses, runs = [], 0, 300
    mon = _monitor()
    for run in range(runs):
        mon.reset()
        t0 = 10.0 * run
        H = rng.normal(0.0, 1.0, (8, 3)) * np.array([0.2, 0.2, 1.0])  # rad/m, rad/m, rad/rad
        for j in range(8):
            y = float(H[j] @ dx + rng.normal(0.0, STD))
            mon.accepted(t0 + 0.01 * j, y * y / STD**2, j, 0.0, (0.0, 0.0, 0.0), None,
                         (y, STD**2, float(H[j, 0]), float(H[j, 1]), float(H[j, 2])))
        fix = mon.fix(t0 + 0.1)
        assert fix is not None and fix[2] == 8
        est, C, _ = fix
        e = est - dx
        d2.append(float(e @ np.linalg.solve(C, e)))
        misses += math.hypot(dx[0], dx[1]) > snapshot_radius(est, C, k)
    assert np.mean(d2) == pytest.approx(3.0, rel=0.15)  # chi-square 3 dof: mean 3, 300 runs: 4.7 % std
    assert misses / runs <= 0.05


def test_no_fix_from_fewer_than_four_reflectors() -> None:
    mon = _monitor()
    for j in range(3):
        mon.accepted(0.01 * j, 0.0, j, 0.0, (0.0, 0.0, 0.0), None, (0.0, STD**2, 0.1, 0.2, 1.0))
    assert mon.fix(0.1) is None


def test_explained_counts_the_reflectors_seen_in_sight_and_the_rejections_of_the_last_revolution() -> None:
    mon = _monitor()
    pose = np.array([4.0, 3.0, 0.3])
    for j, t in ((0, 0.0), (1, 0.9), (2, 0.95), (2, 0.97)):  # reflector 0 more than a revolution ago
        mon.accepted(t, 0.0, j, 0.0, (0.0, 0.0, 0.0))
    for t in (0.5, 0.92, 0.99):
        mon.rejected(t)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    head = pose[:2] + np.array([c * MOUNT[0], s * MOUNT[0]])
    sight = int(reflectors_in_sight(mon.xy, mon.radius, head, mon.walls, mon.max_range).sum())
    assert mon.explained(1.0, pose) == (2, sight, 2)
    assert sight > 2
    assert mon.explained(1.0, np.array([math.nan, 0.0, 0.0])) == (0, 0, 0)
