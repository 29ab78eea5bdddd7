"""Transport jobs and their dispatch (issue 30): bad input located, unserved jobs reported, streams repeatable.

Ground truth: the file's own lines and keys; the network's reachability (a one-way spur with no way out);
a stream drawn twice from one seed.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from agvnav.routes.network import load_network, network_from_dict
from agvnav.routes.planning import VehicleLimits
from agvnav.traffic.dispatch import DriveTimes, FleetVehicle, dispatch, tasks_of
from agvnav.traffic.jobs import TransportJob, generate_jobs, load_jobs
from agvnav.world.fleet import JobStreamSpec
from agvnav.world.strict import ScenarioError

LIM = VehicleLimits("differential", 1.0)


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "jobs.yaml"
    p.write_text(text, encoding="utf-8")
    return p


def test_an_unknown_pick_station_names_file_line_and_key(tmp_path: Path) -> None:
    net = load_network("lane_swap")
    p = _write(tmp_path, "jobs:\n- {id: A, pick: WA, drop: EC}\n- id: B\n  pick: NOWHERE\n  drop: EC\n")
    with pytest.raises(ScenarioError) as err:
        load_jobs(p, net, ["WA", "EC"])
    msg = str(err.value)
    assert str(p) in msg and ":4" in msg and "jobs.1.pick" in msg.replace("[", ".").replace("]", "")
    assert "NOWHERE" in msg


def test_an_unknown_stream_station_and_a_drop_at_the_pick_are_located(tmp_path: Path) -> None:
    net = load_network("lane_swap")
    p = _write(tmp_path, "job_stream:\n  rate_per_h: 60\n  count: 5\n  stations: [WA, XX]\n")
    with pytest.raises(ScenarioError, match="XX") as err:
        load_jobs(p, net, [])
    assert err.value.line == 4 and err.value.key[-1] == 1
    p = _write(tmp_path, "jobs:\n- {id: A, pick: WA, drop: WA}\n")
    with pytest.raises(ScenarioError, match="pick station") as err:
        load_jobs(p, net, [])
    assert err.value.line == 2 and err.value.key[-1] == "drop"


def _dead_end() -> dict[str, object]:
    """A two-way line A-B-C and a one-way spur B->D: nothing leaves D."""
    nodes = [{"id": n, "x": x, "y": y, "kind": "station"} for n, x, y in
             (("A", 0.0, 0.0), ("B", 5.0, 0.0), ("C", 10.0, 0.0), ("D", 5.0, 5.0))]
    edges = [{"id": "A-B", "from": "A", "to": "B", "two_way": True},
             {"id": "B-C", "from": "B", "to": "C", "two_way": True}, {"id": "B-D", "from": "B", "to": "D"}]
    return {"name": "dead_end", "nodes": nodes, "edges": edges, "tolerances": {"joint_deg": 5.0}}


def test_a_job_no_vehicle_can_serve_is_reported_with_the_reason() -> None:
    net = network_from_dict(_dead_end())
    jobs = [TransportJob("ok", "A", "C"), TransportJob("stuck", "D", "A")]
    out = dispatch(jobs, [FleetVehicle("V0", LIM, "A")], DriveTimes(net))
    assert [j.id for j in out.jobs["V0"]] == ["ok"]
    assert [(j.id, "'D'" in why and "'A'" in why) for j, why in out.unserved] == [("stuck", True)]
    tasks = tasks_of(out, [FleetVehicle("V0", LIM, "A")])
    assert [g.station for g in tasks[0].goals] == ["A", "C", "A"]


def test_the_nearest_idle_vehicle_takes_a_job_and_jobs_go_in_release_then_priority_order() -> None:
    net = load_network("lane_swap")
    west, east = FleetVehicle("W", LIM, "WA"), FleetVehicle("E", LIM, "EA")
    jobs = [TransportJob("late", "WB", "WC", 100.0), TransportJob("low", "EB", "EC", 0.0, 0),
            TransportJob("high", "WB", "WD", 0.0, 5)]
    out = dispatch(jobs, [west, east], DriveTimes(net))
    assert [j.id for j in out.jobs["W"]] == ["high", "late"] and [j.id for j in out.jobs["E"]] == ["low"]
    assert out.unserved == []


def test_a_job_stream_is_the_same_from_the_same_seed_and_differs_from_another() -> None:
    stations = ["WA", "WB", "EA", "EB"]
    a = generate_jobs(JobStreamSpec(rate_per_h=120.0, count=50, seed=7), stations)
    b = generate_jobs(JobStreamSpec(rate_per_h=120.0, count=50, seed=7), stations)
    c = generate_jobs(JobStreamSpec(rate_per_h=120.0, count=50, seed=8), stations)
    assert a == b and a != c
    assert all(j.pick != j.drop and {j.pick, j.drop} <= set(stations) for j in a)
    rel = [j.release_s for j in a]
    assert rel[0] == 0.0 and rel == sorted(rel) and 0.0 < rel[-1] / 49 < 3600.0 / 120.0 * 3
