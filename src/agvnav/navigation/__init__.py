"""What runs on a vehicle: the autopilots, the positioning guard, fine positioning.

Each module is one concept and reads only what a real vehicle has (the estimate, its
proprioceptive readings, its sensors' latest inputs), through the roles of :mod:`agvnav.roles`:

* :mod:`~agvnav.navigation.path`: :class:`PathAutopilot`, speed profile + path follower + the
  family's command conversion;
* :mod:`~agvnav.navigation.guard`: :class:`PositioningGuard` and :class:`EstimatorWatch`, slow
  down / stop / resume when positioning degrades;
* :mod:`~agvnav.navigation.mission`: the mission autopilot, one path autopilot per stint, station
  stops, the hold points of a fleet's traffic control (:class:`~agvnav.navigation.mission.HoldPoints`)
  and turns on the spot inside a leg (imported on its own: route planning pulls in networkx and scipy);
* :mod:`~agvnav.navigation.fine_positioning`: fine positioning at a station for a spot-turning vehicle;
* :mod:`~agvnav.navigation.reactive`: the reaction to obstacles and their avoidance;
* :mod:`~agvnav.navigation.hybrid`: the seed-004 hybrid automaton as an autopilot.

:mod:`agvnav.sim` wires them to simulated plants and sensors; this package never imports it.
"""

from agvnav.navigation.fine_positioning import fine_positioner, spot_turn_lever, twist_command
from agvnav.navigation.guard import (
    GUARD_LEVELS,
    GUARD_SIGNALS,
    EstimatorWatch,
    GuardLimits,
    PositioningGuard,
    SpeedWatch,
    demanded_level,
    lateral_sigma,
)
from agvnav.navigation.hybrid import HybridAutopilot
from agvnav.navigation.path import PathAutopilot
from agvnav.navigation.reactive import REACTIVE_SIGNALS, AvoidParams, ReactiveAutopilot, ReactiveInputs, ReactiveWatch

__all__ = [
    "GUARD_LEVELS",
    "GUARD_SIGNALS",
    "REACTIVE_SIGNALS",
    "AvoidParams",
    "EstimatorWatch",
    "GuardLimits",
    "HybridAutopilot",
    "PathAutopilot",
    "PositioningGuard",
    "ReactiveAutopilot",
    "ReactiveInputs",
    "ReactiveWatch",
    "SpeedWatch",
    "demanded_level",
    "fine_positioner",
    "lateral_sigma",
    "spot_turn_lever",
    "twist_command",
]
