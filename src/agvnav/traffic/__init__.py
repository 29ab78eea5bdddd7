"""Traffic control on the route network (issue 30): conflict zones, jobs, dispatch, planning, execution.

* :mod:`agvnav.traffic.zones`: which resources (nodes, edges) two vehicle models may not hold at once;
* :mod:`agvnav.traffic.jobs`, :mod:`agvnav.traffic.dispatch`: transport jobs and their assignment;
* :mod:`agvnav.traffic.plan`: prioritised planning with reservations over conflict resources (SIPP);
* :mod:`agvnav.traffic.stages`: planning in stages when vehicles' goals are one another's starts (lane swaps);
* :mod:`agvnav.traffic.adg`: the action dependency graph that executes the plans under delays;
* :mod:`agvnav.traffic.execute`: a kinematic-time executor of the plans (Monte Carlo, brute-force checks);
* :mod:`agvnav.traffic.replan`: replanning the steps not yet started when a vehicle is blocked long;
* :mod:`agvnav.traffic.hold`: the ADG kept on vehicles that drive themselves and report their progress (hold
  points of the closed-loop fleet, :mod:`agvnav.sim.traffic`);
* :mod:`agvnav.traffic.baseline`: an exclusive-resource allocator the way openTCS allocates;
* :mod:`agvnav.traffic.lif`: LIF 1.0 (VDMA Layout Interchange Format) import and export.
"""

from agvnav.traffic.zones import (
    DEFAULT_MARGIN_M,
    ConflictZones,
    Resource,
    conflict_zones,
    find_missed_conflicts,
    missed_conflicts,
    model_footprint,
)

__all__ = [
    "DEFAULT_MARGIN_M",
    "ConflictZones",
    "Resource",
    "conflict_zones",
    "find_missed_conflicts",
    "missed_conflicts",
    "model_footprint",
]
