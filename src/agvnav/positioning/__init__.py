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
