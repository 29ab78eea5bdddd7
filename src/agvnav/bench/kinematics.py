"""``agvnav bench kinematics``: batch stepping speed of every model; odometry integrators' errors.

Speed: ``steps_per_s`` = vehicle-steps per second when stepping a batch of
10,000 vehicles in one call of the unchecked kernel ``step_unchecked`` (what a
simulator's hot loop uses); ``validated_steps_per_s`` is the same through the
validated ``step`` (shape, finiteness, limits before and after the step). Accuracy: the maximum position error of the
three seed-002 update rules ([seed002 eq20] [seed002 eq25] [seed002 eq26]) against the exact path, on a
circle (where the arc rule is exact) and on a slalom (curvature varying).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from agvnav.bench.common import best_time
from agvnav.kinematics import (
    Ackermann,
    AckermannSimple,
    DifferentialDrive,
    KinematicModel,
    MecanumBase,
    TrackedVehicle,
    TractorTrailer,
    TricycleRearDrive,
    TricycleRearDriveSimple,
    TricycleStacker,
    TricycleStackerSimple,
)
from agvnav.odometry import RULES, integrate_pose

TITLE = "Kinematics: steps/s for 10,000 vehicles per call; odometry integrators vs the exact path"
#: Columns a narrow terminal keeps, most important first (`--wide` shows all).
PRIORITY = ("model", "integrator", "path", "steps_per_s", "max_error_m", "step_m", "step")
BATCH = 10_000

#: name -> (factory, how its step integrates, zero the steering rate so the exact arc branch runs)
MODELS: dict[str, tuple[Callable[[], KinematicModel], str, bool]] = {
    "differential": (lambda: DifferentialDrive(track=0.5), "exact", False),
    "tricycle_stacker (gamma_dot)": (lambda: TricycleStacker(wheelbase=1.3), "RK4 x4", False),
    "tricycle_stacker (gamma_dot=0)": (lambda: TricycleStacker(wheelbase=1.3), "exact", True),
    "tricycle_stacker_simple": (lambda: TricycleStackerSimple(wheelbase=1.3), "exact", False),
    "tricycle_model_a": (lambda: TricycleRearDrive(wheelbase=1.3, max_steer=1.2), "RK4 x4", False),
    "tricycle_model_a_simple": (lambda: TricycleRearDriveSimple(wheelbase=1.3, max_steer=1.2), "exact", False),
    "ackermann": (lambda: Ackermann(wheelbase=2.5, track=1.5), "RK4 x4", False),
    "ackermann_simple": (lambda: AckermannSimple(wheelbase=2.5, track=1.5), "exact", False),
    "tractor_trailer": (lambda: TractorTrailer(trailer_length=2.0, hitch_offset=0.5), "RK4 x4", False),
    "mecanum (X)": (lambda: MecanumBase(0.05, 0.3, 0.25), "exact", False),
    # Layout O moves (rank 3) because a != b; a square O base (a == b) could not rotate.
    "mecanum (O)": (lambda: MecanumBase(0.05, 0.3, 0.25, layout="O"), "exact", False),
    "tracked (concrete)": (lambda: TrackedVehicle(0.4, terrain="concrete"), "exact", False),
    "tracked (artificial_grass)": (lambda: TrackedVehicle(0.4, terrain="artificial_grass"), "exact", False),
}


def _speed_record(name: str, rng: np.random.Generator, repeat: int) -> dict[str, Any]:
    make, method, hold_steering = MODELS[name]
    model = make()
    state = rng.uniform(-0.5, 0.5, (BATCH, model.n_state))
    u = rng.uniform(-0.5, 0.5, (BATCH, model.n_input))
    if hold_steering:
        u[:, 1] = 0.0
    if not (np.all(model.state_valid(state)) and np.all(model.input_valid(u))):
        raise RuntimeError(f"bench kinematics: {name} sample outside the model's limits")
    t = best_time(lambda: model.step_unchecked(state, u, 0.01), repeat=repeat)
    t_checked = best_time(lambda: model.step(state, u, 0.01), repeat=repeat)
    return {"model": name, "step": method, "steps_per_s": BATCH / t, "validated_steps_per_s": BATCH / t_checked}


def _slalom(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Speed 1 m/s, yaw rate 0.8 sin(0.5 t): heading is analytic."""
    return np.ones_like(t), 1.6 * (1.0 - np.cos(0.5 * t))


def _slalom_velocity(tt: float, _xy: np.ndarray) -> np.ndarray:
    """``(x', y')`` (m/s) of the slalom at time ``tt`` (s), for the ODE solver."""
    th = _slalom(np.array([tt]))[1][0]
    return np.array([np.cos(th), np.sin(th)])


def _exact_path(kind: str, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact poses (len(t), 3) and heading, circle (R = 2 m) or slalom (ODE to 1e-12)."""
    if kind == "circle":
        th = 0.5 * t
        return np.stack([2.0 * np.sin(th), 2.0 * (1.0 - np.cos(th)), th], axis=-1), th
    sol = solve_ivp(_slalom_velocity, (t[0], t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-12, atol=1e-12)
    th = _slalom(t)[1]
    return np.stack([sol.y[0], sol.y[1], th], axis=-1), th


def _integrator_records(quick: bool) -> list[dict[str, Any]]:
    records = []
    duration = 20.0 if quick else 60.0
    for kind in ("circle", "slalom"):
        for dt in (0.05, 0.2):
            t = np.arange(0.0, duration + 1e-9, dt)
            exact, th = _exact_path(kind, t)
            delta_d, delta_theta = np.full(len(t) - 1, dt), np.diff(th)
            for rule in RULES:
                pose = np.zeros(3)
                err = 0.0
                for k in range(len(t) - 1):
                    pose = integrate_pose(pose, delta_d[k], delta_theta[k], rule)
                    err = max(err, float(np.hypot(*(pose[:2] - exact[k + 1, :2]))))
                records.append({"integrator": rule, "path": f"{kind} {duration:.0f} m", "step_m": dt,
                                "max_error_m": err})
    return records


def run(quick: bool, seed: int) -> list[dict[str, Any]]:
    """Speed records (``model``, ``steps_per_s``) then accuracy records (``integrator``, ``max_error_m``)."""
    rng = np.random.default_rng(seed)
    repeat = 2 if quick else 7
    records = [_speed_record(name, rng, repeat) for name in MODELS]
    return records + _integrator_records(quick)
