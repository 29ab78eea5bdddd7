"""Odometry (seed 002 §3): increments, pose integration rules, the noise model (its variance kernel in
:mod:`agvnav.odometry.noise_kernels`, its covariance in :mod:`agvnav.odometry.covariance`), error models, UMBmark."""

from agvnav.odometry.covariance import (
    STEERED_MODELS,
    TRUTH_MODELS,
    WHEEL_ODOMETRY_KEYS,
    OdometryNoise,
    SteeredOdometryNoise,
    WheelPairOdometryNoise,
    calibration_jacobian,
    motion_covariance,
    noise_from_truth,
    propagate,
    steered_noise,
    wheel_pair_noise,
)
from agvnav.odometry.errors import (
    DifferentialGeometry,
    NonSystematicErrors,
    SystematicErrors,
    TricycleErrors,
    TrueDifferentialVehicle,
    TrueTricycleVehicle,
)
from agvnav.odometry.increments import differential_increments, differential_wheel_distances, tricycle_increments
from agvnav.odometry.integrate import RULES, increment_jacobian, integrate_pose, pose_jacobian
from agvnav.odometry.noise_kernels import increment_variances, increment_variances_array
from agvnav.odometry.odometer import DifferentialOdometer, TricycleOdometer
from agvnav.odometry.umbmark import UMBmarkResult, estimate_errors, square_run, umbmark

__all__ = [
    "RULES",
    "STEERED_MODELS",
    "TRUTH_MODELS",
    "WHEEL_ODOMETRY_KEYS",
    "DifferentialGeometry",
    "DifferentialOdometer",
    "NonSystematicErrors",
    "OdometryNoise",
    "SteeredOdometryNoise",
    "SystematicErrors",
    "TricycleErrors",
    "TricycleOdometer",
    "TrueDifferentialVehicle",
    "TrueTricycleVehicle",
    "UMBmarkResult",
    "WheelPairOdometryNoise",
    "calibration_jacobian",
    "differential_increments",
    "differential_wheel_distances",
    "estimate_errors",
    "increment_jacobian",
    "increment_variances",
    "increment_variances_array",
    "integrate_pose",
    "motion_covariance",
    "noise_from_truth",
    "pose_jacobian",
    "propagate",
    "square_run",
    "steered_noise",
    "tricycle_increments",
    "umbmark",
    "wheel_pair_noise",
]
