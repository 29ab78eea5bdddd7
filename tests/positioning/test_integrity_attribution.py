"""A moved reflector whose reflections straddle its gate (issue 12: the last silent failures).

Moved by a few of its innovation sigmas, a reflector's reflections fall outside the
identification gate on most revolutions and inside on the others: the filter takes only
the sightings of the least bias (each a 2-3 sigma innovation) and is pulled off, and a
RAIM fed with the accepted innovations alone judges that truncated tail and passes. The
monitor's RAIM now also sees the gated-out reflections one reflector explains
(:meth:`~agvnav.positioning.integrity.IntegrityMonitor.attributed`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from _drive import arc_pose_at

from agvnav.odometry import OdometryNoise
from agvnav.positioning import bearing_model, make_estimator
from agvnav.positioning.estimator import StreamingEstimator
from agvnav.positioning.integrity import IntegrityLimits, IntegrityMonitor, chi2_threshold
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import Reflector, WorldMap, load_builtin_map

MOUNT = np.array([0.0, 0.0, 0.0])
POSE = np.array([4.0, 3.0, 0.3])
XY = np.array([[9.0, 3.0], [4.0, 9.0], [-1.0, 4.0], [5.0, -2.0], [8.0, 8.0], [0.0, -1.0], [9.0, -1.0]])
STD = 1e-3  # rad: sqrt(S) of every innovation
GATE = 10.827566170662733  # the estimator's identification gate, chi-square 1 dof at 0.999


def _jacobian(pose: np.ndarray) -> np.ndarray:
    d = XY - pose[:2]
    d2 = np.sum(d * d, axis=1)
    return np.column_stack([d[:, 1] / d2, -d[:, 0] / d2, -np.ones(len(XY))])


def _straddle(
    mon: IntegrityMonitor, bias_row: int, bias: float, n_rev: int, seed: int = 7
) -> tuple[int, list[tuple[bool, bool, tuple[str, ...]]]]:
    """Innovations about a pose held at POSE; the ``bias_row`` reflector's outside the gate are only attributed.

    Returns how many of its sightings the gate accepted, and per check whether it asked for
    an inflation, whether it excluded a reflector, and its reasons.
    """
    h, _, _ = bearing_model(POSE, MOUNT, XY, np.zeros(len(XY)))
    H = _jacobian(POSE)
    rng = np.random.default_rng(seed)
    accepted, checks = 0, []
    for k in range(n_rev * len(XY)):
        i = k % len(XY)
        if i in mon.excluded:
            continue
        t = (k + 1) * 0.125 / len(XY)
        y = rng.normal(0.0, STD) + (bias if i == bias_row else 0.0)
        S = STD**2
        if y * y / S < GATE:
            mon.accepted(t, y * y / S, i, float(h[i]), (0.0, 0.0, 0.0), None, (y, S, *H[i]))
            accepted += i == bias_row
        else:
            mon.attributed(t, i, (y, S, *H[i]))
        if mon.due(t):
            before = mon.excluded
            inflate = mon.check(t, POSE, np.diag([1e-4, 1e-4, 1e-5]), (0.0, 0.0, 0.0), False)
            checks.append((inflate, mon.excluded != before, mon.reasons))
    return accepted, checks


@pytest.mark.parametrize("attribute", [False, True])
def test_a_reflector_biased_to_the_gate_edge_is_excluded_only_with_its_gated_out_sightings(attribute: bool) -> None:
    """4.5 sigma of bias: one sighting in nine passes the gate (at 2.3-3.3 sigma); the RAIM needs the others.

    On the accepted innovations alone no check of 5 s fails (and each accepted one would
    pull a filter); with the attributed ones the reflector is excluded within the first checks.
    """
    mon = IntegrityMonitor(XY, np.zeros(len(XY)), MOUNT, STD, 0.125,
                           IntegrityLimits(max_latency_s=1.0, attribute=attribute))
    accepted, checks = _straddle(mon, 4, 4.5 * STD, 40)
    assert accepted > 0  # the gate keeps part of its sightings: the truncated tail
    if attribute:
        assert mon.excluded == (4,)
    else:
        assert mon.excluded == () and not any(reasons for _, _, reasons in checks)


def test_attributions_of_a_sound_stream_exclude_nothing() -> None:
    """Sound innovations beyond the gate (0.1 % of them) are attributed too: the RAIM sees them untruncated."""
    mon = IntegrityMonitor(XY, np.zeros(len(XY)), MOUNT, STD, 0.125, IntegrityLimits(max_latency_s=1.0))
    _straddle(mon, -1, 0.0, 80, seed=11)
    assert mon.excluded == () and mon.verdict == "ok"


def test_the_attribution_gate_is_the_raim_quantile() -> None:
    mon = IntegrityMonitor(XY, np.zeros(len(XY)), MOUNT, STD, 0.125, IntegrityLimits(raim_false_alarm=1e-4))
    assert mon.attribution_gate() == chi2_threshold(1, 1e-4)


def test_an_acceptance_in_the_same_sweep_voids_the_attribution() -> None:
    """A spurious reflection next to a sound reflector, which then reflects: the attribution is forgotten."""
    mon = IntegrityMonitor(XY, np.zeros(len(XY)), MOUNT, STD, 0.125)
    H = _jacobian(POSE)
    mon.attributed(1.00, 2, (4e-3, STD**2, *H[2]))
    mon.attributed(1.01, 3, (4e-3, STD**2, *H[3]))
    mon.accepted(1.05, 0.1, 2, 0.0, (0.0, 0.0, 0.0), None, (1e-4, STD**2, *H[2]))
    assert [a[1] for a in mon._attributed] == [3]
    mon.accepted(1.01 + 0.125, 0.1, 3, 0.0, (0.0, 0.0, 0.0), None, (1e-4, STD**2, *H[3]))  # next sweep
    assert [a[1] for a in mon._attributed] == [3]


def test_the_check_that_excludes_a_reflector_inflates_and_the_named_detections_before_it_do_not() -> None:
    """The estimate holds the excluded reflector's past pull: the exclusion asks for an inflated ``P``.

    The failing checks that named it before asked for none: a measurement fault, whose
    gate an inflation would only widen for it.
    """
    mon = IntegrityMonitor(XY, np.zeros(len(XY)), MOUNT, STD, 0.125, IntegrityLimits(max_latency_s=1.0))
    _, checks = _straddle(mon, 4, 4.5 * STD, 40)
    assert mon.excluded == (4,)
    assert [inflate for inflate, newly, _ in checks if newly] == [True]
    named = [inflate for inflate, newly, reasons in checks if reasons == ("raim",) and not newly]
    assert named and not any(named)


# ---------------------------------------------------------------------- end to end, the EKF
def _drive_past_a_moved_reflector(seed: int, attribute: bool, offset: float = 0.06) -> tuple[float, tuple[int, ...]]:
    """The differential AGV of ``bench integrity`` along the hall's south wall at 0.5 m/s for 6 s.

    Odometry noise of its truth (7 mrad of heading per revolution: ``sqrt(S)`` 2-4 mrad);
    from 2 s on S2 (about 5 m away) stands ``offset`` m east of its surveyed place, 6-9 mrad
    of bearing. Returns the longest stretch (s) of status ``tracking`` with the position
    more than 5 sigma (or 0.1 m) off the truth, and the excluded map rows.
    """
    hall = load_builtin_map("hall")
    j = hall.reflector_index("S2")
    refl = list(hall.reflectors)
    refl[j] = dataclasses.replace(refl[j], x=refl[j].x + offset)
    moved = dataclasses.replace(hall, reflectors=tuple(refl))
    noise = OdometryNoise(5e-5, 8e-4, 2e-4)
    start, speed, dt, t1, t2 = np.array([8.0, 4.0, 0.0]), 0.5, 0.02, 2.0, 6.0
    pose_at = arc_pose_at(start, speed, 0.0)
    gon = Goniometer()
    a, b = gon.scan(hall, pose_at, 0.0, t1), gon.scan(moved, pose_at, t1, t2)
    rt, rz = np.concatenate([a.t, b.t]), np.concatenate([a.bearing, b.bearing])
    est = make_estimator("ekf", hall, MOUNT, initial_pose=start, initial_covariance=np.diag([1e-4, 1e-4, 1e-5]),
                         odometry_noise=noise, map_std=0.002, integrity=IntegrityLimits(attribute=attribute))
    rng = np.random.default_rng(seed)
    est.predict(0.0, 0.0, 0.0)
    k, run, longest = 0, 0.0, 0.0
    for i in range(1, round(t2 / dt) + 1):
        t = i * dt
        while k < len(rt) and rt[k] <= t:
            est.update(float(rt[k]), float(rz[k]))
            k += 1
        cov = noise.increment_covariance(speed * dt, 0.0)
        est.predict(t, speed * dt + rng.normal(0.0, math.sqrt(cov[0, 0])), rng.normal(0.0, math.sqrt(cov[1, 1])))
        e = est.pose[:2] - pose_at(t)[0, :2]
        d2 = float(e @ np.linalg.solve(est.covariance[:2, :2], e))
        silent = est.status == "tracking" and (d2 > 25.0 or math.hypot(*e) > 0.1)
        run = run + dt if silent else 0.0
        longest = max(longest, run)
    return longest, est.monitor.excluded


def test_a_reflector_moved_to_the_gate_edge_leaves_no_silent_failure() -> None:
    """Six seeds: none stays ``tracking`` more than 1 s with the position beyond 5 sigma (the bench's silent failure).

    Without the attributions (the RAIM on accepted innovations only) one seed of these six
    stayed ``tracking`` 1.44 s 5-6 sigma off (and in ``bench integrity`` seeds 12 and 15 of
    the differential's mild ``reflector_moved`` row, 1.05 s and 2.80 s). Not covered: the
    leave-one-out sometimes names a sound reflector (the pull spreads the moved one's error);
    driven on to 8 s, one of these seeds excludes two sound ones and then stays ``tracking``
    2 s 5 sigma off.
    """
    longest = [_drive_past_a_moved_reflector(seed, attribute=True)[0] for seed in range(6)]
    assert max(longest) <= 1.0, longest


def test_the_estimator_attributes_a_gated_out_reflection_only_to_a_reflector_unseen_in_the_sweep() -> None:
    """4 sigma off reflector 4: rejected by the 0.999 gate, inside the attribution gate; not once 4 reflected."""
    world = WorldMap(tuple(Reflector(f"R{k}", float(x), float(y), 0.04) for k, (x, y) in enumerate(XY)), ())
    h, _, _ = bearing_model(POSE, MOUNT, world.reflector_xy, world.reflector_radius)

    def fresh() -> StreamingEstimator:
        return make_estimator("ekf", world, MOUNT, initial_pose=POSE, initial_covariance=np.diag([1e-6, 1e-6, 1e-6]),
                              bearing_std=1e-3, map_std=0.0)

    est = fresh()
    off = est.bearing_offset  # the estimator adds it to every reported bearing
    S = est._gate(0.0, float(h[4])).S
    assert not est.update(0.01, float(h[4]) + 4.0 * math.sqrt(S) - off)
    assert [a[1] for a in est.monitor._attributed] == [4]
    assert est.update(0.02, float(h[4]) - off)  # reflector 4 itself, in the same sweep: the attribution is void
    assert list(est.monitor._attributed) == []
    est = fresh()
    assert est.update(0.01, float(h[4]) - off)
    assert not est.update(0.02, float(h[4]) + 4.0 * math.sqrt(S) - off)  # 4 already reflected in this sweep
    assert list(est.monitor._attributed) == []
    est = fresh()
    assert not est.update(0.01, float(h[4]) + 6.0 * math.sqrt(S) - off)  # beyond the attribution gate (4.4 sigma)
    assert list(est.monitor._attributed) == []
