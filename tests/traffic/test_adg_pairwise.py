"""``build_adg`` (pairs as arrays) against its definition visited pair by pair, and Kahn's check against networkx.

Reference: every pair of conflicting occupations of two vehicles in the plans' order, the order of
passage from the planned times, the latest giving-up kept per vehicle pair and event, the first
invalid pair refused (the module doc of :mod:`agvnav.traffic.adg`, written out plainly here).
"""

from __future__ import annotations

from collections import defaultdict

import networkx as nx
import numpy as np
import pytest
from texec_support import DiscZones

from agvnav.routes.layouts import grid_network
from agvnav.routes.network import network_from_dict
from agvnav.routes.planning import VehicleLimits
from agvnav.traffic.adg import Adg, Dependency, PlanConflictError, build_adg
from agvnav.traffic.plan import NEVER, FleetPlan, Goal, Occupation, VehicleTask, plan_fleet

LIM = VehicleLimits("differential", 1.0)


def _reference(plan: FleetPlan, zones: DiscZones) -> dict[tuple[str, int, str], Dependency]:
    occs = [o for p in plan.plans.values() for o in p.occupations()]
    by_res: dict[tuple[str, tuple[str, str]], list[Occupation]] = defaultdict(list)
    models = sorted({o.model for o in occs})
    for o in occs:
        for mb in models:
            for r in zones.conflicts(o.model, o.resource, mb):
                by_res[(mb, r)].append(o)
    best: dict[tuple[str, int, str], Dependency] = {}
    for ob in occs:
        for oa in by_res.get((ob.model, ob.resource), ()):
            if oa.vehicle == ob.vehicle:
                continue
            if oa.t1 <= ob.t0:
                first, later = oa, ob
            elif ob.t1 <= oa.t0:
                first, later = ob, oa
            else:
                raise PlanConflictError("overlap")
            if later.acquire < 0 or later.acquire % 2 == 1:
                continue
            if first.release >= NEVER:
                raise PlanConflictError("parks")
            key = (later.vehicle, later.acquire, first.vehicle)
            old = best.get(key)
            if old is None or old.after_event < first.release:
                best[key] = Dependency(later.vehicle, later.acquire, first.vehicle, first.release, later.resource)
    return best


def _plan(seed: int, n: int) -> tuple[FleetPlan, DiscZones]:
    net = network_from_dict(grid_network(6, 4.0))
    zones = DiscZones(net, {"differential": 0.55})
    rng = np.random.default_rng(seed)
    nodes = list(net.nodes)
    pick = rng.choice(len(nodes), 3 * n, replace=False)
    tasks = [VehicleTask(f"V{i}", LIM, nodes[int(pick[i])], (Goal(nodes[int(pick[n + i])], 2.0),
                                                              Goal(nodes[int(pick[2 * n + i])], 1.0)))
             for i in range(n)]
    return plan_fleet(net, tasks, zones), zones


@pytest.mark.parametrize(("seed", "n"), [(0, 4), (1, 8), (2, 12), (3, 2)])
def test_build_adg_keeps_the_dependencies_of_the_pairwise_definition(seed: int, n: int) -> None:
    """The same dependencies (vehicle, event, after, after_event and resource), in the same order."""
    plan, zones = _plan(seed, n)
    ref = _reference(plan, zones)
    adg = build_adg(plan, zones)
    got = [d for by in adg.deps.values() for lst in by.values() for d in lst]
    want_by_vehicle = [d for v in plan.plans for d in ref.values() if d.vehicle == v]
    assert sorted(got, key=repr) == sorted(ref.values(), key=repr)
    order = {id(d): i for i, d in enumerate(ref.values())}
    for v, by in adg.deps.items():  # within one event, the order the pairs were first met
        for e, lst in by.items():
            want = sorted((d for d in ref.values() if d.vehicle == v and d.event == e), key=lambda d: order[id(d)])
            assert lst == want
    assert len(want_by_vehicle) == adg.n_dependencies


def test_build_adg_refuses_an_overlap_as_the_pairwise_definition_does() -> None:
    """Two plans shifted onto each other's times: both refuse."""
    plan, zones = _plan(5, 6)
    v0, v1 = list(plan.plans)[:2]
    moved = dict(plan.plans)
    p1 = moved[v1]
    moved[v1] = type(p1)(p1.vehicle, p1.model, moved[v0].start, moved[v0].steps, p1.goals, p1.arrivals, p1.ready_s)
    bad = FleetPlan(moved, {}, plan.order, plan.plan_s)
    with pytest.raises(PlanConflictError):
        _reference(bad, zones)
    with pytest.raises(PlanConflictError):
        build_adg(bad, zones)


@pytest.mark.parametrize("seed", range(20))
def test_is_acyclic_agrees_with_networkx(seed: int) -> None:
    """Random dependency sets over chains of events (cycles likely or not): Kahn's answer is networkx's."""
    rng = np.random.default_rng(seed)
    n_events = {f"V{i}": 2 * int(rng.integers(0, 6)) for i in range(5)}
    live = [v for v, n in n_events.items() if n]
    deps: dict[str, dict[int, list[Dependency]]] = defaultdict(lambda: defaultdict(list))
    for _ in range(int(rng.integers(0, 8))):
        a, b = rng.choice(live, 2)
        e, f = int(rng.integers(0, n_events[a])), int(rng.integers(0, n_events[b]))
        deps[str(a)][e].append(Dependency(str(a), e, str(b), f, ("node", "x")))
    adg = Adg(n_events, {v: dict(by) for v, by in deps.items()})
    g = nx.DiGraph()
    g.add_nodes_from((v, e) for v, n in n_events.items() for e in range(n))
    g.add_edges_from(adg.edges())
    assert adg.is_acyclic() == nx.is_directed_acyclic_graph(g)
