"""``agvnav bench fleet``: cost of a fleet in the shipped warehouse, per vehicle-step (issue 28).

For 1, 5, 20, 50 (and 200 unless ``--quick``) differential AGVs in the ``warehouse`` map, each with
the goniometer, the EKF and its integrity monitor, Kanayama guidance, the positioning guard and
a safety scanner with its protective and warning fields, stepped in lockstep
(:mod:`agvnav.sim.fleet`): CPU time per vehicle-step (µs), real-time factor (CPU), peak memory of
the process, collisions, minimum separation and jobs completed. The vehicles stand in rows along
the middle of the three aisles and the south and north lanes (:func:`slots`), 1.5 m apart across a
row's direction and 3.5 m apart along it, and all drive east at 0.5 m/s on parallel lines of the
same length (:data:`PATH_M`) with the same ramps: each keeps its distance to the one ahead, which
stays beyond its warning field (0.6 m of protective and 0.75 m of warning field ahead of the body
at 0.5 m/s and 0.5 m/s² emergency deceleration, 2.6 m of gap), and beside it beyond its field's
side (0.1 m beyond the body), so every vehicle drives its whole line, stops and holds
there until the measurement's end, and the row completes. A first untimed run of two vehicles
loads or compiles every kernel the rows use, so no row pays for that.

Issue 28's target is 50x real time for 50 vehicles (about 20 µs per vehicle-step): this is the
per-vehicle engine stepped in lockstep, whose figures the batch-kernel engine is to beat.
"""

from __future__ import annotations

import math
import resource
import sys
import tracemalloc
from collections.abc import Callable
from typing import Any

from agvnav.sim.fleet import build_fleet, fleet_stride, run_fleet
from agvnav.world.fleet import parse_fleet

__all__ = ["PRIORITY", "SIZES", "TITLE", "fleet_text", "run", "shift_memory", "slots"]

TITLE = "Fleet in the warehouse: CPU per vehicle-step, real-time factor, memory (issue 28; target 50x at 50)"
PRIORITY = ("vehicles", "us_per_vehicle_step", "real_time_factor_cpu", "peak_mib", "collisions", "min_separation_m",
            "jobs_completed")

#: Fleet sizes measured (the quick run stops at 50).
SIZES = (1, 5, 20, 50, 200)
#: Simulated time of each measurement (s).
SIM_S = 8.0
SIM_S_QUICK = 5.0
#: Length of every vehicle's line (m): 0.5 m/s with 0.5 m/s^2 ramps, driven in about 4 s.
PATH_M = 1.5

