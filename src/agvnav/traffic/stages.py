"""Staged planning: vehicles whose goals are one another's starts, planned cycle after cycle (issue 30).

Prioritised planning (:func:`agvnav.traffic.plan.plan_fleet`) plans each vehicle against the ones
planned before it and keeps the start of every vehicle not yet planned reserved. It fails when every
goal is another vehicle's start: eight vehicles swapping ends on one two-way lane with one passing bay
(``lane_swap``, every station full). The first vehicle planned cannot reach its goal while the vehicle
standing there is not planned to leave, and, with a finite hold of the starts, the vehicles planned
first drive out early and wait on the lane near their goals, so the later ones cannot get out.

:func:`plan_fleet_staged` first tries :func:`~agvnav.traffic.plan.plan_fleet` as it is. When it leaves
vehicles unserved it splits the vehicles into the cycles (and chains) of "my last goal is your start"
and plans them as stages, one after the other:

* a stage is one cycle, joined by the next ones while it stays fully served: prioritised planning of its
  vehicles only, from the time the stages before it
  are done (their vehicles park at their goals, reserved for ever: committed occupations), while the
  vehicles of the later stages stand at their starts (reserved for ever: they have not moved yet);
* inside a stage the start of a vehicle not yet planned stays reserved ``hold`` seconds only, so the
  vehicle planned first may plan to arrive there after it is left (a swap of two: one waits in the bay
  while the other passes); the holds of :data:`HOLDS_S` and both orders of the cycle's vehicles are
  tried until one plan serves them all;
* a stage that cannot be served leaves its vehicles at their starts (reported in ``unserved``), and
  the later stages go on.

Every stage plans against everything decided before it, so the whole plan holds no conflicting
resources at overlapping times; the ADG (:mod:`agvnav.traffic.adg`) executes it as any other plan
(the later stages wait for the earlier ones' passages, whatever the delays). The stages are
sequential, so this trades time for getting the swap done at all: ``lane_swap`` with eight vehicles
takes about four two-vehicle swaps one after the other.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence

from agvnav.routes.network import RouteNetwork
from agvnav.traffic.plan import (
    INF,
    NEVER,
    Conflicts,
    FleetPlan,
    Occupation,
    TrafficIndex,
    VehiclePlan,
    VehicleTask,
    plan_fleet,
)

__all__ = ["HOLDS_S", "goal_cycles", "plan_fleet_staged"]

#: Holds (s) of a not-yet-planned start tried inside a stage (module doc), shortest first.
HOLDS_S = (30.0, 60.0, 120.0, 240.0)


def goal_cycles(tasks: Sequence[VehicleTask]) -> list[list[VehicleTask]]:
    """The tasks grouped by "my last goal is your start": each group a chain or a cycle, in the tasks' order.

    A group follows the successors (the vehicle standing at this one's last goal) from the first task
    not yet grouped; a chain ends at a goal no vehicle stands at.
    """
    by_start = {t.start: t for t in tasks}
    seen: set[str] = set()
    groups: list[list[VehicleTask]] = []
    for t in tasks:
        group: list[VehicleTask] = []
        x: VehicleTask | None = t
        while x is not None and x.vehicle not in seen:
            seen.add(x.vehicle)
            group.append(x)
            x = by_start.get(x.goals[-1].station) if x.goals else None
        if group:
            groups.append(group)
    return groups


def plan_fleet_staged(network: RouteNetwork, tasks: Sequence[VehicleTask], zones: Conflicts,
                      index: TrafficIndex | None = None) -> FleetPlan:
    """:func:`~agvnav.traffic.plan.plan_fleet`, or when it leaves vehicles unserved, the stages (module doc).

    Returns the plan that serves more vehicles (the one-shot plan on a tie); ``plan_s`` covers all the
    planning done.
    """
    t_wall = time.perf_counter()
    first = plan_fleet(network, tasks, zones, index)
    if not first.unserved:
        return first
    staged = _stages(network, tasks, zones, index)
    best = staged if len(staged.unserved) < len(first.unserved) else first
    return dataclasses.replace(best, plan_s=time.perf_counter() - t_wall)


def _stages(network: RouteNetwork, tasks: Sequence[VehicleTask], zones: Conflicts,
            index: TrafficIndex | None) -> FleetPlan:
    groups = goal_cycles(tasks)
    plans: dict[str, VehiclePlan] = {}
    unserved: dict[str, str] = {}
    done: list[Occupation] = []
    t_ready = 0.0
    k = 0
    while k < len(groups):
        _, plan, k = _grow_stage(network, groups, k, zones, index, done, t_ready)
        for v, p in plan.plans.items():
            plans[v] = p
            done += p.occupations()
        unserved.update(plan.unserved)
        t_ready = max([t_ready] + [p.end_s for v, p in plan.plans.items() if v not in plan.unserved])
    return FleetPlan(plans, unserved, tuple(t.vehicle for g in groups for t in g))


def _grow_stage(network: RouteNetwork, groups: list[list[VehicleTask]], k: int, zones: Conflicts,
                index: TrafficIndex | None, done: list[Occupation], t_ready: float
                ) -> tuple[list[VehicleTask], FleetPlan, int]:
    """The stage from group ``k`` on: the next groups join it while the stage stays fully served (fewer,
    shorter stages); the stage's tasks, its plan and the first group left for the next stage."""
    stage = list(groups[k])
    plan = _stage(network, stage, zones, index, done + _waiting(groups[k + 1:]), t_ready)
    k += 1
    while not plan.unserved and k < len(groups):
        bigger = stage + groups[k]
        trial = _stage(network, bigger, zones, index, done + _waiting(groups[k + 1:]), t_ready)
        if trial.unserved:
            break
        stage, plan, k = bigger, trial, k + 1
    return stage, plan, k


def _waiting(groups: list[list[VehicleTask]]) -> list[Occupation]:
    """The vehicles of later stages stand at their starts: their nodes held for ever (they have not moved)."""
    return [Occupation(f"{t.vehicle}@start", t.limits.model, ("node", t.start), 0.0, INF, -1, NEVER)
            for g in groups for t in g]


def _stage(network: RouteNetwork, group: list[VehicleTask], zones: Conflicts, index: TrafficIndex | None,
           committed: list[Occupation], t_ready: float) -> FleetPlan:
    """One stage: the group from ``t_ready`` on, holds and orders tried (module doc); the best tried."""
    # a vehicle stands at its start until its stage begins: its node is held from 0 (the waiting occupation)
    held = [Occupation(f"{t.vehicle}@start", t.limits.model, ("node", t.start), 0.0, t_ready, -1, NEVER)
            for t in group if t_ready > max(t.ready_s, 0.0)]
    moved = [dataclasses.replace(t, ready_s=max(t.ready_s, t_ready)) for t in group]
    best: FleetPlan | None = None
    for hold in HOLDS_S:
        for order in (moved, moved[::-1]):
            plan = plan_fleet(network, order, zones, index, committed + held, start_hold_s=hold)
            if best is None or len(plan.unserved) < len(best.unserved):
                best = plan
            if not plan.unserved:
                return plan
    assert best is not None
    return best
