"""Replanning a fleet when a vehicle is blocked long: the not-yet-started steps, the rest kept (issue 30).

The ADG keeps the planned order of passage through every conflict zone whatever the delays; when one
vehicle is late (a person stops it, it drives slowly) every vehicle ordered after it waits, and the
waits propagate. :class:`Replanner` (an :class:`agvnav.traffic.execute.Replan`) plans again from where
the vehicles are, so that the others may pass the late one:

* **committed**: what has happened or is under way stays. A vehicle on an edge finishes its step: the
  step (its resources from now to its planned arrival) is reserved for everyone and becomes the first
  step of its new plan, its start already done; a vehicle whose goals are all reached stays parked
  (its node reserved for ever); the goals already reached are not planned again.
* **replanned**: every step not yet started, all vehicles together (:func:`agvnav.traffic.plan.plan_fleet`
  with the committed occupations), in the order of their next planned start in the plan being executed
  (a vehicle standing ahead on a lane is planned before the ones behind it; prioritised planning keeps
  the start of every vehicle not yet planned reserved for ``start_hold_s``), a vehicle in a stop last and
  from the end of its expected stop on (its node reserved until then); when some are not served, again with those
  first (at most :data:`ATTEMPTS` plannings).
* **accepted only when safe**: the new plan must serve every vehicle, hold no conflicting resources at
  overlapping times (:func:`agvnav.traffic.adg.build_adg` checks every pair) and give an acyclic ADG;
  else the current routes and ADG stay. The new ADG starts marked where the vehicles are (a moving
  vehicle's step start done): the resources held now are pairwise free of conflict (the executor's
  checks) and every later taking waits for the planned giving up of whatever it conflicts with, so the
  ADG's safety and deadlock freedom hold from the switch on.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvnav.routes.network import RouteNetwork
from agvnav.traffic.adg import Adg, PlanConflictError, build_adg
from agvnav.traffic.execute import AdgController, Controller, Progress, RouteStep, VehicleRoute, routes_from_plan
from agvnav.traffic.plan import (
    INF,
    Conflicts,
    FleetPlan,
    Goal,
    Occupation,
    Step,
    VehiclePlan,
    VehicleTask,
    plan_fleet,
)

__all__ = ["Replanner"]

#: Gap (s) between a moving vehicle's planned arrival and the start of its replanned part.
EPS_S = 1e-3
#: Plannings tried per replan (module doc).
ATTEMPTS = 2


@dataclass
class _Vehicle:
    task: VehicleTask
    goals: tuple[Goal, ...]
    """the goals the current route's steps reach, in order."""


