"""The one table of equations that still exist in two plain forms (issue 11), kernels aside.

Most equations are written once: a NumPy kernel over ``(..., n)`` arrays serves
batches and, for a single vehicle, the same kernel runs on scalars or a compiled
scalar kernel is wrapped for batches. Where a second, scalar plain-Python form must
stay for the closed loop's hot path (plain ``math`` on one vehicle is 5-20x cheaper
than NumPy's per-call overhead on 3-vectors), it is listed here, next to the form it
mirrors. The compiled kernels (:mod:`agvnav._jit`) are not listed: each is checked
against its oracle (``tests/positioning/test_kernel_oracles.py``) and its two modes
against each other (``tests/test_jit.py``) (issue 27). ``tests/test_twins.py`` walks this table with one parametrized
equivalence test (random inputs, the two forms agree to ``atol``), and a guard
test fails when a scalar twin appears in the source without a row here, so a
twin cannot land untested.

A row names both forms as ``"module:qualified.name"`` strings (no imports: this
module stays import-free so the table costs nothing at start-up).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["TWINS", "Twin", "twin_names"]


@dataclass(frozen=True)
class Twin:
    """One equation in two forms.

    Attributes
    ----------
    name:
        Short unique key (the test case of ``tests/test_twins.py`` has this name).
    scalar:
        ``"module:qualname"`` of the scalar (hot-loop) form.
    reference:
        ``"module:qualname"`` of the vectorised reference form it mirrors.
    equation:
        Where the equation comes from (``[seedNNN eqK]`` or a section).
    atol:
        Largest absolute difference allowed between the two forms (SI units of the output).
    """

    name: str
    scalar: str
    reference: str
    equation: str
    atol: float = 1e-12


TWINS: tuple[Twin, ...] = (
    Twin("wrap_angle", "agvnav.geometry.angles:wrap_angle_scalar", "agvnav.geometry.angles:wrap_angle",
         "[-pi, pi) convention", 0.0),
    Twin("stacker_rk4", "agvnav.kinematics.scalar:stacker_rk4", "agvnav.kinematics:TricycleStacker.step",
         "[seed000 eq8]"),
    Twin("stacker_rk4_values", "agvnav.kinematics.scalar:stacker_rk4_values", "agvnav.kinematics:TricycleStacker.step",
         "[seed000 eq8] (stacker_rk4's body, as floats)"),
    Twin("stacker_rate", "agvnav.kinematics.scalar:stacker_rate", "agvnav.kinematics:TricycleStacker.derivative",
         "[seed000 eq8]"),
    Twin("track_twist", "agvnav.kinematics.scalar:track_twist", "agvnav.kinematics:TrackedVehicle.body_twist",
         "[seed004 eq3]"),
    Twin("track_factors", "agvnav.kinematics.tracked:TrackSlipNoise.factors_scalar",
         "agvnav.kinematics.tracked:TrackSlipNoise.factors", "seed 004 §II slip noise", 0.0),
    Twin("tricycle_increments", "agvnav.odometry.scalar:tricycle_increments_scalar",
         "agvnav.odometry:tricycle_increments", "[seed000 eq8]"),
    Twin("track_increments", "agvnav.odometry.scalar:track_increments", "agvnav.kinematics:TrackedVehicle.body_twist",
         "[seed004 eq5]"),
    Twin("differential_increments", "agvnav.odometry.scalar:differential_increments_scalar",
         "agvnav.odometry:differential_increments", "[seed002 eq16]"),
    Twin("perturb", "agvnav.odometry.errors:NonSystematicErrors.perturb_scalar",
         "agvnav.odometry.errors:NonSystematicErrors.perturb", "seed 002 §3 slip", 1e-12),
    Twin("speed_loop", "agvnav.actuators.scalar:ScalarSpeedLoop.step", "agvnav.actuators:WheelSpeedLoop.step",
         "seed 004 §II"),
    Twin("steering_step", "agvnav.actuators.steering:_steering_step_scalar", "agvnav.actuators.steering:steering_step",
         "issue 5 §3 servo lag"),
    Twin("profile_speed", "agvnav.actuators.speed_profile:_profile_speed_scalar",
         "agvnav.actuators.speed_profile:profile_speed", "issue 5 §3 speed profile"),
    Twin("tracking_errors", "agvnav.guidance.errors:tracking_errors_scalar", "agvnav.guidance.errors:tracking_errors",
         "[seed000 eq9] [seed000 eq10]"),
    Twin("line_point", "agvnav.guidance.paths:LineSegment.point_scalar", "agvnav.guidance.paths:LineSegment.point_at",
         "path geometry"),
    Twin("line_project", "agvnav.guidance.paths:LineSegment.project_scalar",
         "agvnav.guidance.paths:LineSegment.local_projection", "path geometry"),
    Twin("arc_point", "agvnav.guidance.paths:ArcSegment.point_scalar", "agvnav.guidance.paths:ArcSegment.point_at",
         "path geometry"),
    Twin("arc_project", "agvnav.guidance.paths:ArcSegment.project_scalar",
         "agvnav.guidance.paths:ArcSegment.local_projection", "path geometry"),
    Twin("path_project", "agvnav.guidance.paths:Path.project_point", "agvnav.guidance.paths:Path.project",
         "path geometry"),
    Twin("encoder_bearing", "agvnav.sensors.goniometer:Goniometer._encoder_bearing_few",
         "agvnav.sensors.goniometer:Goniometer.encoder_bearing", "seed 000 §2.1", 0.0),
    Twin("gate_one", "agvnav.positioning._fast:gate_one", "agvnav.positioning.bearing_gate:gate_reflection",
         "[seed000 eq2] chi-square gate", 1e-10),
)


def twin_names() -> frozenset[str]:
    """Every scalar form listed (``"module:qualname"``), for the guard test."""
    return frozenset(t.scalar for t in TWINS)
