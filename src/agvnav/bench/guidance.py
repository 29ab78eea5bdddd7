"""``agvnav bench guidance``: the seed's laws against pure pursuit and Stanley, and the simulator's speed.

Every controller runs in the full closed loop (goniometer, EKF positioning,
steering servo, truth errors of the default scenario) on the same paths with
the same random seed, each tuned for the same convergence distance
(``convergence_distance``, understood by all four laws). The vehicle starts
110 mm off the path (seed 000 §4.3). Paths:

- ``line``: 6 m straight, forward, point C (cruising);
- ``arc``: a half circle of radius 2 m, forward, point C;
- ``seed_test``: the seed-000 §4.3 path, an arc of radius 1.24 m then 3 m straight;
- ``reverse_line``: 5 m straight driven in reverse (forks first), point O (manoeuvre).
  The simple law and Stanley are defined for forward driving only, so only the
  general law and pure pursuit run it.

The general law on point C is designed with its real pole at -1/L per metre
(hidden from eps_c, see :mod:`agvnav.guidance.gains`): with the earlier
seed-like pattern (real pole = real part of the pair) at 1.5 m it overshot
to -140 mm on the line and saturated the wheel on ``seed_test``.

Figures from the true lateral error of the tracked point, none fixed by a threshold
(issue 13): ``max_lateral_2nd_half_m`` and ``rms_lateral_2nd_half_m`` over the second
half of the path (true path abscissa), ``settling_distance_m`` where |e| enters and
stays within 20 % of the initial 110 mm (:func:`agvnav.sim.metrics.settling_distance`),
``max_wheel_heading_2nd_half_deg`` likewise. The seed-000 §4.3 figures themselves, with
the seed's method, are in ``agvnav bench seeds``. The last
records give the real-time factor of the default scenario (best of a few runs)
and, in the full run, the peak memory of a one-hour simulated drive.
"""

from __future__ import annotations

import copy
import math
import resource
import time
from typing import Any

import numpy as np
import yaml

from agvnav.sim import simulate
from agvnav.sim.metrics import SETTLING_FRACTION, max_abs_from, settling_distance
from agvnav.world.scenario import Scenario, builtin_scenario, default_scenario, parse_scenario

TITLE = "Guidance laws in the closed loop (start 110 mm off the path): seed 000 vs pure pursuit and Stanley"

CONTROLLERS = ("seed_general", "seed_simple", "pure_pursuit", "stanley")
CONVERGENCE_DISTANCE_M = 1.5

PATHS: dict[str, dict[str, Any]] = {
    "line": {"start": [4.0, 3.0, 0.0], "segments": [{"type": "line", "length_m": 6.0}]},
    "arc": {"start": [8.0, 2.0, 0.0], "segments": [{"type": "arc", "radius_m": 2.0, "sweep_deg": 180.0}]},
    "seed_test": {
        "start": [5.5, 2.0, 0.0],
        "segments": [{"type": "arc", "radius_m": 1.24, "sweep_deg": 90.0}, {"type": "line", "length_m": 3.0}],
    },
    "reverse_line": {
        "start": [10.0, 3.0, 180.0],
        "segments": [{"type": "line", "length_m": 5.0, "direction": "reverse"}],
    },
}


def _base() -> dict[str, Any]:
    data = yaml.safe_load(builtin_scenario("guidance_test").read_text(encoding="utf-8"))
    assert isinstance(data, dict)
    return data


def scenario_for(controller: str, path: str, seed: int, base: dict[str, Any] | None = None) -> Scenario:
    """The bench scenario of ``controller`` on ``path`` (see the module docstring)."""
    d = copy.deepcopy(base if base is not None else _base())
    d["name"] = f"{controller}_{path}"
    d["seed"] = seed
    d["path"] = copy.deepcopy(PATHS[path])
    reverse = path.startswith("reverse")
    d["controller"] = {
        "name": controller,
        "point": "O" if reverse else "C",
        "params": {"convergence_distance": CONVERGENCE_DISTANCE_M},
    }
    return parse_scenario(yaml.safe_dump(d, sort_keys=False), source=d["name"])


