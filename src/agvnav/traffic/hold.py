"""Traffic control of vehicles that drive themselves: hold points from the ADG, progress from the vehicles.

The kinematic executor (:mod:`agvnav.traffic.execute`) moves its vehicles itself. A fleet of closed
loops (:mod:`agvnav.sim.fleet`), or of real vehicles, drives on its own: each vehicle follows its
route with its own positioning and guidance and only *reports* how far along it is. This module keeps
a fleet plan's order of passage through the conflict zones (the ADG, :mod:`agvnav.traffic.adg`) on
such vehicles (issue 30):

* **missions**: each vehicle's plan becomes a mission (:func:`mission_legs`: one leg per goal, the
  planned steps leading to it as its route, the goal's dwell as the stop), which the vehicle chains
  into the one path it follows; step ``k`` spans ``[s_k0, s_k1]`` (m) along that path
  (:func:`step_bounds`: the arclengths of the step's source and target nodes).
* **progress** (:meth:`HoldControl.report`): the vehicle reports its progress ``s`` along its path,
  its *estimate* (what a real vehicle reports, as VDA 5050's ``lastNodeId`` does; never the truth).
  Step ``k`` has arrived (ADG event ``2 k + 1``, which gives up its edge and source node) once
  ``s >= s_k1 - NODE_REACHED_M``; it has started (event ``2 k``) once the step before it has arrived,
  the ADG allows it and its release time (a job's, :attr:`agvnav.traffic.plan.Step.not_before_s`) is
  past.
* **hold points** (:meth:`HoldControl.hold_point`): the vehicle must stand at the source node
  ``s_k0`` of its next step whose start is not allowed yet; it brakes to stop there
  (:class:`agvnav.navigation.mission.HoldPoints`, smoothly: its own speed profile) and drives on once
  the vehicles it waits for have reported passing the events it depends on. A step allowed in time is
  driven through without stopping.

Safety is the ADG's (a step's resources are taken only after every conflicting occupation planned
before it has been given up) provided each vehicle stays within the resources it holds: it never passes
the hold point ``s_k0`` of a step not yet allowed, and the zones' margin covers the distance between
its estimate and its true pose and its tracking error (:func:`agvnav.sim.traffic` widens the margin by
the guided point's offset; the simulator checks the true footprints every step). Deadlock freedom is
the ADG's: its graph is acyclic, so some vehicle can always pass its next event.

Waiting for traffic (:attr:`HoldControl.waits`): a vehicle waits while it stands at the source of a
step it has reached (the step before it has arrived) whose start the ADG does not allow yet, outside a
station's dwell; the time is counted per vehicle, per zone (the first resource it waits for,
``edge:ID`` or ``node:ID``) and per node (where it stands).

Independent check (:meth:`HoldControl.conflicting`): the resources each vehicle holds by its reported
progress (on step ``k``: its source, edge and target; at a node: the node), compared pairwise with the
zones' relation, whether or not the ADG is followed (``follow_adg=False`` drives the plans without hold
points, for comparison: what the traffic control prevents).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from agvnav.routes.mission import Leg
from agvnav.routes.planning import Route
from agvnav.traffic.adg import Adg
from agvnav.traffic.plan import Conflicts, Resource, VehiclePlan

__all__ = [
    "AT_NODE_M",
    "NODE_REACHED_M",
    "HoldControl",
    "VehicleHolds",
    "Waits",
    "mission_legs",
    "step_bounds",
    "zone_name",
]

#: A node counts as reached once the reported progress is within this distance (m) of it
#: (as :data:`agvnav.navigation.mission.NODE_REACHED_M`).
NODE_REACHED_M = 0.05

#: The independent check counts a vehicle as standing at a node within this distance (m) of it: a vehicle stopped
#: at a hold point stands a few centimetres off it (braking on a progress one step old, the estimate's noise),
#: which the zones' margin covers.
AT_NODE_M = 0.1


def mission_legs(plan: VehiclePlan) -> list[Leg]:
    """The mission of a vehicle's plan: one leg per goal (its planned steps as the route; None when the goal is
    reached where the previous one was), the goal's action and dwell (s)."""
    legs = []
    for g, goal in enumerate(plan.goals):
        steps = [st for st in plan.steps if st.goal == g]
        route = None
        if steps:
            nodes = (steps[0].source, *(st.target for st in steps))
            route = Route(tuple(st.traversal for st in steps), nodes, steps[-1].t_end - steps[0].t_start)
        legs.append(Leg(g, goal.action, goal.station, route, goal.dwell_s))
    return legs


