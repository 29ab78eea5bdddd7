"""The VDA 5050 master with traffic control (issues 30, 31): routes planned together, bases released by the ADG.

Two agvnav vehicles on the in-process bus, each in its own simulated world, whose routes cross: the test
places their true footprints in one hall every step (the brute-force check the simulated worlds do not do).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from shapely.geometry import Polygon

from agvnav.vda5050.bus import InProcessBus
from agvnav.vda5050.master import JobMaster, MasterMessages, job_master, load_fleet_spec
from agvnav.vda5050.vehicle import VdaVehicle, VehicleConfig
from agvnav.world.scenario import parse_scenario

# Two straight one-way lanes in the hall crossing at (10, 5): west A0 -> east A1, south B0 -> north B1; the vehicles
# start 3.5 m before the crossing, so at the same speed they reach it together.
CROSS = """\
name: hall_cross
description: two one-way lanes crossing in the hall
tolerances: {joint_deg: 5.0}
nodes:
- {id: A0, x: 6.5, y: 5.0, heading_deg: 0.0, kind: station}
- {id: A1, x: 16.0, y: 5.0, heading_deg: 0.0, kind: station}
- {id: B0, x: 10.0, y: 1.5, heading_deg: 90.0, kind: station}
- {id: B1, x: 10.0, y: 10.0, heading_deg: 90.0, kind: station}
edges:
- {id: a, from: A0, to: A1, speed_m_s: 1.0}
- {id: b, from: B0, to: B1, speed_m_s: 1.0}
"""

SCENARIO = """\
name: cross_vehicle
seed: {seed}
step_s: 0.05
map: hall
world_truth: {{reflector_survey_std_m: 0.002}}
traction: {{speed_m_s: 1.0, max_accel_m_s2: 0.3, max_decel_m_s2: 0.3}}
goniometer: {{mount: [0.0, 0.0, 0.0], p_miss: 0.05}}
positioning: {{method: ekf, odometry_noise: [5.0e-5, 8.0e-4, 2.0e-4]}}
vehicle: {{model: differential, track_m: 0.5, wheel_radius_m: 0.08, encoder_counts_per_rev: 4096,
          truth: {{wheel_diameter_ratio: 1.002, track_ratio: 1.01, slip_k: 0.0001}}}}
