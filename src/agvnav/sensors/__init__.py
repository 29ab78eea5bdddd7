"""Sensors: wheel/steering encoders, the rotating laser goniometer, ultrasonic rangers."""

from agvnav.sensors.encoders import SteeringEncoder, WheelEncoder  # noqa: E402  (issue 3)
from agvnav.sensors.goniometer import (  # noqa: E402  (laser goniometer, issue 4)
    Goniometer,
    Reflections,
    leading_edge_bearing,
    reflector_centre_bearing,
)
from agvnav.sensors.ultrasonic import (  # noqa: E402  (ultrasonic rangers, issue 6)
    ConeEcho,
    UltrasonicArray,
    UltrasonicReadings,
    UltrasonicSensor,
    check_wall_segments,
    cone_echo,
    seed_004_layout,
)
