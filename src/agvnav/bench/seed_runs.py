"""One run of a seed experiment with drawn values of the parameters the seed does not give.

Each task function is pure and seeded: it takes the shipped scenario's name, the
values of the swept parameters and a random seed, runs the closed loop and returns
the run's figures as a flat ``{name: float | None}`` mapping (SI units, degrees in
``*_deg``). :mod:`agvnav.bench.seeds` draws the values and summarises the runs.

The swept parameters (name, low, high) and their meaning are listed in
:data:`SEED000_SWEEPS` and :data:`SEED004_SWEEPS`: plausible ranges for a real
vehicle, not values chosen to hit the seed's figures.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import yaml

from agvnav.geometry import lateral_position_error
from agvnav.sim import simulate
from agvnav.sim.laps import simulate_tracked
from agvnav.sim.metrics import guidance_figures, lateral_error_statistics
from agvnav.world.scenario import builtin_scenario, parse_scenario

__all__ = [
    "SEED000_SWEEPS",
    "SEED004_SWEEPS",
    "Sweep",
    "draw",
    "guidance_run",
    "positioning_run",
    "square_run",
]


@dataclass(frozen=True)
class Sweep:
    """A parameter the seed does not give: uniform over ``[low, high]`` (unit in the name)."""

    name: str
    low: float
    high: float
    meaning: str

    def __post_init__(self) -> None:
        if not self.low <= self.high:
            raise ValueError(f"sweep {self.name}: low {self.low} > high {self.high}")


SEED000_SWEEPS = (
    Sweep("reflector_survey_std_m", 0.0, 0.005, "std per axis of the true reflectors around the surveyed map"),
    Sweep("wheel_radius_error", -0.005, 0.005, "relative error of the drive wheel radius"),
    Sweep("steering_offset_deg", -0.5, 0.5, "steering encoder zero offset"),
    Sweep("slip_std", 0.0, 0.02, "random traction slip per sqrt(m)"),
    Sweep("wheelbase_error", -0.01, 0.01, "relative error of the wheelbase"),
    Sweep("servo_time_constant_s", 0.02, 0.15, "steering servo lag"),
)
SEED004_SWEEPS = (
    Sweep("icr_error", 0.0, 0.04, "odometry ICR factor below the true one (fraction)"),
    Sweep("slip_error", 0.0, 0.4, "odometry slip below the true slip (fraction)"),
    Sweep("slip_noise_std", 0.0, 0.006, "random slip per metre rolled per track"),
    Sweep("ranger_noise_std_m", 0.0, 0.01, "ultrasonic range noise"),
    Sweep("motor_asymmetry", -0.04, 0.04, "right minus left motor gain"),
)

#: Seed 000 §4.3: the arc of radius 1.24 m (90 deg) before the straight; path abscissa of the straight's start (m).
SEED000_STRAIGHT_START_M = 1.24 * math.pi / 2.0
#: True terrains of the tracked presets (slip, ICR factor), as agvnav.kinematics.tracked defines them.
_TRUTH = {"concrete": (0.02, 1.15), "artificial_grass": (0.06, 1.4)}


def draw(sweeps: tuple[Sweep, ...], rng: np.random.Generator) -> dict[str, float]:
    """One uniform draw of every swept parameter."""
    return {s.name: float(rng.uniform(s.low, s.high)) for s in sweeps}


def _document(name: str) -> dict[str, Any]:
    data = yaml.safe_load(builtin_scenario(name).read_text(encoding="utf-8"))
    if not isinstance(data, dict):
        raise ValueError(f"scenario {name} is not a mapping")
    return data


def _parse(data: dict[str, Any]) -> Any:
    return parse_scenario(yaml.safe_dump(data, sort_keys=False), source=str(data.get("name", "bench")))


def _seed000_document(name: str, values: dict[str, float], seed: int) -> dict[str, Any]:
    d = copy.deepcopy(_document(name))
    d["seed"] = int(seed)
    d.setdefault("world_truth", {})["reflector_survey_std_m"] = values["reflector_survey_std_m"]
    truth = d["vehicle"].setdefault("truth", {})
    for key in ("wheel_radius_error", "steering_offset_deg", "slip_std", "wheelbase_error"):
        truth[key] = values[key]
    d["vehicle"].setdefault("steering", {})["time_constant_s"] = values["servo_time_constant_s"]
    return d


def guidance_run(name: str, values: dict[str, float], seed: int) -> dict[str, float | None]:
    """Seed 000 §4.3 figures of one run of scenario ``name`` (see :func:`guidance_figures`)."""
    r = simulate(_parse(_seed000_document(name, values, seed)))
    s = r.series
    g = guidance_figures(s["s_true"], s["distance_C"], s["eps_c"], s["xi_r"], SEED000_STRAIGHT_START_M)
    xi = g.max_abs_xi_r_after_rad
    return {
        "max_abs_eps_c_after_m": g.max_abs_eps_c_after_m,
        "max_abs_eps_c_straight_m": g.max_abs_eps_c_straight_m,
        "max_abs_xi_r_after_deg": None if xi is None else math.degrees(xi),
        "settling_distance_m": g.settling_distance_m,
        "completed": float(r.completed),
    }


def positioning_run(
    name: str, values: dict[str, float], seed: int, segments: int | None = None
) -> dict[str, float | None]:
    """Seed 000 §4.2 |e_lat| statistics of one run (1 Hz tracer); ``segments`` cuts the drive short."""
    d = _seed000_document(name, values, seed)
    if segments is not None:
        d["path"]["segments"] = d["path"]["segments"][:segments]
    r = simulate(_parse(d))
    s = r.series
    e = lateral_position_error(np.column_stack([s["x"], s["y"], s["psi"]]),
                               np.column_stack([s["est_x"], s["est_y"], s["est_psi"]]))
    st = lateral_error_statistics(s["t"], e, s["est_status"] >= 1.0)
    if st is None:
        return dict.fromkeys(("mean_abs_m", "std_abs_m", "std_signed_m", "max_abs_m"))
    return {"mean_abs_m": st.mean_abs_m, "std_abs_m": st.std_abs_m, "std_signed_m": st.std_signed_m,
            "max_abs_m": st.max_abs_m, "samples": float(st.samples)}


def _seed004_document(name: str, values: dict[str, float], seed: int, laps: int, landmarks: bool) -> dict[str, Any]:
    d = copy.deepcopy(_document(name))
    d["seed"] = int(seed)
    terrain = d["vehicle"]["terrain"]
    slip, icr = _TRUTH[terrain["truth"]]
    s_odo, i_odo = slip * (1.0 - values["slip_error"]), icr * (1.0 - values["icr_error"])
    terrain["odometry"] = {"slip_left": s_odo, "slip_right": s_odo, "icr_left": i_odo, "icr_right": i_odo}
    terrain["slip_noise_std"] = values["slip_noise_std"]
    d["ultrasonic"]["noise_std_m"] = values["ranger_noise_std_m"]
    d["vehicle"]["motor"]["asymmetry"] = values["motor_asymmetry"]
    d["controller"].update(laps=int(laps), landmarks=bool(landmarks), compare_landmarks=False)
    return d


def square_run(name: str, values: dict[str, float], seed: int, laps: int, landmarks: bool) -> dict[str, float | None]:
    """Seed 004 §III figures of one run: per-lap error and the lap end point's |x|, |y| from the start (m)."""
    d = _seed004_document(name, values, seed, laps, landmarks)
    result = simulate_tracked(_parse(d))
    run = result.runs[bool(landmarks)]
    lp = run.laps
    side = float(d["route"]["side_m"])
    if lp.laps == 0:
        return dict.fromkeys(("per_lap_m", "per_lap_pct_side", "end_abs_x_m", "end_abs_y_m"))
    start = np.asarray(d["route"]["start"][:2], dtype=np.float64)
    off = np.abs(np.asarray(lp.end_xy) - start)
    per_lap = float(np.mean(lp.per_lap_m))
    return {"per_lap_m": per_lap, "per_lap_pct_side": 100.0 * per_lap / side,
            "end_abs_x_m": float(np.mean(off[:, 0])), "end_abs_y_m": float(np.mean(off[:, 1])),
            "laps": float(lp.laps)}
