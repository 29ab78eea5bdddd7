"""Vehicle kinematics of every seed configuration (seed 000 §3.1, 002 §2, 003 §3.2, 004 §II.A).

Every model implements ``KinematicModel``: ``derivative``, ``jacobian_state``,
``jacobian_input``, ``step`` and the checks, vectorised over leading batch
dimensions.
"""

from agvnav.kinematics.ackermann import Ackermann, AckermannSimple, ackermann_wheel_angles
from agvnav.kinematics.base import KinematicModel, numerical_jacobian, rk4_step, twist_step
from agvnav.kinematics.differential import (
    DifferentialDrive,
    body_speeds,
    instantaneous_centre,
    turning_radius,
    unicycle_derivative,
    wheel_speeds,
)
from agvnav.kinematics.omnidirectional import MecanumBase
from agvnav.kinematics.tracked import TERRAIN_PRESETS, TrackedVehicle, TrackTerrain, terrain_preset
from agvnav.kinematics.tractor_trailer import TractorTrailer
from agvnav.kinematics.tricycle import (
    TricycleModelA,
    TricycleModelB,
    TricycleRearDrive,
    TricycleRearDriveSimple,
    TricycleStacker,
    TricycleStackerSimple,
    front_drive_twist,
    rear_drive_twist,
)
from agvnav.kinematics.wheels import (
    castor_heading_rate,
    castor_wheel_residual,
    fixed_wheel_residual,
    lateral_residual,
    point_velocity,
    rolling_residual,
    steered_wheel_residual,
    swedish_wheel_residual,
)

__all__ = [
    "Ackermann",
    "AckermannSimple",
    "DifferentialDrive",
    "KinematicModel",
    "MecanumBase",
    "TERRAIN_PRESETS",
    "TrackTerrain",
    "TrackedVehicle",
    "TractorTrailer",
    "TricycleModelA",
    "TricycleModelB",
    "TricycleRearDrive",
    "TricycleRearDriveSimple",
    "TricycleStacker",
    "TricycleStackerSimple",
    "ackermann_wheel_angles",
    "body_speeds",
    "castor_heading_rate",
    "castor_wheel_residual",
    "fixed_wheel_residual",
    "front_drive_twist",
    "instantaneous_centre",
    "lateral_residual",
    "numerical_jacobian",
    "point_velocity",
    "rear_drive_twist",
    "rk4_step",
    "rolling_residual",
    "steered_wheel_residual",
    "swedish_wheel_residual",
    "terrain_preset",
    "turning_radius",
    "twist_step",
    "unicycle_derivative",
    "wheel_speeds",
]
