"""Truth vehicles: one Plant per configuration (docs/ARCHITECTURE.md, "One closed loop for every vehicle").

Each plant composes its kinematic model (:mod:`agvnav.kinematics`), actuators
(:mod:`agvnav.actuators`), encoders (:mod:`agvnav.sensors.encoders`) and
truth-vs-nominal errors (:mod:`agvnav.odometry.errors`), and implements the
engine's Plant role: ``family``, ``signal_names``/``signals()``, ``pose``,
``pose_at(t)``, ``advance(command, t0, dt, rng)``, ``odometry() -> (delta_d,
delta_theta, delta_lateral)`` (the body-twist integrals ``(∫v_x dt, ∫ω dt,
∫v_y dt)`` of base_link over the step, nominal parameters), ``failure()``,
``geometry`` and ``footprint``. :func:`build_plant` makes the plant of any vehicle spec
(:mod:`agvnav.vehicles.builders`). This package never imports :mod:`agvnav.sim`.
"""

from agvnav.vehicles.builders import PLANT_BUILDERS, Plant, build_plant, footprint
from agvnav.vehicles.differential import DifferentialPlant
from agvnav.vehicles.geometry import (
    DRIVE_POINTS,
    HolonomicGeometry,
    SteeredGeometry,
    UnicycleGeometry,
    box_footprint,
    check_footprint,
)
from agvnav.vehicles.mecanum import MecanumPlant
from agvnav.vehicles.steered import STEERED_MODELS, SteeredPlant
from agvnav.vehicles.tracked import TrackedPlant
from agvnav.vehicles.tractor_trailer import TractorTrailerPlant
from agvnav.vehicles.tricycle import TricyclePlant
from agvnav.vehicles.wheel_pair import WheelPairPlant

__all__ = [
    "DRIVE_POINTS",
    "PLANT_BUILDERS",
    "STEERED_MODELS",
    "DifferentialPlant",
    "HolonomicGeometry",
    "MecanumPlant",
    "Plant",
    "SteeredGeometry",
    "SteeredPlant",
    "TrackedPlant",
    "TractorTrailerPlant",
    "TricyclePlant",
    "UnicycleGeometry",
    "WheelPairPlant",
    "box_footprint",
    "build_plant",
    "check_footprint",
    "footprint",
]
