"""Reflector mapping (SLAM, issue 17): survey the reflectors by driving, with honest uncertainty.

From a drive's wheel odometry and anonymous goniometer reflections, the reflector positions and
the trajectory are estimated jointly in a factor graph (odometry between-factors, leading-edge
bearing factors, anchors as priors), solved incrementally during the drive and in batch at the
end with SciPy's sparse least squares; see :mod:`agvnav.mapping.slam` for the steps and
:mod:`agvnav.mapping.anchors` for what fixes frame and scale.
"""

from agvnav.mapping.anchors import (
    Anchor,
    AnchorImplausible,
    BaselineAnchor,
    ScaleUnobservable,
    StartPoseAnchor,
    SurveyedAnchor,
    anchor_kind,
    check_anchor_fit,
    match_surveyed,
    parse_anchor,
)
from agvnav.mapping.association import associate, head_poses, predicted_edge_bearings
from agvnav.mapping.drive import Drive, prepare_drive
from agvnav.mapping.graph import FactorGraph, linearize
from agvnav.mapping.initialise import InitialiseOptions, initialise_from_tracks, track_reflections, triangulate_rays
from agvnav.mapping.output import frame_free_covariance, map_summary, result_to_map, write_map
from agvnav.mapping.slam import MappingOptions, MappingResult, build_map, front_end, solve_anchored
from agvnav.mapping.solve import marginal_covariances, reflector_covariance, solve

__all__ = [
    "Anchor",
    "AnchorImplausible",
    "BaselineAnchor",
    "Drive",
    "FactorGraph",
    "InitialiseOptions",
    "MappingOptions",
    "MappingResult",
    "ScaleUnobservable",
    "StartPoseAnchor",
    "SurveyedAnchor",
    "anchor_kind",
    "associate",
    "build_map",
    "check_anchor_fit",
    "frame_free_covariance",
    "front_end",
    "head_poses",
    "initialise_from_tracks",
    "linearize",
    "map_summary",
    "marginal_covariances",
    "match_surveyed",
    "parse_anchor",
    "predicted_edge_bearings",
    "prepare_drive",
    "reflector_covariance",
    "result_to_map",
    "solve",
    "solve_anchored",
    "track_reflections",
    "triangulate_rays",
    "write_map",
]
