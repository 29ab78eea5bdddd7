"""Factories of every truth vehicle with small, known parameters, and a fixed-command driver (test helper)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from agvnav.actuators import SteeringActuator, WheelSpeedLoop
from agvnav.kinematics import MecanumBase, TrackedVehicle, TractorTrailer, twist_step
from agvnav.odometry import NonSystematicErrors, SystematicErrors, TricycleErrors
from agvnav.vehicles import (
    DifferentialPlant,
    MecanumPlant,
    SteeredPlant,
    TrackedPlant,
    TractorTrailerPlant,
    TricyclePlant,
)


def tricycle(systematic: TricycleErrors | None = None, nonsystematic: NonSystematicErrors | None = None,
             state: Sequence[float] = (0.0, 0.0, 0.0, 0.0), cpr: int = 100000) -> TricyclePlant:
    """The seed-000 stacker: L = 1.24 m, R = 0.125 m, fine encoders."""
    steering = SteeringActuator(max_angle=math.pi / 2 - 1e-9, max_rate=2.0, tau=0.0)
    return TricyclePlant(1.24, 0.125, cpr, 1 << 20, steering, systematic or TricycleErrors(), nonsystematic, state)


def steered(model: str = "tricycle_rear", systematic: TricycleErrors | None = None,
            nonsystematic: NonSystematicErrors | None = None, state: Sequence[float] = (0.0, 0.0, 0.0, 0.0),
            cpr: int = 100000) -> SteeredPlant:
    """Model A / Ackermann: L = 1.5 m, R = 0.15 m, track 1.0 m for Ackermann, max steer 60 deg."""
    steering = SteeringActuator(max_angle=math.radians(60.0), max_rate=2.0, tau=0.0)
    return SteeredPlant(model, 1.5, 0.15, cpr, 1 << 20, steering, systematic, nonsystematic, state,
                        track=1.0 if model == "ackermann" else None)


def differential(systematic: SystematicErrors | None = None, nonsystematic: NonSystematicErrors | None = None,
                 pose: Sequence[float] = (0.0, 0.0, 0.0), cpr: int = 100000) -> DifferentialPlant:
    """Wheel radius 0.1 m, track 0.5 m, seed-004 speed loop."""
    return DifferentialPlant(0.1, 0.5, cpr, pose, WheelSpeedLoop(), systematic, nonsystematic)


def tracked(pose: Sequence[float] = (0.0, 0.0, 0.0), slip_noise_std: float = 0.0) -> TrackedPlant:
    """The seed-004 robot on concrete (gauge 0.33 m, sprocket 0.05 m), odometry calibrated for it."""
    veh = TrackedVehicle(0.33, 0.05, "concrete")
    return TrackedPlant(veh, WheelSpeedLoop(), veh.terrain, 100000, pose, 0.01, slip_noise_std)


def tractor_trailer(phi0: float = 0.0, hitch_offset: float = 0.3, max_hitch: float = math.radians(60.0),
                    nonsystematic: NonSystematicErrors | None = None) -> TractorTrailerPlant:
    """The differential tractor towing a 1.2 m trailer."""
    return TractorTrailerPlant(differential(nonsystematic=nonsystematic),
                               TractorTrailer(1.2, hitch_offset, max_hitch), phi0)


def mecanum(radius_scales: Sequence[float] = (1.0, 1.0, 1.0, 1.0), roller_slip: float = 0.0,
            nonsystematic: NonSystematicErrors | None = None, cpr: int = 100000) -> MecanumPlant:
    """r = 0.05 m, a = 0.3 m, b = 0.25 m, X layout."""
    base = MecanumBase(0.05, 0.3, 0.25, "X")
    return MecanumPlant(base, cpr, (0.0, 0.0, 0.0), WheelSpeedLoop(), radius_scales, roller_slip, nonsystematic)


#: name -> (factory, a command the plant can hold for a while)
PLANTS: dict[str, tuple[Callable[..., Any], tuple[float, ...]]] = {
    "tricycle": (tricycle, (0.5, 0.2)),
    "tricycle_rear": (steered, (0.5, 0.2)),
    "ackermann": (lambda **kw: steered("ackermann", **kw), (0.5, 0.2)),
    "differential": (differential, (3.0, 2.0)),
    "tracked": (tracked, (3.0, 2.0)),
    "tractor_trailer": (tractor_trailer, (3.0, 2.5)),
    "mecanum": (mecanum, (0.1, 0.05, 0.1)),
}


def drive(plant: Any, command: Sequence[float], steps: int, dt: float = 0.05, seed: int = 0,
          t0: float = 0.0) -> list[tuple[float, float, float]]:
    """Hold ``command`` for ``steps`` steps of ``dt``; returns the odometry increments."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(steps):
        plant.advance(command, t0 + k * dt, dt, rng)
        out.append(plant.odometry())
    return out


def integrate_odometry(start: Sequence[float], increments: Sequence[tuple[float, float, float]]) -> np.ndarray:
    """Dead-reckoned pose: the SE(2) exponential of every increment in turn."""
    pose = np.asarray(start, dtype=np.float64)
    for dd, dth, dlat in increments:
        pose = twist_step(pose, dd, dlat, dth, 1.0)
    return pose
