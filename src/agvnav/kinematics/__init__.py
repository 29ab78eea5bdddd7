"""Vehicle kinematics of every seed configuration (seed 000 §3.1, 002 §2, 003 §3.2, 004 §II.A).

Every model implements ``KinematicModel``: ``derivative``, ``jacobian_state``,
``jacobian_input``, ``step`` and the checks, vectorised over leading batch
dimensions.

Validated path and kernels
--------------------------
The public methods are the validated path, the default for users: ``step``
checks the shapes, that state and input are finite and within the model's
limits, that ``dt`` is a positive finite number, and that the *resulting* state
is still within its limits (e.g. γ pushed past ``max_steer`` raises a ValueError;
no silent clamping). ``derivative`` and the Jacobians check shapes and
finiteness. Every bad case is a ValueError naming ``state``/``u``/``dt`` or the
variable, never an IndexError or a silent NaN. ``checked_step`` is an alias of
``step``.

Hot loops (benchmarks, simulators stepping thousands of vehicles) call the
unchecked kernels ``step_unchecked``, ``derivative_unchecked``,
``jacobian_state_unchecked`` and ``jacobian_input_unchecked``, which do no
checking; pair them with the batch flags ``input_valid``/``state_valid``.

The free functions (``wheel_speeds``, ``body_speeds``, ``ackermann_wheel_angles``,
``odometry.tricycle_increments``/``differential_increments``) require positive
geometry (ValueError); on scalar inputs a NaN/inf (or a steering angle at/beyond
±90°) raises a ValueError naming it, on batch inputs those elements come out NaN
(the flag) and never touch their neighbours.
"""

from agvnav.kinematics.ackermann import Ackermann, AckermannSimple, ackermann_wheel_angles
from agvnav.kinematics.base import KinematicModel, numerical_jacobian, rk4_step, twist_step
from agvnav.kinematics.differential import (
    DifferentialDrive,
    body_speeds,
    body_speeds_unchecked,
    body_twist_matrix,
    instantaneous_centre,
    turning_radius,
    unicycle_derivative,
    wheel_speeds,
    wheel_speeds_unchecked,
)
from agvnav.kinematics.omnidirectional import MecanumBase
from agvnav.kinematics.tracked import (
    TERRAIN_PRESETS,
    TrackedVehicle,
    TrackSlipNoise,
    TrackTerrain,
    terrain_preset,
)
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
    "TERRAIN_PRESETS",
    "Ackermann",
    "AckermannSimple",
    "DifferentialDrive",
    "KinematicModel",
    "MecanumBase",
    "TrackSlipNoise",
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
    "body_speeds_unchecked",
    "body_twist_matrix",
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
    "wheel_speeds_unchecked",
]
