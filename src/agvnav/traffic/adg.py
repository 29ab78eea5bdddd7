"""The action dependency graph (ADG) that executes a fleet plan under delays (Hönig et al. 2019).

Each vehicle's plan is a chain of events: step ``k`` starts (event ``2 k``, the vehicle enters its
edge) and arrives (event ``2 k + 1``); the events of one vehicle happen in order. For every two
*conflicting* occupations of different vehicles (:meth:`agvnav.traffic.plan.VehiclePlan.occupations`,
conflict from the zones) the plan fixes the order of passage: the one planned first, ``a``, before
the other, ``b``; at execution, ``b``'s vehicle may start the step that takes ``b`` only once ``a``'s
vehicle has passed the event that gives ``a`` up (a type-2 dependency). Only steps take resources:
a stop holds the node its step arrived at, and the step after it holds that node too.

Properties (tested in ``tests/traffic/test_adg.py``):

* **Acyclic.** A dependency goes from an event planned at ``t`` to one planned at ``t' >= t``;
  within a vehicle, a step's arrival is strictly after its start and a stop of positive length
  strictly before the next start, so a cycle would have to return to its own planned time after a
  strict increase. :meth:`Adg.is_acyclic` checks it (Kahn's algorithm).
* **Safe.** At execution two vehicles never hold conflicting resources at the same time, whatever
  the delays: the later occupation's step starts only after the earlier one is given up.
* **Deadlock-free.** An event whose dependencies are all done can happen; in an acyclic graph the
  earliest undone event in topological order has all its dependencies done, so some vehicle can
  always move on.

A dependency on event ``e`` of vehicle ``i`` implies every earlier event of ``i``: only the latest
per other vehicle is kept.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping
from dataclasses import dataclass, field

from agvnav.traffic.plan import NEVER, Conflicts, FleetPlan, Occupation, Resource

__all__ = ["Adg", "Dependency", "PlanConflictError", "build_adg"]


class PlanConflictError(ValueError):
    """Two vehicles' plans hold conflicting resources at overlapping times: the plan is invalid."""


@dataclass(frozen=True)
class Dependency:
    """Event ``event`` of ``vehicle`` waits for event ``after_event`` of ``after`` (resource ``resource``)."""

    vehicle: str
    event: int
    after: str
    after_event: int
    resource: Resource
    """what the waiting vehicle is about to take."""


@dataclass
class Adg:
    """The dependencies per vehicle and event, and the executed progress.

    ``done[v]``: how many of ``v``'s events have happened (event ``e`` is done when ``done[v] > e``).
    """

    n_events: dict[str, int]
    deps: dict[str, dict[int, list[Dependency]]]
    done: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for v in self.n_events:
            self.done.setdefault(v, 0)

    def blockers(self, vehicle: str, event: int) -> list[Dependency]:
        """The dependencies of ``vehicle``'s ``event`` not yet met."""
        return [d for d in self.deps.get(vehicle, {}).get(event, ()) if self.done[d.after] <= d.after_event]

    def ready(self, vehicle: str, event: int) -> bool:
        """True when ``vehicle``'s own earlier events are done and every dependency of ``event`` is met."""
        return self.done[vehicle] == event and not self.blockers(vehicle, event)

    def mark(self, vehicle: str, event: int) -> None:
        """Record that ``vehicle``'s ``event`` happened (ValueError when out of order or not ready)."""
        if self.done[vehicle] != event:
            raise ValueError(f"vehicle {vehicle!r}: event {event} out of order (next is {self.done[vehicle]})")
        if event % 2 == 0 and self.blockers(vehicle, event):
            raise ValueError(f"vehicle {vehicle!r}: event {event} started before its dependencies")
        self.done[vehicle] = event + 1

    def edges(self) -> list[tuple[tuple[str, int], tuple[str, int]]]:
        """Every edge of the graph: the type-1 chain of each vehicle and the type-2 dependencies."""
        out = [((v, e), (v, e + 1)) for v, n in self.n_events.items() for e in range(n - 1)]
        for v, by_event in self.deps.items():
            for e, lst in by_event.items():
                out += [((d.after, d.after_event), (v, e)) for d in lst]
        return out

    def is_acyclic(self) -> bool:
        """Kahn's algorithm over :meth:`edges`."""
        nodes = [(v, e) for v, n in self.n_events.items() for e in range(n)]
        indeg = dict.fromkeys(nodes, 0)
        succ: dict[tuple[str, int], list[tuple[str, int]]] = defaultdict(list)
        for a, b in self.edges():
            succ[a].append(b)
            indeg[b] += 1
        stack = [n for n, d in indeg.items() if d == 0]
        seen = 0
        while stack:
            n = stack.pop()
            seen += 1
            for m in succ[n]:
                indeg[m] -= 1
                if indeg[m] == 0:
                    stack.append(m)
        return seen == len(nodes)

    @property
    def n_dependencies(self) -> int:
        """Number of type-2 dependencies kept."""
        return sum(len(lst) for by in self.deps.values() for lst in by.values())


def build_adg(plan: FleetPlan, zones: Conflicts) -> Adg:
    """The ADG of a valid fleet plan (module doc); :class:`PlanConflictError` for an invalid one."""
    occs = [o for p in plan.plans.values() for o in p.occupations()]
    by_res: dict[tuple[str, Resource], list[Occupation]] = defaultdict(list)
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
                raise PlanConflictError(
                    f"vehicles {oa.vehicle!r} and {ob.vehicle!r} plan conflicting {oa.resource} and {ob.resource} at "
                    f"overlapping times [{oa.t0:.2f}, {oa.t1:.2f}] and [{ob.t0:.2f}, {ob.t1:.2f}] s")
            _depend(best, first, later)
    deps: dict[str, dict[int, list[Dependency]]] = defaultdict(lambda: defaultdict(list))
    for d in best.values():
        deps[d.vehicle][d.event].append(d)
    n_events = {v: 2 * len(p.steps) for v, p in plan.plans.items()}
    return Adg(n_events, {v: dict(by) for v, by in deps.items()})


def _depend(best: dict[tuple[str, int, str], Dependency], first: Occupation, later: Occupation) -> None:
    """``later``'s taking waits for ``first``'s giving up; only step starts take resources (module doc)."""
    if later.acquire < 0 or later.acquire % 2 == 1:
        return
    if first.release >= NEVER:
        raise PlanConflictError(f"vehicle {later.vehicle!r} plans {later.resource} after {first.vehicle!r} parks "
                                f"holding {first.resource}")
    key = (later.vehicle, later.acquire, first.vehicle)
    old = best.get(key)
    if old is None or old.after_event < first.release:
        best[key] = Dependency(later.vehicle, later.acquire, first.vehicle, first.release, later.resource)


def waits_for(adg: Adg, waiting: Mapping[str, int]) -> dict[str, set[str]]:
    """The wait-for graph: vehicle -> the vehicles whose events it waits for (``waiting``: vehicle -> event)."""
    return {v: {d.after for d in adg.blockers(v, e)} for v, e in waiting.items()}