def step_bounds(node_s: Sequence[tuple[float, str]], plan: VehiclePlan) -> list[tuple[float, float]]:
    """``[(s_k0, s_k1)]`` (m): where each step of ``plan`` starts and ends along the chained mission path whose
    passed nodes are ``node_s`` (:attr:`agvnav.routes.mission.MissionPlan.node_s`, one per step)."""
    if len(node_s) != len(plan.steps):
        raise ValueError(f"vehicle {plan.vehicle!r}: {len(node_s)} nodes passed for {len(plan.steps)} steps")
    out = []
    s0 = 0.0
    for (s1, node), st in zip(node_s, plan.steps, strict=True):
        if node != st.target:
            raise ValueError(f"vehicle {plan.vehicle!r}: the mission passes {node!r} where the plan reaches "
                             f"{st.target!r}")
        out.append((s0, float(s1)))
        s0 = float(s1)
    return out


def zone_name(res: Resource) -> str:
    """A resource as shown in the figures: ``edge:ID`` or ``node:ID``."""
    return f"{res[0]}:{res[1]}"


@dataclass
class Waits:
    """Time (s) a vehicle waited for traffic: in all, per zone waited for, per node stood at."""

    total_s: float = 0.0
    by_zone: dict[str, float] = field(default_factory=dict)
    by_node: dict[str, float] = field(default_factory=dict)

    def add(self, dt: float, zone: str, node: str) -> None:
        """Count ``dt`` s waiting at ``node`` for ``zone``."""
        self.total_s += dt
        self.by_zone[zone] = self.by_zone.get(zone, 0.0) + dt
        self.by_node[node] = self.by_node.get(node, 0.0) + dt


class VehicleHolds:
    """One vehicle's view of the controller (:class:`agvnav.navigation.mission.HoldPoints`)."""

    def __init__(self, control: HoldControl, vehicle: str) -> None:
        self.control = control
        self.vehicle = vehicle

    def hold_point(self, s: float) -> float:
        """Arclength (m) where the vehicle must stand next (inf: none)."""
        return self.control.hold_point(self.vehicle)


