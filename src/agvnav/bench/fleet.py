"""``agvnav bench fleet``: cost of a fleet in the shipped warehouse, per vehicle-step (issue 28).

For 1, 5, 20, 50 (and 200 unless ``--quick``) differential AGVs in the ``warehouse`` map, each with
the goniometer, the EKF and its integrity monitor, Kanayama guidance, the positioning guard and
a safety scanner with its protective and warning fields, stepped in lockstep
(:mod:`agvnav.sim.fleet`): CPU time per vehicle-step (µs), real-time factor (CPU), peak memory of
the process, collisions, minimum separation and jobs completed. The vehicles stand in rows along
the lanes and aisles, 2.4 m apart, and all drive 1 m ahead on parallel lines at the same speed:
they follow one another without crossing (each shows on its follower's scanner).

Issue 28's target is 50x real time for 50 vehicles (about 20 µs per vehicle-step): this is the
per-vehicle engine stepped in lockstep, whose figures the batch-kernel engine is to beat.
"""

from __future__ import annotations

import math
import resource
import sys
from collections.abc import Callable
from typing import Any

from agvnav.sim.fleet import build_fleet, run_fleet
from agvnav.world.fleet import parse_fleet

__all__ = ["PRIORITY", "SIZES", "TITLE", "fleet_text", "run", "slots"]

TITLE = "Fleet in the warehouse: CPU per vehicle-step, real-time factor, memory (issue 28; target 50x at 50)"
PRIORITY = ("vehicles", "us_per_vehicle_step", "real_time_factor_cpu", "peak_mib", "collisions", "min_separation_m",
            "jobs_completed")

#: Fleet sizes measured (the quick run stops at 50).
SIZES = (1, 5, 20, 50, 200)
#: Simulated time of each measurement (s).
SIM_S = 8.0
SIM_S_QUICK = 5.0

_HEAD = """\
name: bench_fleet_{n}
seed: {seed}
step_s: 0.05
duration_s: {duration}
end_hold_s: {duration}
map: warehouse
world_truth: {{reflector_survey_std_m: 0.002}}
traction: {{speed_m_s: 1.0, max_accel_m_s2: 0.3, max_decel_m_s2: 0.3}}
goniometer: {{rate_hz: 8.0, mount: [0.0, 0.0, 0.0], max_range_m: 20.0, p_miss: 0.05, spurious_rate_hz: 0.2}}
positioning: {{method: ekf, odometry_noise: [5.0e-5, 8.0e-4, 2.0e-4]}}
vehicle: {{model: differential, track_m: 0.5, wheel_radius_m: 0.08, encoder_counts_per_rev: 4096,
          truth: {{wheel_diameter_ratio: 1.002, track_ratio: 1.01, slip_k: 0.0001}}}}
controller: {{name: kanayama, params: {{convergence_distance: 0.5}}}}
scanner: {{rate_hz: 12.5, step_deg: 1.0}}
reactive: {{approach_speed_m_s: 0.0}}   # fields for standing or crossing obstacles: the racks stay outside
fleet:
  vehicles:
"""


def slots() -> list[tuple[float, float, float]]:
    """Start poses ``(x, y, heading_deg)`` in the warehouse, rows along the lanes and aisles first, then columns."""
    rows = [5.0, 34.0, 12.0, 18.0, 24.0, 3.0, 7.0, 32.0, 36.0, 11.0, 13.0, 17.0, 19.0, 23.0, 25.0]
    xs = [11.0 + 2.4 * k for k in range(15)]
    out = [(x, y, 0.0) for y in rows for x in xs]
    out += [(x, 8.0 + 2.4 * k, 90.0) for x in (7.5, 52.5) for k in range(9)]
    return out


def fleet_text(n: int, seed: int, duration: float) -> str:
    """The fleet scenario of ``n`` vehicles (YAML text)."""
    lines = [_HEAD.format(n=n, seed=seed, duration=duration)]
    for i, (x, y, h) in enumerate(slots()[:n]):
        path = f"{{start: [{x}, {y}, {h}], segments: [{{type: line, length_m: 1.0}}]}}"
        lines.append(f"    - id: v{i}\n      path: {path}\n")
    return "".join(lines)


def _peak_mib() -> float:
    """Peak resident memory of this process so far (MiB)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**20 if sys.platform == "darwin" else peak / 1024.0


def run(quick: bool, seed: int, progress: Callable[[int, int], None] | None = None) -> list[dict[str, Any]]:
    """One record per fleet size: vehicles, simulated time, CPU, µs per vehicle-step, real-time factor, memory."""
    sizes = [n for n in SIZES if not (quick and n > 50)]
    duration = SIM_S_QUICK if quick else SIM_S
    records = []
    for k, n in enumerate(sizes):
        fleet = parse_fleet(fleet_text(n, seed, duration), f"<bench fleet {n}>")
        result = run_fleet(build_fleet(fleet))
        f = result.figures
        records.append({
            "vehicles": n,
            "sim_time_s": f["sim_time_s"],
            "vehicle_steps": f["vehicle_steps"],
            "cpu_time_s": f["cpu_time_s"],
            "us_per_vehicle_step": f["us_per_vehicle_step"],
            "real_time_factor_cpu": f["real_time_factor_cpu"],
            "peak_mib": _peak_mib(),
            "collisions": f["collisions"],
            "min_separation_m": f["min_separation_m"] if math.isfinite(f["min_separation_m"]) else None,
            "jobs_completed": f["jobs_completed"],
            "outcome": result.outcome,
        })
        if progress is not None:
            progress(k + 1, len(sizes))
    return records