controller: {{name: kanayama, params: {{convergence_distance: 0.5}}}}
mission: {{network: cross.yaml, start: {start}, jobs: [{{action: goto, station: {goal}}}]}}
"""


def _footprint(v: VdaVehicle) -> Polygon:
    fp = np.asarray(v.truth_plant.footprint, dtype=np.float64)
    x, y, h = (float(c) for c in np.asarray(v.truth_plant.pose)[:3])
    c, s = math.cos(h), math.sin(h)
    return Polygon(np.column_stack([x + c * fp[:, 0] - s * fp[:, 1], y + s * fp[:, 0] + c * fp[:, 1]]))


def _vehicles(tmp_path: Path) -> dict[str, VdaVehicle]:
    (tmp_path / "cross.yaml").write_text(CROSS)
    fleet = {}
    for i, (serial, start, goal) in enumerate((("a", "A0", "A1"), ("b", "B0", "B1"))):
        sc = parse_scenario(SCENARIO.format(seed=i, start=start, goal=goal), str(tmp_path / f"{serial}.yaml"),
                            base_dir=tmp_path)
        fleet[serial] = VdaVehicle(sc, VehicleConfig("agvnav", serial, "2.1.0", state_period_s=5.0,
                                                     visualization_period_s=0.0))
    return fleet


def test_crossing_vehicles_take_turns_as_the_adg_releases_their_bases(tmp_path: Path) -> None:
    fleet = _vehicles(tmp_path)
    v0 = fleet["a"]
    bus = InProcessBus(fleet, "2.1.0")
    master = JobMaster(v0.network, v0.map_id, "2.1.0", "agvnav", list(fleet), {"a": "A0", "b": "B0"},
                       bus.publish_master, instant_period_s=0.0, action_s=1.0, traffic=True)
    master.max_jobs = 1
    reached: dict[str, float] = {}

    def on_message(serial: str, topic: str, msg: dict[str, object]) -> None:
        master.on_message(serial, topic, msg)
        last = msg.get("lastNodeId")
        if topic == "state" and isinstance(last, str):
            reached.setdefault(f"{serial}:{last}", v0.t)

    bus.on_message = on_message
    closest = math.inf
    while v0.t < 60.0 and master.jobs_done < 2:
        master.tick(v0.t)
        bus.step()
        closest = min(closest, _footprint(fleet["a"]).distance(_footprint(fleet["b"])))
    assert not bus.checked.failures, bus.checked.failures[:3]
    assert master.jobs_done == 2 and all(d.done == 1 for d in master.vehicles.values())
    assert closest > 0.3  # the true footprints never came near each other
    adg = master.adg
    assert adg is not None and adg.is_acyclic()
    deps = [d for by in adg.deps.values() for lst in by.values() for d in lst]
    assert len(deps) == 1  # the crossing: one vehicle's lane waits for the other to have left it
    dep = deps[0]
    # the waiting vehicle got no step at first; its step was released only after the master marked the event it
    # waits for, from the other vehicle's reported lastNodeId
    first: dict[str, int] = {}
    for _, serial, k0, n in master.releases:
        if k0 == 0:
            first.setdefault(serial, n)
    assert first[dep.vehicle] == 0 and first[dep.after] == 1
    released_at = next(t for t, s, k0, n in master.releases if s == dep.vehicle and k0 <= dep.event // 2 < k0 + n)
    marked_at = next(t for t, s, e in master.marks if (s, e) == (dep.after, dep.after_event))
    assert released_at >= marked_at > 0.0
    goal = {"a": "a:A1", "b": "b:B1"}
    step = 0.05  # the state that marked the event arrived within the step after the master's last tick
    assert reached[goal[dep.after]] <= released_at + step and released_at < reached[goal[dep.vehicle]]


def test_without_traffic_control_the_same_orders_meet_at_the_crossing(tmp_path: Path) -> None:
    # the same two routes sent at once, wholly released (what a master without traffic control does)
    fleet = _vehicles(tmp_path)
    bus = InProcessBus(fleet, "2.1.0")
    for serial, (a, b) in (("a", ("A0", "A1")), ("b", ("B0", "B1"))):
        m = MasterMessages(fleet[serial].network, fleet[serial].map_id, "2.1.0", "agvnav", serial)
        bus.publish_master(serial, "order", m.order(f"{serial}-o", 0, [a, b], 2))
    closest = math.inf
    while fleet["a"].t < 25.0 and closest > 0.0:
        bus.step()
        closest = min(closest, _footprint(fleet["a"]).distance(_footprint(fleet["b"])))
    assert closest == 0.0  # their true footprints overlapped: a collision


def test_a_fleet_spec_turns_the_traffic_control_on(tmp_path: Path) -> None:
    p = tmp_path / "f.yaml"
    p.write_text("scenario: mission_hall_differential\nmanufacturer: acme\ntraffic: true\nmargin_m: 0.3\n"
                 "vehicles:\n  - {serial: a, start: S1}\n  - {serial: b, start: S3}\n", encoding="utf-8")
    m = job_master(load_fleet_spec(p))
    assert m.traffic and m.zones is not None and m.zones.margin_m == 0.3
    off = job_master(load_fleet_spec(_without_traffic(p)))
    assert not off.traffic and off.zones is None


def _without_traffic(p: Path) -> Path:
    q = p.with_name("g.yaml")
    q.write_text(p.read_text(encoding="utf-8").replace("traffic: true\nmargin_m: 0.3\n", ""), encoding="utf-8")
    return q
