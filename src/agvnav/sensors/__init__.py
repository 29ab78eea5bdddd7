"""Sensors: wheel/steering encoders, the rotating laser goniometer, ultrasonic rangers."""

from agvnav.sensors.encoders import SteeringEncoder, WheelEncoder
from agvnav.sensors.goniometer import (
    Goniometer,
    Reflections,
    leading_edge_bearing,
    reflector_centre_bearing,
)
from agvnav.sensors.ultrasonic import (
    ConeEcho,
    UltrasonicArray,
    UltrasonicReadings,
    UltrasonicSensor,
    check_wall_segments,
    cone_echo,
    seed_004_layout,
)

__all__ = [
    "ConeEcho",
    "Goniometer",
    "Reflections",
    "SteeringEncoder",
    "UltrasonicArray",
    "UltrasonicReadings",
    "UltrasonicSensor",
    "WheelEncoder",
    "check_wall_segments",
    "cone_echo",
    "leading_edge_bearing",
    "reflector_centre_bearing",
    "seed_004_layout",
]
