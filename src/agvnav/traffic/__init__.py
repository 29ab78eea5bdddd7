"""Traffic control on the route network (issue 30): conflict zones, LIF exchange.

* :mod:`agvnav.traffic.zones`: which edges and nodes may not be occupied at the same time by
  two vehicles, computed from each model's footprint swept along the exact edge geometry and
  turned at the nodes, with the brute-force check that nothing was missed.
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
