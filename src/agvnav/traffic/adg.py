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

import numpy as np
from numpy.typing import NDArray

from agvnav.traffic._adg_fast import visit_pairs
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
        """Kahn's algorithm over :meth:`edges` (events numbered in one integer range, the chains implicit)."""
        base: dict[str, int] = {}
        total = 0
        for v, n in self.n_events.items():
            base[v] = total
            total += n
        last = [False] * total
        for v, n in self.n_events.items():
            if n:
                last[base[v] + n - 1] = True
        indeg = [0 if i == 0 or last[i - 1] else 1 for i in range(total)]  # the chain edge into each event
        succ: list[list[int]] = [[] for _ in range(total)]
        for v, by_event in self.deps.items():
            for e, lst in by_event.items():
                for d in lst:
                    succ[base[d.after] + d.after_event].append(base[v] + e)
                    indeg[base[v] + e] += 1
        stack = [i for i in range(total) if indeg[i] == 0]
        seen = 0
        while stack:
            i = stack.pop()
            seen += 1
            nxt = succ[i] if last[i] else [*succ[i], i + 1]
            for m in nxt:
                indeg[m] -= 1
                if indeg[m] == 0:
                    stack.append(m)
        return seen == total

    @property
    def n_dependencies(self) -> int:
        """Number of type-2 dependencies kept."""
        return sum(len(lst) for by in self.deps.values() for lst in by.values())


def build_adg(plan: FleetPlan, zones: Conflicts) -> Adg:
    """The ADG of a valid fleet plan (module doc); :class:`PlanConflictError` for an invalid one.

    Every pair of conflicting occupations of two vehicles is visited (each twice, in the order of the
    plans' occupations, :func:`agvnav.traffic._adg_fast.visit_pairs`): the order of passage, the plan's
    validity and the latest dependency per vehicle pair and event.
    """
    occs = [o for p in plan.plans.values() for o in p.occupations()]
    indptr, members, key_of = _conflict_lists(occs, zones)
    veh_id = {v: i for i, v in enumerate(plan.plans)}
    n_veh = max(len(veh_id), 1)
    n_ev = [2 * len(p.steps) for p in plan.plans.values()]
    slot_base = np.concatenate([[0], np.cumsum(n_ev)[:-1]]).astype(np.int64) if n_ev else np.zeros(1, np.int64)
    n_slots = max(int(sum(n_ev)), 1) * n_veh
    best_rel, best_later, best_first = (np.zeros(n_slots, dtype=np.int64) for _ in range(3))
    order = np.full(n_slots, -1, dtype=np.int64)
    bad = np.zeros(3, dtype=np.int64)
    visit_pairs(indptr, members, key_of, np.array([veh_id[o.vehicle] for o in occs], dtype=np.int64),
                np.array([o.t0 for o in occs], dtype=np.float64), np.array([o.t1 for o in occs], dtype=np.float64),
                np.array([o.acquire for o in occs], dtype=np.int64), np.array([o.release for o in occs],
                                                                             dtype=np.int64),
                slot_base, n_veh, NEVER, best_rel, best_later, best_first, order, bad)
    if bad[0]:
        _refuse(occs, int(bad[1]), int(bad[2]), int(bad[1]), int(bad[2]), bool(bad[0] == 1))
    filled = np.flatnonzero(order >= 0)
    filled = filled[np.argsort(order[filled], kind="stable")]
    deps: dict[str, dict[int, list[Dependency]]] = defaultdict(lambda: defaultdict(list))
    for lo_i, fo_i in zip(best_later[filled].tolist(), best_first[filled].tolist(), strict=True):
        lo, fo = occs[lo_i], occs[fo_i]
        deps[lo.vehicle][lo.acquire].append(Dependency(lo.vehicle, lo.acquire, fo.vehicle, fo.release, lo.resource))
    n_events = {v: 2 * len(p.steps) for v, p in plan.plans.items()}
    return Adg(n_events, {v: dict(by) for v, by in deps.items()})


def _conflict_lists(occs: list[Occupation], zones: Conflicts
                    ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Per key (a model and a resource), the occupations (in order) whose resource conflicts with it: CSR
    ``indptr``, ``members``; and each occupation's own key (-1: none conflicts with it)."""
    models = sorted({o.model for o in occs})
    keys: dict[tuple[str, Resource], int] = {}
    reach: dict[tuple[str, Resource], NDArray[np.int64]] = {}
    rows: list[NDArray[np.int64]] = []
    for o in occs:
        got = reach.get((o.model, o.resource))
        if got is None:
            ids = [keys.setdefault((mb, r), len(keys))
                   for mb in models for r in zones.conflicts(o.model, o.resource, mb)]
            got = reach[(o.model, o.resource)] = np.array(ids, dtype=np.int64)
        rows.append(got)
    lengths = np.array([len(x) for x in rows], dtype=np.int64)
    occ = np.repeat(np.arange(len(occs), dtype=np.int64), lengths)
    key = np.concatenate(rows) if rows else np.zeros(0, dtype=np.int64)
    by_key = np.argsort(key, kind="stable")  # grouped by key, each group in the occupations' order
    members = occ[by_key]
    indptr = np.zeros(len(keys) + 1, dtype=np.int64)
    np.cumsum(np.bincount(key, minlength=len(keys)), out=indptr[1:])
    key_of = np.array([keys.get((o.model, o.resource), -1) for o in occs], dtype=np.int64)
    return indptr, members, key_of


def _refuse(occs: list[Occupation], a: int, b: int, first: int, later: int, overlap: bool) -> None:
    """Raise the :class:`PlanConflictError` of the first invalid pair met."""
    oa, ob, fo, lo = occs[a], occs[b], occs[first], occs[later]
    if overlap:
        raise PlanConflictError(
            f"vehicles {oa.vehicle!r} and {ob.vehicle!r} plan conflicting {oa.resource} and {ob.resource} at "
            f"overlapping times [{oa.t0:.2f}, {oa.t1:.2f}] and [{ob.t0:.2f}, {ob.t1:.2f}] s")
    raise PlanConflictError(f"vehicle {lo.vehicle!r} plans {lo.resource} after {fo.vehicle!r} parks "
                            f"holding {fo.resource}")


def waits_for(adg: Adg, waiting: Mapping[str, int]) -> dict[str, set[str]]:
    """The wait-for graph: vehicle -> the vehicles whose events it waits for (``waiting``: vehicle -> event)."""
    return {v: {d.after for d in adg.blockers(v, e)} for v, e in waiting.items()}