_HEAD = """\
name: bench_fleet_{n}
seed: {seed}
step_s: 0.05
duration_s: {duration}
end_hold_s: {duration}
map: warehouse
world_truth: {{reflector_survey_std_m: 0.002}}
traction: {{speed_m_s: 0.5, max_accel_m_s2: 0.5, max_decel_m_s2: 0.5}}
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

#: Rows of start slots ``(y, x_first, x_last)`` (m): the middle of each aisle (y 10-14, 16-20, 22-26, racks
#: x 10-50; a vehicle beside another in an aisle hides the rack faces' reflectors from it), then rows 1.5 m
#: apart in the south (y 0-8) and north (y 28-40) lanes, listed so that the first rows are far apart.
ROWS = tuple((y, 11.0, 45.5) for y in (12.0, 18.0, 24.0)) + tuple(
    (y, 1.5, 55.0) for y in (4.5, 33.5, 1.5, 36.5, 30.5, 6.0, 35.0, 3.0, 32.0, 38.0, 29.0))
#: Distance (m) between two vehicles of a row (beyond the warning field of the one behind).
ALONG_M = 3.5


def slots() -> list[tuple[float, float, float]]:
    """Start poses ``(x, y, heading_deg)`` in the warehouse, row by row (:data:`ROWS`), heading east."""
    out = []
    for k, (y, x0, x1) in enumerate(ROWS):
        shift = 0.5 * ALONG_M * (k % 2)  # neighbouring rows staggered
        n = int((x1 - x0 - shift) // ALONG_M) + 1
        out += [(x0 + shift + ALONG_M * j, y, 0.0) for j in range(n)]
    return out


def fleet_text(n: int, seed: int, duration: float, record_step_s: float | None = None) -> str:
    """The fleet scenario of ``n`` vehicles (YAML text); ``record_step_s`` its recording period (s; None automatic)."""
    if n > len(slots()):
        raise ValueError(f"the bench places at most {len(slots())} vehicles, got {n}")
    lines = [_HEAD.format(n=n, seed=seed, duration=duration)]
    if record_step_s is not None:
        lines.insert(0, f"record_step_s: {record_step_s}\n")
    for i, (x, y, h) in enumerate(slots()[:n]):
        path = f"{{start: [{x}, {y}, {h}], segments: [{{type: line, length_m: {PATH_M}}}]}}"
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
    warm_up = parse_fleet(fleet_text(2, seed, SIM_S_QUICK), "<bench fleet warm-up>")
    run_fleet(build_fleet(warm_up))  # loads or compiles the kernels
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
            progress(k + 1, len(sizes) + 1)
    records.append(shift_memory(quick, seed))
    if progress is not None:
        progress(len(sizes) + 1, len(sizes) + 1)
    return records


def _baseline_growth(samples: list[tuple[float, int]], sim_s: float) -> float:
    """Growth (bytes/s) of the traced memory's floor: its least value over the third quarter of the run and over
    the fourth, apart by a quarter of the run (a step's transient arrays sit on top of the floor, so a
    straight-line fit through the samples measures their noise, not the growth)."""
    q3 = [b for t, b in samples if 0.5 * sim_s <= t < 0.75 * sim_s]
    q4 = [b for t, b in samples if t >= 0.75 * sim_s]
    if not q3 or not q4:
        return 0.0
    return (min(q4) - min(q3)) / (0.25 * sim_s)


#: The shift whose memory is projected: vehicles and simulated time (s).
SHIFT_VEHICLES = 50
SHIFT_S = 8 * 3600.0
#: The shorter run it is projected from: vehicles and simulated time (s), quick and not.
MEMORY_RUN = {True: (5, 30.0), False: (10, 120.0)}


def shift_memory(quick: bool, seed: int) -> dict[str, Any]:
    """Memory of an 8-hour shift of 50 vehicles, projected from a shorter run (module docstring of the row).

    The shorter run records at the shift's automatic rate (:func:`agvnav.sim.fleet.fleet_stride`). What a
    run keeps grows with time: the recorded rows (series and the recorded steps' events: counted in the
    result, bytes per vehicle-hour) and anything else the roles accumulate (:func:`_baseline_growth` of the
    memory traced by ``tracemalloc``; the recorder's blocks are allocated up front, so they are not in it).
    Projection: the process's peak so far (the 50-vehicle row's build included) plus both growths times
    50 vehicles times 8 h.
    """
    n, sim_s = MEMORY_RUN[quick]
    shift = parse_fleet(fleet_text(SHIFT_VEHICLES, seed, SHIFT_S), "<bench fleet shift>")
    stride = fleet_stride(shift, SHIFT_VEHICLES, shift.step_s, SHIFT_S)
    record_s = stride * shift.step_s
    built = build_fleet(parse_fleet(fleet_text(n, seed, sim_s, record_s), "<bench fleet memory>"))
    samples: list[tuple[float, int]] = []
    tracemalloc.start()
    try:
        result = run_fleet(built, progress=lambda t: samples.append((t, tracemalloc.get_traced_memory()[0])))
    finally:
        tracemalloc.stop()
    kept = sum(sum(a.nbytes for a in r.series.values()) + sum(a.nbytes for ev in r.events.values()
                                                               for a in ev.values()) for r in result.results)
    other = _baseline_growth(samples[:-1], sim_s)  # the last sample follows finish()
    recorded_h = kept / (n * sim_s) * 3600.0 / 2**20
    other_h = max(other, 0.0) / n * 3600.0 / 2**20
    base = _peak_mib()
    return {
        "vehicles": SHIFT_VEHICLES,
        "sim_time_s": SHIFT_S,
        "measure": "projected",
        "record_step_s": record_s,
        "recorded_mib_per_vehicle_hour": recorded_h,
        "other_mib_per_vehicle_hour": other_h,
        "peak_mib": base + SHIFT_VEHICLES * SHIFT_S / 3600.0 * (recorded_h + other_h),
        "measured_vehicles": n,
        "measured_sim_s": sim_s,
        "outcome": result.outcome,
    }
