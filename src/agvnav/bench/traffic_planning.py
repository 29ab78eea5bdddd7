"""Planning speed for ``agvnav bench traffic``: one vehicle on a 10,000-node network (issue 30, target <= 1 ms).

:func:`bench_planning` builds a ``side`` x ``side`` grid of two-way lines
(:func:`agvnav.routes.layouts.grid_network`, 5 m spacing: 100 x 100 = 10,000 nodes, 50 x 50 in
``quick``), a :class:`agvnav.routes.planning.Planner` for a differential vehicle (it may turn
on the spot, so every query has a route), and times random node-to-node queries (seeded). The
search runs compiled (the A* kernel); the first query, which loads the kernel, is not timed.
It checks what it times: every timed route's time is compared with the interpreted search's
(scipy's Dijkstra) on the same query, and a difference beyond 1e-6 s makes ``plan_ok`` false.
nav2's route server: 0.232 ms at 10,000 nodes (its README).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from agvnav import jit
from agvnav.routes.layouts import grid_network
from agvnav.routes.network import network_from_dict
from agvnav.routes.planning import Planner, VehicleLimits

__all__ = ["PLAN_TARGET_MS", "bench_planning"]

#: The issue-30 target (ms per query, one vehicle, 10,000 nodes).
PLAN_TARGET_MS = 1.0


def bench_planning(quick: bool, seed: int = 0) -> dict[str, Any]:
    """Median planning time of random queries on a grid (module doc).

    Keys: ``plan_ms`` (median, ms), ``plan_p95_ms``, ``plan_nodes``, ``plan_states``, ``plan_queries``,
    ``plan_build_s`` (building the planner, s), ``plan_ok`` (every timed route as fast as Dijkstra's),
    ``plan_target_ms``.
    """
    side, queries = (50, 20) if quick else (100, 100)
    net = network_from_dict(grid_network(side, spacing=5.0))
    t0 = time.perf_counter()
    planner = Planner(net, VehicleLimits("differential"))
    build_s = time.perf_counter() - t0
    ids = list(net.nodes)
    rng = np.random.default_rng(seed)
    pairs = [(ids[int(a)], ids[int(b)]) for a, b in rng.integers(0, len(ids), (queries, 2))]
    before = jit.compiled()
    try:
        jit.set_compiled(True)
        planner.plan(ids[0], ids[-1])  # loads the kernel: not timed
        ms, times = [], []
        for a, b in pairs:
            t = time.perf_counter()
            route = planner.plan(a, b)
            ms.append(1000.0 * (time.perf_counter() - t))
            times.append(route.time_s)
        jit.set_compiled(False)
        reference = [planner.plan(a, b).time_s for a, b in pairs]
    finally:
        jit.set_compiled(before)
    ok = all(math.isclose(x, y, rel_tol=0.0, abs_tol=1e-6) for x, y in zip(times, reference, strict=True))
    return {"plan_ms": float(np.median(ms)), "plan_p95_ms": float(np.percentile(ms, 95)), "plan_nodes": len(ids),
            "plan_states": planner.states,
            "plan_queries": queries, "plan_build_s": build_s, "plan_ok": ok, "plan_target_ms": PLAN_TARGET_MS}
