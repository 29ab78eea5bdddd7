"""Integrity monitor against the faults that once passed silently (issue 12): late stamps,
a moved reflector, reflectors hidden behind racks, a status that flips back too soon."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _drive import arc_pose_at

from agvnav.positioning import bearing_model, make_estimator
from agvnav.positioning.integrity import IntegrityLimits, IntegrityMonitor, reflectors_in_sight
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import Reflector, Wall, WorldMap, load_builtin_map

MOUNT = np.array([0.3, 0.0, 0.0])
TRUTH = np.array([4.0, 3.0, 0.3])
REV = 0.125
P_SMALL = np.diag([1e-4, 1e-4, 1e-5])
ODOM0 = (0.0, 0.0, 0.0)


@pytest.fixture(scope="module")
def lab() -> WorldMap:
    return load_builtin_map("lab")


# ---------------------------------------------------------------------- line of sight
def test_reflectors_in_sight_hides_what_a_wall_or_the_range_hides() -> None:
    xy = np.array([[5.0, 0.0], [0.0, 5.0], [-5.0, 0.0], [40.0, 1.0]])
    radius = np.full(4, 0.04)
    wall = np.array([[[-1.0, 2.0], [1.0, 2.0]]])  # across the line to the second reflector
    np.testing.assert_array_equal(reflectors_in_sight(xy, radius, (0.0, 0.0), wall, 30.0), [1, 0, 1, 0])
    np.testing.assert_array_equal(reflectors_in_sight(xy, radius, (0.0, 0.0)), [1, 1, 1, 1])
    np.testing.assert_array_equal(reflectors_in_sight(xy, radius, (0.0, 3.0), wall, 30.0), [1, 1, 1, 0])
    with pytest.raises(ValueError, match="head_xy"):
        reflectors_in_sight(xy, radius, (0.0, math.nan))
    with pytest.raises(ValueError, match="reflector_radius"):
        reflectors_in_sight(xy, radius[:2], (0.0, 0.0))


def _rack_hall() -> WorldMap:
    """Three reflectors in the aisle, four behind a rack (a closed rectangle) from the head at TRUTH."""
    aisle = [Reflector("A1", 8.0, 3.0, 0.04), Reflector("A2", 4.0, 7.0, 0.04), Reflector("A3", 0.5, 1.0, 0.04)]
    hidden = [Reflector(f"H{i}", 4.5 + i, -1.5, 0.04) for i in range(4)]
    rack = Wall("rack", np.array([[2.0, 0.5], [9.0, 0.5], [9.0, 1.0], [2.0, 1.0]]), closed=True)
    return WorldMap(tuple(aisle + hidden), (rack,))


def _feed_exact(mon: IntegrityMonitor, world: WorldMap, rows: list[int], n: int, t0: float = 0.0) -> float:
    h, _, _ = bearing_model(TRUTH, MOUNT, world.reflector_xy, world.reflector_radius)
    t = t0
    for k in range(n):
        t = t0 + (k + 1) / 72.0
        mon.accepted(t, 1.0, rows[k % len(rows)], float(h[rows[k % len(rows)]]), ODOM0)
    return t


def test_the_explained_fraction_counts_only_reflectors_in_sight() -> None:
    hall = _rack_hall()
    for walls, expected in ((None, ("unexplained",)), (hall.wall_segments, ())):
        mon = IntegrityMonitor(hall.reflector_xy, hall.reflector_radius, MOUNT, 1e-4, REV, walls=walls)
        mon.check(0.0, TRUTH, P_SMALL, ODOM0, False)
        t = _feed_exact(mon, hall, [0, 1, 2], 72, t0=0.5)
        mon.check(t, TRUTH, P_SMALL, ODOM0, False)
        assert mon.reasons == expected  # 3 of 7 in range, 3 of 3 in sight


def test_the_estimator_gives_the_monitor_the_map_walls() -> None:
    hall = _rack_hall()
    est = make_estimator("ekf", hall, MOUNT, initial_pose=TRUTH)
    assert est.monitor.walls is not None and est.monitor.walls.shape == hall.wall_segments.shape


# ---------------------------------------------------------------------- timing
def test_stamps_that_lag_the_head_phase_leave_tracking(lab: WorldMap) -> None:
    """A standing vehicle: true stamps keep it tracking; stamps 0.3 s late (2.4 revolutions) make it degraded."""
    gon = Goniometer(mount=tuple(MOUNT))
    refl = gon.scan(lab, arc_pose_at(TRUTH, 0.0, 0.0), 0.0, 6.0)
    est = make_estimator("ekf", lab, MOUNT, initial_pose=TRUTH, initial_covariance=np.diag([1e-3, 1e-3, 1e-4]) ** 2)
    late = refl.t > 3.0
    t_odo = 0.0
    for t, z, lag in zip(refl.t, refl.bearing, np.where(late, 0.3, 0.0), strict=True):
        while t_odo + 0.05 <= t + lag:
            t_odo += 0.05
            est.predict(t_odo, 0.0, 0.0)
        est.update(float(t + lag), float(z))
        if not late[refl.t.searchsorted(t)] and t > 2.0:
            assert est.status == "tracking"
    assert est.status in ("degraded", "lost") and "timing" in est.monitor.reasons


def test_the_head_clock_stays_unknown_on_stamps_from_no_rotating_head(lab: WorldMap) -> None:
    mon = IntegrityMonitor(lab.reflector_xy, lab.reflector_radius, MOUNT, 1e-4, REV)
    t = _feed_exact(mon, lab, list(range(9)), 144)  # one reflection per 1/72 s, bearings of a standing head
    mon.check(t, TRUTH, P_SMALL, ODOM0, False)
    assert "timing" not in mon.reasons and mon.verdict == "ok"


# ---------------------------------------------------------------------- exclusion
def test_a_reflector_with_innovations_off_the_others_is_excluded(lab: WorldMap) -> None:
    mon = IntegrityMonitor(lab.reflector_xy, lab.reflector_radius, MOUNT, 1e-4, REV)
    h, _, _ = bearing_model(TRUTH, MOUNT, lab.reflector_xy, lab.reflector_radius)
    rng = np.random.default_rng(3)
    t = 0.0
    mon.check(t, TRUTH, P_SMALL, ODOM0, False)
    for k in range(16):  # 16 revolutions: reflector 4 at 4 sigma, its sign flipping halfway; the others white
        for j in range(9):
            t += REV / 9
            nu = (4.0 if k < 8 else -4.0) + rng.normal(0.0, 0.3) if j == 4 else rng.normal()
            mon.accepted(t, nu * nu, j, float(h[j]), ODOM0)
        mon.check(t, TRUTH, P_SMALL, ODOM0, False)
    assert mon.excluded == (4,)
    est = make_estimator("ekf", lab, MOUNT, initial_pose=TRUTH)
    est.monitor.excluded = (4,)
    est.apply_exclusions()  # what a check that excludes does
    assert not est.update(0.5, float(h[4]))  # never associated again


def test_white_innovations_exclude_nothing(lab: WorldMap) -> None:
    mon = IntegrityMonitor(lab.reflector_xy, lab.reflector_radius, MOUNT, 1e-4, REV)
    h, _, _ = bearing_model(TRUTH, MOUNT, lab.reflector_xy, lab.reflector_radius)
    rng = np.random.default_rng(4)
    t = 0.0
    for _ in range(200):
        for j in range(9):
            t += REV / 9
            nu = rng.normal()
            mon.accepted(t, nu * nu, j, float(h[j]), ODOM0)
        mon.check(t, TRUTH, P_SMALL, ODOM0, False)
    assert mon.excluded == ()


# ---------------------------------------------------------------------- hysteresis
def test_degraded_returns_to_ok_only_after_recover_s_of_passing_checks(lab: WorldMap) -> None:
    mon = IntegrityMonitor(lab.reflector_xy, lab.reflector_radius, MOUNT, 1e-4, REV, IntegrityLimits(recover_s=1.0))
    h, _, _ = bearing_model(TRUTH, MOUNT, lab.reflector_xy, lab.reflector_radius)
    t = 0.0
    for k in range(72):  # innovations 3 sigma wide: the NIS check fails
        t = (k + 1) / 72.0
        mon.accepted(t, 9.0, k % 9, float(h[k % 9]), ODOM0)
    assert mon.check(t, TRUTH, P_SMALL, ODOM0, False) and mon.reasons == ("nis",)
    t_fail = t
    while t < t_fail + 1.5:
        t = _feed_exact(mon, lab, list(range(9)), 9, t0=t)
        mon.check(t, TRUTH, P_SMALL, ODOM0, False)
        assert mon.reasons == ()
        assert mon.verdict == ("degraded" if t - t_fail < 1.0 else "ok")


def test_a_lone_crosscheck_failure_is_not_held(lab: WorldMap) -> None:
    mon = IntegrityMonitor(lab.reflector_xy, lab.reflector_radius, MOUNT, 1e-4, REV, IntegrityLimits(recover_s=1.0))
    t = _feed_exact(mon, lab, list(range(9)), 72)
    mon.check(t, TRUTH + [0.2, 0.0, 0.0], P_SMALL, ODOM0, False)
    assert mon.reasons == ("crosscheck",) and mon.verdict == "degraded"
    t = _feed_exact(mon, lab, list(range(9)), 9, t0=t)
    mon.check(t, TRUTH, P_SMALL, ODOM0, False)
    assert mon.verdict == "ok"
