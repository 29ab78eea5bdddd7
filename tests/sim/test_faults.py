"""Fault wrappers (issue 12 §3): each fault has its known effect on a known stream."""

import math

import numpy as np
import pytest

from agvnav.sim.faults import FaultyPlant, FaultySensor, world_with_faults
from agvnav.world import Reflector, WorldMap
from agvnav.world.scenario import FaultSpec

WORLD = WorldMap(reflectors=(Reflector("A", 0.0, 5.0), Reflector("B", 5.0, 0.0), Reflector("C", -5.0, 0.0)))


class _Sensor:
    """Events every 10 ms, reflector index cycling 0, 1, 2, bearing = 0.1 * index."""

    name = "reflections"
    event_names = ("t", "bearing", "reflector_index")

    def __init__(self, estimator=None):
        self.delivered = []
        self.estimator = estimator

    def observe(self, pose_at, t0, t1, rng):
        k = np.arange(math.floor(t0 * 100 + 1e-9) + 1, math.floor(t1 * 100 + 1e-9) + 1)
        idx = (k % 3).astype(float)
        return np.column_stack([k / 100.0, 0.1 * idx, idx])

    def deliver(self, event):
        self.estimator.update(float(event[0]), float(event[1]))


class _Est:
    def __init__(self, strict=False):
        self.updates, self.t, self.strict = [], 0.0, strict

    def update(self, t, bearing):
        if self.strict and t < self.t:
            raise ValueError("out of order")
        self.t = max(self.t, t)
        self.updates.append((t, bearing))


def _fault(**kw):
    return FaultSpec(**kw)


def _collect(sensor, t_end=2.0, dt=0.05):
    rows = [sensor.observe(None, k * dt, (k + 1) * dt, None) for k in range(round(t_end / dt))]
    return np.concatenate(rows, axis=0)


def test_blind_drops_exactly_the_window():
    s = FaultySensor(_Sensor(), [_fault(kind="blind", start_s=0.5, duration_s=0.5)], WORLD, 8.0, 0)
    ev = _collect(s)
    assert not np.any((ev[:, 0] >= 0.5) & (ev[:, 0] < 1.0))
    assert ev.shape[0] == 200 - 50 and s.dropped == 50


def test_reflector_removed_drops_only_that_reflector():
    s = FaultySensor(_Sensor(), [_fault(kind="reflector_removed", reflector="B")], WORLD, 8.0, 0)
    ev = _collect(s)
    assert not np.any(ev[:, 2] == 1) and np.any(ev[:, 2] == 0) and np.any(ev[:, 2] == 2)


def test_clutter_adds_spurious_events_at_the_poisson_rate_reproducibly():
    f = [_fault(kind="clutter", start_s=1.0, per_revolution=5.0)]
    a = _collect(FaultySensor(_Sensor(), f, WORLD, 8.0, 3), t_end=40.0)
    b = _collect(FaultySensor(_Sensor(), f, WORLD, 8.0, 3), t_end=40.0)
    np.testing.assert_array_equal(a, b)  # bit for bit with the same seed
    spurious = a[a[:, 2] == -1]
    assert np.all(spurious[:, 0] > 1.0) and np.all(np.abs(spurious[:, 1]) <= math.pi)
    expected = 5.0 * 8.0 * 39.0  # per revolution x revolutions per second x seconds
    assert abs(spurious.shape[0] - expected) < 4 * math.sqrt(expected)
    assert np.all(np.diff(a[:, 0]) >= 0)  # still in time order


