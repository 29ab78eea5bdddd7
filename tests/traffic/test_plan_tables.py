"""The planner's fast paths agree with their plain definitions (issue 30, replanning speed).

* the occupations reserved for a planned vehicle (computed from the search's chain of states) are
  :func:`agvnav.traffic.plan.occupation_arrays` of its plan;
* merging a vehicle's touching busy intervals keeps the busy time: every resource is busy exactly
  when some occupation that conflicts with it says so (brute force over the occupations);
* the search's scratch tables are left all -1 (the next search starts clean).
"""

from __future__ import annotations

import numpy as np

from agvnav.routes.layouts import grid_network
from agvnav.routes.network import network_from_dict
from agvnav.routes.planning import VehicleLimits
from agvnav.traffic.plan import (
    Goal,
    Reservations,
    VehicleTask,
    _plan_vehicle,
    occupation_arrays,
    plan_fleet,
    traffic_index,
)

LIM = VehicleLimits("differential", 1.0)


class _TouchZones:
    """A node conflicts with itself and the edges at it; an edge with its ends and its twin."""

    def __init__(self, network: object) -> None:
        self.net = network

    def conflicts(self, model_a: str, res: tuple[str, str], model_b: str) -> frozenset[tuple[str, str]]:
        edges = self.net.edges.values()  # type: ignore[attr-defined]
        if res[0] == "node":
            return frozenset({res} | {("edge", e.id) for e in edges if res[1] in (e.source, e.target)})
        e = self.net.edges[res[1]]  # type: ignore[attr-defined]
        twin = {("edge", x.id) for x in edges if {x.source, x.target} == {e.source, e.target}}
        return frozenset({res, ("node", e.source), ("node", e.target)} | twin)


def _fleet(seed: int, n: int = 14) -> tuple[object, _TouchZones, list[VehicleTask]]:
    net = network_from_dict(grid_network(8, 5.0))
    rng = np.random.default_rng(seed)
    nodes = list(net.nodes)
    pick = rng.choice(len(nodes), 3 * n, replace=False)
    tasks = [VehicleTask(f"V{i}", LIM, nodes[int(pick[i])],
                         (Goal(nodes[int(pick[n + i])], 2.0), Goal(nodes[int(pick[2 * n + i])], 1.0)))
             for i in range(n)]
    return net, _TouchZones(net), tasks


def test_reserved_occupations_are_the_plan_s_and_busy_time_is_kept() -> None:
    for seed in range(3):
        net, zones, tasks = _fleet(seed)
        ix = traffic_index(net, zones)  # type: ignore[arg-type]
        res = Reservations(ix, [LIM.model])
        occs = []
        served = 0
        for t in tasks:
            out = _plan_vehicle(t, ix.graph(LIM), res)  # without the end points reserved: some may be blocked
            if out is None:
                continue
            served += 1
            vplan, (q, t0, t1) = out
            want = occupation_arrays(vplan, ix)
            for got, ref in zip((q, t0, t1), want, strict=True):
                np.testing.assert_array_equal(got, ref)
            res.add_arrays(t.vehicle, LIM.model, q, t0, t1)
            occs += list(zip(q.tolist(), t0.tolist(), t1.tolist(), strict=True))
        assert served >= len(tasks) // 2
        ptr, idx = ix.conf(LIM.model, LIM.model)
        probes = np.linspace(0.0, 400.0, 801)
        for r in range(ix.n_res):
            busy = np.zeros(len(probes), dtype=bool)
            for q, a, b in occs:
                if r in idx[ptr[q]:ptr[q + 1]]:
                    busy |= (probes >= a) & (probes < b)
            mine = np.zeros(len(probes), dtype=bool)
            n = int(res.bn[LIM.model][r])
            for a, b in zip(res.b0[LIM.model][r, :n], res.b1[LIM.model][r, :n], strict=True):
                mine |= (probes >= a) & (probes < b)
            assert np.array_equal(busy, mine), r


def test_the_search_leaves_its_scratch_tables_clean() -> None:
    net, zones, tasks = _fleet(7)
    plan_fleet(net, tasks, zones)  # type: ignore[arg-type]
    g = traffic_index(net, zones).graph(LIM)  # type: ignore[arg-type]
    best_at, iv_at = g.scratch(*g.flat_classes()[:1], 2)
    assert len(best_at) > 0 and (best_at == -1).all() and (iv_at == -1).all()