class Replanner:
    """Replans the fleet from the vehicles' progress (module doc); counts the replans tried and kept."""

    def __init__(self, network: RouteNetwork, zones: Conflicts, tasks: Sequence[VehicleTask],
                 footprints: Mapping[str, NDArray[np.float64]], plan: FleetPlan, start_hold_s: float = 30.0,
                 stop_guess_s: float = 30.0) -> None:
        self.stop_guess_s = stop_guess_s
        """how long (s) a vehicle in a stop is expected to stay stopped (it is planned to move on after it)."""
        self.start_hold_s = start_hold_s
        """how long (s) the start of a vehicle not yet planned stays reserved (:func:`plan_fleet`)."""
        self.plan = plan
        """the plan being executed (its steps are the routes' steps, one for one)."""
        self.network = network
        self.zones = zones
        self.footprints = footprints
        self.vehicles = {t.vehicle: _Vehicle(t, t.goals) for t in tasks}
        self.tried = 0
        self.kept = 0

    def __call__(self, t: float, progress: Mapping[str, Progress], routes: Mapping[str, VehicleRoute]
                 ) -> tuple[dict[str, VehicleRoute], Controller] | None:
        """New routes and their ADG controller, or None when the replan is not served or not safe."""
        self.tried += 1
        committed: list[Occupation] = []
        tasks: list[tuple[float, VehicleTask]] = []
        heads: dict[str, Step] = {}
        left: dict[str, tuple[Goal, ...]] = {}
        for v, p in progress.items():
            r, info = routes[v], self.vehicles[v]
            model = info.task.limits.model
            before = sum(st.reached for st in r.steps[:p.k])
            goals = info.goals[before:]
            left[v] = goals
            if p.done or not goals:
                node = r.steps[-1].traversal.edge.target if r.steps else r.start
                committed.append(Occupation(v, model, ("node", node), t, INF, -1, -1))
                continue
            start, ready = self._position(v, p, r, t, committed, heads)
            if p.stopped:
                committed.append(Occupation(v, model, ("node", start), t, ready + self.stop_guess_s, -1, -1))
                ready += self.stop_guess_s
            rest = goals[r.steps[p.k].reached:] if p.moving else goals
            if not rest:
                committed.append(Occupation(v, model, ("node", start), t, INF, -1, -1))
                continue
            task = VehicleTask(v, info.task.limits, start, rest, ready_s=ready)
            tasks.append((INF if p.stopped else self._next_start(v, p), task))
        order = [tk for _, tk in sorted(tasks, key=lambda x: x[0])]
        plan = plan_fleet(self.network, order, self.zones, committed=committed, start_hold_s=self.start_hold_s)
        for _ in range(ATTEMPTS - 1):
            if not plan.unserved:
                break
            order = [tk for tk in order if tk.vehicle in plan.unserved] + [
                tk for tk in order if tk.vehicle not in plan.unserved]
            plan = plan_fleet(self.network, order, self.zones, committed=committed, start_hold_s=self.start_hold_s)
        if plan.unserved:
            return None
        plan = self._with_heads(plan, heads, progress, routes, t)
        try:
            adg = build_adg(plan, self.zones)
        except PlanConflictError:
            return None
        if not adg.is_acyclic():
            return None
        self._mark(adg, heads)
        new = self._routes(plan, heads, progress, routes)
        for v, goals in left.items():
            self.vehicles[v].goals = goals
        self.kept += 1
        self.plan = plan
        return new, AdgController(adg)

    def _next_start(self, v: str, p: Progress) -> float:
        """The planned start (s) of ``v``'s next step not under way, in the plan being executed."""
        steps = self.plan.plans[v].steps
        k = p.k + 1 if p.moving else p.k
        return steps[k].t_start if k < len(steps) else INF

    def _position(self, v: str, p: Progress, r: VehicleRoute, t: float, committed: list[Occupation],
                  heads: dict[str, Step]) -> tuple[str, float]:
        """Where and when the replanned part of ``v`` starts; a step under way is committed and kept in ``heads``."""
        model = self.vehicles[v].task.limits.model
        if not p.moving:
            return (r.steps[p.k].traversal.edge.source if r.steps else r.start), t
        tr = r.steps[p.k].traversal
        st = Step(tr, tr.edge.source, tr.edge.target, t, p.eta_s, 0)
        for res in st.resources():
            committed.append(Occupation(v, model, res, t, p.eta_s, 0, 1))
        heads[v] = st
        return tr.edge.target, p.eta_s + EPS_S

    def _with_heads(self, plan: FleetPlan, heads: Mapping[str, Step], progress: Mapping[str, Progress],
                    routes: Mapping[str, VehicleRoute], t: float) -> FleetPlan:
        """The plans with each step under way first (a vehicle parking after it: that step alone)."""
        plans = dict(plan.plans)
        for v, head in heads.items():
            info = self.vehicles[v]
            old = plans.get(v)
            steps = (head, *(old.steps if old else ()))
            r = routes[v]
            before = sum(st.reached for st in r.steps[:progress[v].k])
            reached = r.steps[progress[v].k].reached
            head_goals = info.goals[before:before + reached]
            if reached:
                steps = (head._replace(arrives=0, reached=reached), *steps[1:])
                steps = (steps[0], *(s._replace(goal=s.goal + reached,
                                                arrives=None if s.arrives is None else s.arrives + reached)
                                     for s in steps[1:]))
            goals = head_goals + (old.goals if old else ())
            arrivals = (head.t_end,) * reached + (old.arrivals if old else ())
            plans[v] = VehiclePlan(v, info.task.limits.model, head.source, steps, goals, arrivals, t)
        order = tuple(plan.order) + tuple(v for v in heads if v not in plan.plans)
        return FleetPlan(plans, {}, order, plan.plan_s)

    @staticmethod
    def _mark(adg: Adg, heads: Mapping[str, Step]) -> None:
        """The steps under way: their start events done."""
        for v in heads:
            adg.done[v] = 1

    def _routes(self, plan: FleetPlan, heads: Mapping[str, Step], progress: Mapping[str, Progress],
                routes: Mapping[str, VehicleRoute]) -> dict[str, VehicleRoute]:
        """The executor's routes: a step under way keeps its old record (deliveries), the next its dwell."""
        limits = {v: self.vehicles[v].task.limits for v in plan.plans}
        new = {r.vehicle: r for r in routes_from_plan(plan, self.network, limits, self.footprints)}
        out: dict[str, VehicleRoute] = {}
        for v, old in routes.items():
            r = new.get(v)
            if r is None:  # parked (its goals all reached): it stays where its route ended, not at its first start
                last = old.steps[-1].traversal if old.steps else None
                end, heading = (last.edge.target, last.end_heading) if last else (old.start, old.start_heading)
                out[v] = VehicleRoute(v, old.limits, old.footprint, end, heading, ())
                continue
            steps = list(r.steps)
            k = progress[v].k
            if v in heads:
                steps[0] = old.steps[k]
                if len(steps) > 1 and k + 1 < len(old.steps):
                    steps[1] = _with_dwell(steps[1], old.steps[k + 1].dwell_s)
            out[v] = VehicleRoute(v, old.limits, old.footprint, r.start, old.start_heading, tuple(steps))
        return out


def _with_dwell(step: RouteStep, dwell_s: float) -> RouteStep:
    return RouteStep(step.traversal, max(step.dwell_s, dwell_s), step.not_before_s, step.delivers,
                     step.drop_dwell_s, step.reached)
