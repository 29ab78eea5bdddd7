"""Dispatch: transport jobs assigned to vehicles, nearest idle vehicle first (issue 30).

Jobs are taken in order of release time, then priority (higher first), then id. Each vehicle is
known by where it will be and when it will be free once its jobs so far are done (the static
fastest times of :class:`agvnav.routes.planning.Planner`, ignoring traffic). A job goes to the
vehicle that is idle at its release and nearest in drive time to its pick station; when none is
idle, to the one that can be at the pick station first. Vehicles that cannot reach the pick or the
drop station (their model is not allowed there, no route) are never chosen; a job no vehicle can
serve is reported unserved with the reason, never left waiting.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from agvnav.routes.network import RouteNetwork
from agvnav.routes.planning import NoRouteError, Planner, VehicleLimits
from agvnav.traffic.jobs import TransportJob
from agvnav.traffic.plan import Goal, VehicleTask

__all__ = ["Assignment", "DriveTimes", "FleetVehicle", "dispatch", "tasks_of"]


@dataclass(frozen=True)
class FleetVehicle:
    """A vehicle to dispatch: id, model limits, start node (its home, where it parks at the end)."""

    id: str
    limits: VehicleLimits
    start: str
    own: tuple[Goal, ...] = ()
    """goals of its own mission, done before any dispatched job."""


class DriveTimes:
    """Static fastest drive times (s) between nodes, per vehicle model (cached; inf: no route)."""

    def __init__(self, network: RouteNetwork) -> None:
        self.network = network
        self._planners: dict[VehicleLimits, Planner] = {}
        self._memo: dict[tuple[VehicleLimits, str, str], float] = {}

    def __call__(self, limits: VehicleLimits, a: str, b: str) -> float:
        """Drive time (s) from node ``a`` to node ``b``."""
        key = (limits, a, b)
        if key not in self._memo:
            p = self._planners.get(limits)
            if p is None:
                p = self._planners[limits] = Planner(self.network, limits)
            try:
                self._memo[key] = p.plan(a, b).time_s
            except NoRouteError:
                self._memo[key] = math.inf
        return self._memo[key]


@dataclass
class Assignment:
    """Jobs per vehicle (in order) and the unserved jobs with why."""

    jobs: dict[str, list[TransportJob]]
    unserved: list[tuple[TransportJob, str]] = field(default_factory=list)


def dispatch(jobs: Sequence[TransportJob], vehicles: Sequence[FleetVehicle], times: DriveTimes) -> Assignment:
    """Assign every job (module doc)."""
    out = Assignment({v.id: [] for v in vehicles})
    where = {v.id: v.start for v in vehicles}
    free = dict.fromkeys(where, 0.0)
    for v in vehicles:
        for g in v.own:
            free[v.id] += times(v.limits, where[v.id], g.station) + g.dwell_s
            where[v.id] = g.station
    for job in sorted(jobs, key=lambda j: (j.release_s, -j.priority, j.id)):
        able = [v for v in vehicles if math.isfinite(times(v.limits, job.pick, job.drop))
                and math.isfinite(times(v.limits, where[v.id], job.pick))]
        if not able:
            out.unserved.append((job, f"no vehicle can drive from station {job.pick!r} to {job.drop!r}"))
            continue
        idle = [v for v in able if free[v.id] <= job.release_s]
        if idle:
            best = min(idle, key=lambda v: (times(v.limits, where[v.id], job.pick), v.id))
        else:
            best = min(able, key=lambda v: (free[v.id] + times(v.limits, where[v.id], job.pick), v.id))
        at_pick = max(free[best.id] + times(best.limits, where[best.id], job.pick), job.release_s)
        free[best.id] = at_pick + job.pick_s + times(best.limits, job.pick, job.drop) + job.drop_s
        where[best.id] = job.drop
        out.jobs[best.id].append(job)
    return out


def tasks_of(assignment: Assignment, vehicles: Sequence[FleetVehicle], home: bool = True) -> list[VehicleTask]:
    """Each vehicle's planning task: its own goals, then pick and drop of each job, then home (its start)."""
    out = []
    for v in vehicles:
        goals = list(v.own)
        for j in assignment.jobs[v.id]:
            goals += [Goal(j.pick, j.pick_s, j.release_s, job=j.id, action="pick"),
                      Goal(j.drop, j.drop_s, 0.0, job=j.id, action="drop")]
        if home and goals and goals[-1].station != v.start:
            goals.append(Goal(v.start, 0.0, 0.0, action="goto"))
        out.append(VehicleTask(v.id, v.limits, v.start, tuple(goals)))
    return out
