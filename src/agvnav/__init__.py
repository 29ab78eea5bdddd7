"""agvnav: positioning and guidance of automated guided vehicles.

Packages, in the direction data flows:
world and vehicle (``world``, ``kinematics``) -> ``sensors`` -> ``positioning``
(with ``odometry``) -> ``guidance`` -> actuators -> vehicle; ``sim`` only wires
them together, ``report`` plots, ``cli`` parses arguments.

Conventions: SI units and radians everywhere; REP-103 frames (x forward,
y left, counter-clockwise positive); REP-105 frame names (map, odom,
base_link). A pose is an array ``(..., 3)`` of ``[x, y, heading]``.
"""

__version__ = "0.1.0"