class HoldControl:
    """The ADG of a fleet plan kept on vehicles that report their progress (module doc).

    ``plans``: each vehicle's plan (a vehicle without steps stands at its start: in the check, not in the ADG);
    ``bounds``: each vehicle's :func:`step_bounds`; ``follow_adg``: False drives the plans without hold points
    (nothing is marked, nobody waits; the comparison case).
    """

    def __init__(self, adg: Adg, plans: dict[str, VehiclePlan], bounds: dict[str, list[tuple[float, float]]],
                 zones: Conflicts, follow_adg: bool = True) -> None:
        self.adg = adg
        self.plans = plans
        self.bounds = bounds
        self.zones = zones
        self.follow_adg = follow_adg
        self.s = dict.fromkeys(plans, 0.0)
        self.t = 0.0
        self.waits = {v: Waits() for v in plans}
        self._ends = {v: [b[1] for b in bounds[v]] for v in plans}

    def agent(self, vehicle: str) -> VehicleHolds:
        """What vehicle ``vehicle`` asks for its hold points."""
        if vehicle not in self.plans:
            raise ValueError(f"no plan for vehicle {vehicle!r}")
        return VehicleHolds(self, vehicle)

    def _next_step(self, vehicle: str) -> int:
        """The step whose start is the vehicle's next start event (len(steps) when all have started)."""
        done = self.adg.done.get(vehicle, 0)  # a vehicle without steps is not in the ADG
        return (done + 1) // 2

    def _allowed(self, vehicle: str, k: int) -> bool:
        """True when step ``k`` may start: the ADG's dependencies met and its release time past."""
        st = self.plans[vehicle].steps[k]
        return self.t >= st.not_before_s and not self.adg.blockers(vehicle, 2 * k)

    def hold_point(self, vehicle: str) -> float:
        """Arclength (m) of the source of the vehicle's next step not allowed yet (inf: none, or not following
        the ADG)."""
        if not self.follow_adg:
            return math.inf
        steps = self.plans[vehicle].steps
        for k in range(self._next_step(vehicle), len(steps)):
            if not self._allowed(vehicle, k):
                return self.bounds[vehicle][k][0]
        return math.inf

    def report(self, vehicle: str, s: float, t: float, dt: float, dwelling: bool = False) -> None:
        """Vehicle ``vehicle`` is at ``s`` (m, its estimate) at ``t`` (s): mark the events passed, count a wait
        of ``dt`` (s) when it stands at a step not allowed outside a station's dwell."""
        self.s[vehicle] = float(s)
        self.t = max(self.t, float(t))
        adg, b = self.adg, self.bounds[vehicle]
        if not self.follow_adg or not b:
            return
        n = len(b)
        while adg.done[vehicle] < 2 * n:
            e = adg.done[vehicle]
            k = e // 2
            if e % 2 == 1:  # under way on step k: arrived?
                if s < b[k][1] - NODE_REACHED_M:
                    break
                adg.mark(vehicle, e)
            else:
                if not self._allowed(vehicle, k):
                    if not dwelling and s >= b[k][0] - NODE_REACHED_M and adg.blockers(vehicle, e):
                        res = adg.blockers(vehicle, e)[0].resource
                        self.waits[vehicle].add(dt, zone_name(res), self.plans[vehicle].steps[k].source)
                    break
                adg.mark(vehicle, e)

    def waiting_on(self, vehicle: str) -> set[str]:
        """The vehicles whose events the vehicle's next step waits for, once it has reached that step's source
        (empty while it drives, or when only a release time holds it)."""
        e = self.adg.done.get(vehicle)
        if not self.follow_adg or e is None:
            return set()
        if e % 2 or e // 2 >= len(self.plans[vehicle].steps):
            return set()
        return {d.after for d in self.adg.blockers(vehicle, e)}

    def held(self, vehicle: str) -> tuple[Resource, ...]:
        """The resources the vehicle holds by its reported progress: step ``k``'s source, edge and target on it, the
        node when at one (within :data:`AT_NODE_M`)."""
        plan = self.plans[vehicle]
        if not plan.steps:
            return (("node", plan.start),)
        s = self.s[vehicle]
        ends = self._ends[vehicle]
        k = bisect.bisect_left(ends, s - AT_NODE_M)
        if k >= len(ends):
            return (("node", plan.steps[-1].target),)
        st = plan.steps[k]
        s0, s1 = self.bounds[vehicle][k]
        if s <= s0 + AT_NODE_M:
            return (("node", st.source),)
        if s >= s1 - AT_NODE_M:
            return (("node", st.target),)
        return st.resources()

    def conflicting(self) -> list[tuple[str, str]]:
        """The pairs of vehicles holding conflicting resources now (by their reported progress)."""
        ids = list(self.plans)
        held = {v: self.held(v) for v in ids}
        out = []
        for i, a in enumerate(ids):
            ma = self.plans[a].model
            for bv in ids[i + 1:]:
                mb = self.plans[bv].model
                hb = set(held[bv])
                if any(hb & self.zones.conflicts(ma, r, mb) for r in held[a]):
                    out.append((a, bv))
        return out