def test_delay_arrival_stamped_and_measurement_stamped():
    est = _Est()
    s = FaultySensor(_Sensor(est), [_fault(kind="reflection_delay", delay_s=0.12)], WORLD, 8.0, 0)
    ev = _collect(s, t_end=1.0)
    assert s.event_names[-1] == "stamp" and ev.shape[1] == 4
    np.testing.assert_allclose(ev[:, 0], np.arange(13, 101) / 100.0)  # arrivals 0.13..1.00 (0.01..0.88 + 0.12)
    np.testing.assert_array_equal(ev[:, 3], ev[:, 0])  # stamped on arrival
    s.deliver(ev[0])
    assert est.updates == [(0.13, ev[0, 1])]
    strict = _Est(strict=True)
    strict.t = 0.5
    st = FaultySensor(_Sensor(strict), [_fault(kind="reflection_delay", delay_s=0.12, stamped=True)], WORLD, 8.0, 0)
    ev = _collect(st, t_end=1.0)
    np.testing.assert_allclose(ev[:, 3], ev[:, 0] - 0.12)  # the measurement time travels with the event
    st.deliver(ev[0])  # older than the estimator's time: refused, counted, the run goes on
    assert st.late_rejected == 1 and strict.updates == []


def test_world_with_faults_moves_the_true_reflector_only():
    moved = world_with_faults(WORLD, [_fault(kind="reflector_moved", reflector="A", offset_m=(0.5, -0.25))])
    np.testing.assert_allclose(moved.reflector_xy[0], [0.5, 4.75])
    np.testing.assert_array_equal(moved.reflector_xy[1:], WORLD.reflector_xy[1:])
    with pytest.raises(ValueError, match="Z"):
        world_with_faults(WORLD, [_fault(kind="reflector_removed", reflector="Z")])


class _Plant:
    """Moves 0.01 m and turns 0.001 rad per step."""

    signal_names = ("x",)

    def advance(self, command, t0, dt, rng):
        pass

    def pose_at(self, t):
        return np.zeros((len(t), 3))

    def odometry(self):
        return 0.01, 0.001, 0.0

    def signals(self):
        return (0.0,)

    def failure(self):
        return None


def _odometry(faults, n=100, dt=0.05):
    p = FaultyPlant(_Plant(), [FaultSpec(**f) for f in faults])
    out = []
    for k in range(n):
        p.advance((0.0,), k * dt, dt, None)
        out.append(p.odometry())
    return np.array(out)


def test_wheel_slip_scales_the_distance_in_its_window():
    o = _odometry([{"kind": "wheel_slip", "start_s": 1.0, "duration_s": 1.0, "slip_fraction": 0.3}])
    assert np.sum(o[:, 0]) == pytest.approx(100 * 0.01 + 20 * 0.003)
    assert np.all(o[:, 1] == 0.001)


def test_encoder_dropout_loses_the_motion():
    o = _odometry([{"kind": "encoder_dropout", "start_s": 1.0, "duration_s": 1.0}])
    assert np.sum(o[:, 0]) == pytest.approx(80 * 0.01) and np.sum(o[:, 1]) == pytest.approx(80 * 0.001)


def test_lost_odometry_messages_arrive_summed_in_the_next_one():
    o = _odometry([{"kind": "odometry_lost", "start_s": 1.0, "duration_s": 1.0}])
    assert np.sum(o[:, 0]) == pytest.approx(1.0) and np.sum(o[:, 1]) == pytest.approx(0.1)
    assert np.count_nonzero(o[:, 0] == 0.0) == 20 and o[:, 0].max() == pytest.approx(21 * 0.01)


def test_counter_wrap_adds_one_jump_once():
    o = _odometry([{"kind": "counter_wrap", "start_s": 1.0, "jump_m": 6.5e5}])
    jumps = np.flatnonzero(o[:, 0] > 1.0)
    assert jumps.tolist() == [20] and o[20, 0] == pytest.approx(6.5e5 + 0.01)


def test_fault_spec_fields_per_kind():
    with pytest.raises(ValueError, match="needs reflector"):
        FaultSpec(kind="reflector_moved", offset_m=(1.0, 0.0))
    with pytest.raises(ValueError, match="takes no jump_m"):
        FaultSpec(kind="blind", jump_m=3.0)
    assert FaultSpec(kind="blind", start_s=2.0, duration_s=1.5).end_s == 3.5
    assert math.isinf(FaultSpec(kind="clutter", per_revolution=1.0).end_s)