def _supports(controller: str, path: str) -> bool:
    return not (path.startswith("reverse") and controller in ("seed_simple", "stanley"))


def _row(controller: str, path: str, seed: int) -> dict[str, Any]:
    sc = scenario_for(controller, path, seed)
    r = simulate(sc)
    s, e = r.series["s_true"], r.series["lateral_error"]
    half = 0.5 * r.path.length
    tail = e[(s >= half) & np.isfinite(e)]
    xr = max_abs_from(r.series["heading_error"], s, half)
    return {
        "controller": controller,
        "path": path,
        "direction": "reverse" if path.startswith("reverse") else "forward",
        "rms_lateral_2nd_half_m": float(np.sqrt(np.mean(tail**2))) if tail.size else None,
        "max_lateral_2nd_half_m": max_abs_from(e, s, half),
        "settling_distance_m": settling_distance(e, r.series["distance_C"] if "distance_C" in r.series
                                                 else r.series["distance_O"], SETTLING_FRACTION * abs(float(e[0]))),
        "max_wheel_heading_2nd_half_deg": None if xr is None else math.degrees(xr),
        "completed": r.completed,
    }


def real_time_factor(seed: int, repeat: int = 3) -> dict[str, Any]:
    """Best real-time factor of the default scenario over ``repeat`` runs (simulated s per wall s)."""
    sc = default_scenario().with_seed(seed)
    best = None
    for _ in range(repeat):
        m = simulate(sc).metrics
        if best is None or m.wall_time_s < best.wall_time_s:
            best = m
    assert best is not None
    return {
        "controller": sc.controller.name,
        "path": "default scenario",
        "direction": "forward",
        "sim_time_s": best.sim_time_s,
        "wall_time_s": best.wall_time_s,
        "real_time_factor": best.real_time_factor,
    }


def one_hour_memory(seed: int, hours: float = 1.0) -> dict[str, Any]:
    """Peak resident memory (MiB, the process's ru_maxrss) and wall time of an ``hours``-long drive.

    The default scenario's vehicle drives laps of a closed 4 m x 2 m loop in the lab
    for the given time; every signal is recorded as in any run.
    """
    d = _base()
    d["name"] = "one_hour"
    d["seed"] = seed
    d["duration_s"] = 3600.0 * hours
    lap = [
        {"type": "line", "length_m": 4.0},
        {"type": "arc", "radius_m": 1.5, "sweep_deg": 180.0},
        {"type": "line", "length_m": 4.0},
        {"type": "arc", "radius_m": 1.5, "sweep_deg": 180.0},
    ]
    laps = math.ceil(3600.0 * hours * d["traction"]["speed_m_s"] / (8.0 + 3.0 * math.pi)) + 1
    d["path"] = {"start": [4.0, 2.5, 0.0], "segments": lap * laps}
    sc = parse_scenario(yaml.safe_dump(d, sort_keys=False), source="one_hour")
    start = time.perf_counter()
    m = simulate(sc).metrics
    wall = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: KiB
    return {
        "controller": sc.controller.name,
        "path": f"{hours:g} h of laps",
        "direction": "forward",
        "sim_time_s": m.sim_time_s,
        "wall_time_s": wall,
        "peak_memory_mib": peak / 2**20,
        "rms_lateral_m": m.rms_lateral_error_m,
    }


def run(quick: bool, seed: int) -> list[dict[str, Any]]:
    """One record per controller and path, then the simulator's speed (and memory in the full run)."""
    paths = ("seed_test", "reverse_line") if quick else tuple(PATHS)
    records = [_row(c, p, seed) for p in paths for c in CONTROLLERS if _supports(c, p)]
    records.append(real_time_factor(seed, repeat=1 if quick else 3))
    if not quick:
        records.append(one_hour_memory(seed))
    return records
