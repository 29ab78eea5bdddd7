"""The triangulation cross-check counts the odometry that brings its bearings to one instant (issue 12).

A differential AGV's odometric heading wanders several mrad within the one revolution
the cross-check reaches back; a check that took the propagated bearings as exact failed
about every 2 s on a sound estimate. Known answers on the lab map: exact bearings from a
vehicle driving straight at 0.5 m/s, an odometric heading error growing 0.1 rad/s into
the past (12 mrad one revolution back).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from agvnav import _jit
from agvnav.positioning import bearing_model
from agvnav.positioning._integrity_fast import CROSSCHECK_NONE, crosscheck_fix
from agvnav.positioning.integrity import IntegrityLimits, IntegrityMonitor
from agvnav.world import WorldMap, load_builtin_map

MOUNT = np.array([0.3, 0.0, 0.0])
START = np.array([4.0, 3.0, 0.3])
REV = 0.125
SPEED = 0.5
DRIFT = 0.1  # rad/s: odometric heading error per second into the past
NOISE = (0.001, 0.003, 0.001)  # seed 002's typical K_D, K_Dtheta, K_theta


@pytest.fixture(scope="module")
def lab() -> WorldMap:
    return load_builtin_map("lab")


def _truth(t: float) -> np.ndarray:
    return START + SPEED * t * np.array([math.cos(START[2]), math.sin(START[2]), 0.0])


def _monitor(lab: WorldMap, noise: tuple[float, float, float]) -> IntegrityMonitor:
    limits = IntegrityLimits(crosscheck_min_m=1e-3)  # judge by the statistics, not the gross-error floor
    return IntegrityMonitor(lab.reflector_xy, lab.reflector_radius, MOUNT, 1e-4, REV, limits,
                            map_std=0.002, odometry_noise=noise)


def _drive(mon: IntegrityMonitor, lab: WorldMap) -> float:
    """One revolution and a half of exact bearings, one per 1/72 s; odometry in the map frame with its heading error."""
    t_now = 1.5 * REV
    for k in range(1, 28):
        t = k / 72.0
        if t > t_now:
            break
        truth = _truth(t)
        h, _, _ = bearing_model(truth, MOUNT, lab.reflector_xy, lab.reflector_radius)
        j = k % lab.reflector_xy.shape[0]
        odom = (float(truth[0]), float(truth[1]), float(truth[2]) + DRIFT * (t_now - t))
        mon.accepted(t, 1.0, j, float(h[j]), odom)
    return t_now


def _check(mon: IntegrityMonitor, t: float, offset: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> bool:
    truth = _truth(t)
    mon.check(t, truth + np.array(offset), np.diag([1e-6, 1e-6, 1e-8]), tuple(float(v) for v in truth), False)
    return "crosscheck" in mon.reasons


def test_an_unmodelled_odometry_error_fails_a_sound_estimate(lab: WorldMap) -> None:
    mon = _monitor(lab, (0.0, 0.0, 0.0))
    assert _check(mon, _drive(mon, lab))  # the old check: the estimate is the truth, yet it fails
    assert mon.crosscheck > 13.8


def test_the_odometry_error_in_the_variances_passes_it(lab: WorldMap) -> None:
    mon = _monitor(lab, NOISE)
    assert not _check(mon, _drive(mon, lab))
    assert 0.0 <= mon.crosscheck < 13.8


def test_a_gross_error_still_fails_with_the_odometry_noise(lab: WorldMap) -> None:
    mon = _monitor(lab, NOISE)
    assert _check(mon, _drive(mon, lab), (0.3, 0.0, 0.0))
    assert mon.crosscheck > 50.0  # 0.3 m off: Mahalanobis distance² ~90


def test_odometry_noise_is_checked(lab: WorldMap) -> None:
    with pytest.raises(ValueError, match="odometry_noise"):
        _monitor(lab, (0.001, -1.0, 0.0))


def _triple_of(mon: IntegrityMonitor, t: float, pose: np.ndarray) -> tuple[int, tuple[int, ...]]:
    """The cross-check kernel's code and triple (map rows, ``out[6:9]``) on the monitor's window at ``t``."""
    buf, start = mon._entries.buffer()
    rx, ry, radius, map_std = mon._tables
    pose_t = tuple(float(v) for v in pose)
    out = crosscheck_fix(buf, start, mon._tally(t).newest, pose_t, pose_t, mon._mount_t, rx, ry, radius, map_std,
                         mon.odometry_noise, mon.bearing_std**2, mon.limits.max_fix_std_m**2)
    return int(out[0]), tuple(int(v) for v in out[6:9])


def _sight_all(mon: IntegrityMonitor, pose: np.ndarray, order: list[int], t_end: float) -> None:
    """Exact edge bearings of the reflectors ``order`` from ``pose``, one sighting each within the revolution."""
    h, _, _ = bearing_model(pose, mon.mount, mon.xy, mon.radius)
    odom = tuple(float(v) for v in pose)
    for k, j in enumerate(order):
        mon.accepted(t_end - REV * (len(order) - k) / (len(order) + 1), 1.0, j, float(h[j]), odom)


@pytest.mark.usefixtures("restore_jit_mode")
@pytest.mark.parametrize("on", [False, True])
def test_a_dense_map_triple_comes_from_the_whole_revolution(on: bool) -> None:
    # 64 reflectors on a 5 m circle around the head, seen in angle (= time) order within one
    # revolution: the eight newest span 45 degrees; the triple must come from the whole revolution
    _jit.set_compiled(on)
    n = 64
    ang = np.arange(n) * 2.0 * math.pi / n
    xy = np.column_stack([5.0 * np.cos(ang), 5.0 * np.sin(ang)])
    mon = IntegrityMonitor(xy, np.full(n, 0.04), np.zeros(3), 1e-4, REV, map_std=0.005)
    _sight_all(mon, np.zeros(3), list(range(n)), 1.0)
    code, idx = _triple_of(mon, 1.0, np.zeros(3))
    assert code in (1, 2) and min(idx) >= 0
    spread = np.sort(ang[list(idx)])
    gaps = np.diff(np.concatenate([spread, [spread[0] + 2.0 * math.pi]]))
    assert gaps.max() < math.radians(180.0)  # around the head, not one sector (the newest eight: 39 deg)
    # the candidates are eight spread over the revolution (linspace(0, 63, 8) rounded, newest first)
    spread8 = {n - 1 - int(k) for k in np.linspace(0, n - 1, 8).round()}
    assert set(idx) <= spread8


def _reference_best_triple(head: tuple[float, float], xy: np.ndarray, var: np.ndarray, bearing_var: float,
                           max_var: float) -> tuple[int, ...] | None:
    """Brute force in NumPy: the CRLB (seed 000 §2.3) of every triple from its 3x3 information matrix."""
    d = xy - np.asarray(head)
    d2 = np.sum(d * d, axis=1)
    rows = np.column_stack([d[:, 1] / d2, -d[:, 0] / d2, -np.ones(len(xy))])
    best, best_score = None, math.inf
    for tri in itertools.combinations(range(len(xy)), 3):
        h = rows[list(tri)]
        try:
            geometry = np.trace(np.linalg.inv(h.T @ h)[:2, :2]) * bearing_var
            score = np.trace(np.linalg.inv(h.T @ (h / var[list(tri), None]))[:2, :2])
        except np.linalg.LinAlgError:
            continue
        if 0.0 <= geometry <= max_var and 0.0 <= score < best_score:
            best, best_score = tri, score
    return best


@pytest.mark.usefixtures("restore_jit_mode")
@pytest.mark.parametrize("on", [False, True])
def test_the_chosen_triple_has_the_smallest_bound(on: bool) -> None:
    """The cross-check kernel's triple (``crosscheck_fix``, its rows ``out[6:9]``) against brute force in NumPy.

    Three to eight reflectors, each seen once from a standing head (no odometry between then and
    now): each bearing's variance is the bearing's and its reflector's survey ``(map_std / d)^2``.
    """
    _jit.set_compiled(on)
    rng = np.random.default_rng(21)
    agree = none = 0
    for _ in range(200):
        n = int(rng.integers(3, 9))
        xy = rng.uniform(-8.0, 8.0, (n, 2))
        map_std = rng.uniform(0.0, 0.02, n)
        mon = IntegrityMonitor(xy, np.full(n, 0.04), np.zeros(3), 1e-3, REV, IntegrityLimits(max_fix_std_m=0.05),
                               map_std=map_std)
        _sight_all(mon, np.zeros(3), rng.permutation(n).tolist(), 1.0)
        code, got = _triple_of(mon, 1.0, np.zeros(3))
        var = 1e-6 + (map_std / np.hypot(xy[:, 0], xy[:, 1])) ** 2
        want = _reference_best_triple((0.0, 0.0), xy, var, 1e-6, 0.05**2)
        if want is None:
            assert code == CROSSCHECK_NONE
            none += 1
        elif code != CROSSCHECK_NONE:  # (no fix also when the chosen triple's fix is invalid)
            assert tuple(sorted(got)) == want
            agree += 1
    assert agree >= 150 and none >= 5  # both sides: a triple within max_fix_std_m, and none
