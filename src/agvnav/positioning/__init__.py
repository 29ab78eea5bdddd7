"""positioning: absolute fixes from reflector bearings (and, later, dynamic estimators)."""

from agvnav.positioning.bounds import bearing_jacobian, crlb, encoder_bearing_std, fisher_information, pdop
from agvnav.positioning.triangulation import METHODS, TriangulationResult, triangulate

__all__ = [
    "METHODS",
    "TriangulationResult",
    "bearing_jacobian",
    "crlb",
    "encoder_bearing_std",
    "fisher_information",
    "pdop",
    "triangulate",
]

# Dynamic positioning (issue 4): identification, streaming estimators, factory by name.
from agvnav.positioning.bearing_gate import associate_sweep, gate_reflection
from agvnav.positioning.bearing_propagation import batch_ml_fix, propagate_bearings
from agvnav.positioning.deviation import (
    DeviationWatch,
    Evidence,
    TrustedFix,
    covariance_radius,
    radius_k,
    reach_radius,
    snapshot_radius,
)
from agvnav.positioning.dynamic import AnglePropagationEstimator, BatchMLEstimator, NaiveEstimator
from agvnav.positioning.edge_bearing import bearing_model
from agvnav.positioning.ekf import EkfEstimator, ekf_predict, ekf_update
from agvnav.positioning.ekf_core import EkfCore, EkfStep
from agvnav.positioning.estimator import METHODS as ESTIMATOR_METHODS
from agvnav.positioning.estimator import StreamingEstimator, make_estimator
from agvnav.positioning.identification import InitialPoseResult, initial_pose_search
from agvnav.positioning.measurement import BearingMeasurement, MeasurementModel, WallRangeMeasurement

__all__ += [
    "ESTIMATOR_METHODS",
    "AnglePropagationEstimator",
    "BatchMLEstimator",
    "BearingMeasurement",
    "DeviationWatch",
    "EkfCore",
    "EkfEstimator",
    "EkfStep",
    "Evidence",
    "InitialPoseResult",
    "MeasurementModel",
    "NaiveEstimator",
    "StreamingEstimator",
    "TrustedFix",
    "WallRangeMeasurement",
    "associate_sweep",
    "batch_ml_fix",
    "bearing_model",
    "covariance_radius",
    "ekf_predict",
    "ekf_update",
    "gate_reflection",
    "initial_pose_search",
    "make_estimator",
    "propagate_bearings",
    "radius_k",
    "reach_radius",
    "snapshot_radius",
]
