"""Actuators: steering servo, traction speed profile, motors with PID speed loops."""

from agvnav.actuators.differential import DriveGeometry, WheelSpeedLoop, unicycle_to_wheels, wheels_to_unicycle
from agvnav.actuators.motor import MotorPair, motor_step
from agvnav.actuators.pid import PID, SEED_004_GAINS
from agvnav.actuators.speed_profile import SpeedProfile, profile_speed
from agvnav.actuators.steering import SteeringActuator, steering_step

__all__ = [
    "PID",
    "SEED_004_GAINS",
    "DriveGeometry",
    "MotorPair",
    "SpeedProfile",
    "SteeringActuator",
    "WheelSpeedLoop",
    "motor_step",
    "profile_speed",
    "steering_step",
    "unicycle_to_wheels",
    "wheels_to_unicycle",
]
