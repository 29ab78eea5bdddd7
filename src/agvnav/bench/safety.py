"""``agvnav bench safety``: does the vehicle stop in time for a person crossing, and avoid a pallet in its lane?

Two vehicles at a cruise of 1 m/s (assumptions: an indoor AGV's and an unladen stacker's
speed), braking at 0.5 m/s², positioned by the goniometer and the EKF in the hall, with a
safety scanner (270°, 0.5°, 25 Hz, 1 cm noise) in front: the differential AGV of
``safety_person_crossing`` and the seed-000 tricycle stacker (``guidance_test``'s vehicle,
tracked point C). The fields are generated from the stopping distance
``D = v t_r + v²/(2a) + margin`` with ``t_r = 0.3 s`` and a 0.3 m margin: ``D = 1.6 m`` at 1 m/s.

Cases:

* ``person``: a person (cylinder, radius 0.25 m) walks across the straight path at an angle
  (90°: square across; 45°: slanting away from the vehicle; 135°: slanting towards it) and a
  speed; the start time is set so that the person reaches the edge of the protective field's
  width when the gap along the path between the vehicle's front and the person is
  ``appear_m = ratio x D`` (the vehicle driving at cruise on the nominal profile). The case is
  at/beyond its stopping distance (``zone`` ``beyond``, target: 0 collisions) when ``appear_m``
  reaches ``stop_dist_m``: ``D``, plus for a person slanting towards the vehicle the distance it
  walks towards it while the vehicle reacts and brakes (:func:`case_stop_distance`, the
  approach term of ISO 13855); otherwise ``inside``, where physics allows a collision
  (reported separately). A closing row also counts every case appearing at/beyond ``D`` itself;
* ``lane``: a pallet (1.2 m x 0.8 m) on the path in the right-hand lane of a two-way aisle;
  avoidance allowed on that segment within a corridor 2.0 m left and 0.6 m right of the path,
  and a warning field 3 s of cruise long (4.6 m) so that the detour is planned while the vehicle
  slows down (target: avoided, never leaving the corridor: ``max_corridor_dev_m`` 0).

Records per (model, case) over 20 seeds (2 with ``--quick``): ``collisions``,
``min_clearance_m`` (smallest over the runs), ``stops`` (mean per run), ``avoided`` (runs whose
encounter ended in a detour), ``time_lost_s`` (mean completion time minus that of the same
run without the obstacle), ``max_corridor_dev_m`` (lane), ``appear_m`` (the gap at
appearance, nominal), ``outcomes``. Two summary rows close the table: every case at/beyond
the designed distance, and every case inside it.
"""

from __future__ import annotations

import functools
import math
import os
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np
import yaml

from agvnav.reactive import stopping_distance
from agvnav.sim import simulate
from agvnav.sim.build import build
from agvnav.world.scenario import builtin_scenario, parse_scenario

TITLE = "Reactive safety: crossing people and a pallet in the lane (truth-judged; issue 18)"

#: Columns a narrow terminal keeps, most important first.
PRIORITY = ("model", "case", "zone", "runs", "collisions", "min_clearance_m", "stops", "avoided", "time_lost_s",
            "max_corridor_dev_m", "appear_m", "stop_dist_m")

CRUISE_M_S = 1.0
DECEL_M_S2 = 0.5
REACTION_TIME_S = 0.3
MARGIN_M = 0.3
LATERAL_MARGIN_M = 0.1
PERSON_RADIUS_M = 0.25
#: Path along y = 4 m of the hall; the crossing (or the pallet) at x = 16 m.
PATH_Y_M = 4.0
CROSSING_X_M = 16.0
#: Run-up at cruise before the appearance (m), and path beyond the crossing (m).
RUN_UP_M = 4.0
BEYOND_M = 5.0
#: Walking distance of the person before it reaches the field's edge (m).
WALK_IN_M = 2.0
#: Lane case: corridor either side of the path (m), path beyond the pallet (m), and a warning field
#: 3 s of cruise longer than the protective one (4.6 m): room to plan the S-curve while slowing.
CORRIDOR = (2.0, 0.6)
LANE_BEYOND_M = 9.0
LANE_WARNING_S = 3.0


@dataclass(frozen=True)
class Model:
    """A bench vehicle: scenario sections, the tracked point's offset ahead of base_link, its body."""

    name: str
    vehicle: dict[str, Any]
    extra: dict[str, Any]
    point_offset: float  # tracked point ahead of base_link (m)
    front: float         # body front ahead of base_link (m)
    half_width: float    # body half-width (m)


@functools.lru_cache(maxsize=1)
def _models() -> dict[str, Model]:
    diff = yaml.safe_load(builtin_scenario("safety_person_crossing").read_text(encoding="utf-8"))
    tri = yaml.safe_load(builtin_scenario("guidance_test").read_text(encoding="utf-8"))
    L = float(tri["vehicle"]["wheelbase_m"])
    tri_extra = {"goniometer": tri["goniometer"],
                 "controller": {"name": "seed_simple", "point": "C", "poles_per_m": [-3.0, -3.0]}}
    return {
        "differential": _model("differential", diff, {"goniometer": diff["goniometer"]}, 0.0),
        "tricycle": _model("tricycle", tri, tri_extra, L),  # tracked point C, L ahead of O
    }


def _model(name: str, doc: dict[str, Any], extra: dict[str, Any], offset: float) -> Model:
    """A bench model, its body front and half-width read from the built plant's footprint."""
    fp = build(parse_scenario(yaml.safe_dump(doc, sort_keys=False), name)).plant.footprint
    return Model(name, doc["vehicle"], extra, offset, float(np.max(fp[:, 0])), float(np.max(np.abs(fp[:, 1]))))


def design_distance() -> float:
    """The protective field's reach at cruise (m): the designed stopping distance."""
    return float(stopping_distance(CRUISE_M_S, REACTION_TIME_S, DECEL_M_S2, MARGIN_M))


def case_stop_distance(angle_deg: float, speed: float) -> float:
    """Stopping distance (m) against a person crossing at ``angle_deg`` and ``speed`` (m/s).

    ``D`` plus the distance the person walks towards the vehicle while it reacts and brakes,
    ``u_a (t_r + v/a)`` with ``u_a = max(0, -u cos(angle))`` (the approach-speed term of ISO 13855's
    ``S = K T + C``): a person slanting towards the vehicle (135°) closes the gap while it stops;
    one walking square across (90°) or away (45°) does not.
    """
    approach = max(0.0, -speed * math.cos(math.radians(angle_deg)))
    return design_distance() + approach * (REACTION_TIME_S + CRUISE_M_S / DECEL_M_S2)


def _nominal_time(distance: float) -> float:
    """Time (s) for the tracked point to cover ``distance`` m from rest at cruise after the ramp."""
    ramp = CRUISE_M_S**2 / (2.0 * DECEL_M_S2)  # accel equals decel here
    if distance <= ramp:
        return math.sqrt(2.0 * distance / DECEL_M_S2)
    return CRUISE_M_S / DECEL_M_S2 + (distance - ramp) / CRUISE_M_S


def person_cases(quick: bool) -> list[tuple[str, float, float, float]]:
    """``(case name, ratio of D, angle deg, speed m/s)`` of the crossing cases."""
    ratios = (0.5, 1.0, 1.5) if not quick else (0.5, 1.0)
    kinds = ((90.0, 1.0), (90.0, 1.6), (45.0, 1.2), (135.0, 1.2)) if not quick else ((90.0, 1.2),)
    return [(f"person {a:.0f}deg {u:.1f}m/s at {r:.1f}D", r, a, u) for r in ratios for a, u in kinds]


def scenario_doc(model: Model, case: tuple[str, float, float, float] | None, seed: int,
                 obstacle: bool = True) -> dict[str, Any]:
    """The scenario of one run: ``case`` a crossing (name, ratio, angle, speed) or None for the lane."""
    D = design_distance()
    doc: dict[str, Any] = {
        "name": f"safety_{model.name}", "seed": seed, "step_s": 0.05,
        "vehicle": model.vehicle,
        "traction": {"speed_m_s": CRUISE_M_S, "max_accel_m_s2": DECEL_M_S2, "max_decel_m_s2": DECEL_M_S2},
        "positioning": {"method": "ekf"}, "map": "hall",
        "scanner": {"fov_deg": 270.0, "step_deg": 0.5, "max_range_m": 10.0, "noise_std_m": 0.01, "rate_hz": 25.0},
        **model.extra,
    }
    reactive: dict[str, Any] = {"reaction_time_s": REACTION_TIME_S, "margin_m": MARGIN_M,
                                "lateral_margin_m": LATERAL_MARGIN_M, "resume_after_s": 1.0}
    front = model.front - model.point_offset  # body front ahead of the tracked point
    if case is None:  # the lane: a pallet on the path at the crossing point
        x0 = CROSSING_X_M - 10.0
        doc["path"] = {"start": [x0, PATH_Y_M, 0.0], "segments": [{"type": "line", "length_m": 10.0 + LANE_BEYOND_M}]}
        if obstacle:
            doc["obstacles"] = [{"id": "pallet", "shape": "box", "length_m": 1.2, "width_m": 0.8,
                                 "position": [CROSSING_X_M, PATH_Y_M]}]
        reactive.update(avoid_segments=[0], corridor_left_m=CORRIDOR[0], corridor_right_m=CORRIDOR[1],
                        avoid_after_s=0.5, warning_time_s=LANE_WARNING_S)
        doc["duration_s"] = 60.0
        doc["reactive"] = reactive
        return doc
    _, ratio, angle_deg, speed = case
    a = math.radians(angle_deg)
    lateral = model.half_width + LATERAL_MARGIN_M + PERSON_RADIUS_M  # the person's centre at the field's edge
    x_entry = CROSSING_X_M - lateral / math.tan(a)  # along the path where it gets there
    gap = ratio * D
    s_appear = x_entry - PERSON_RADIUS_M - gap - front  # the tracked point when the person appears
    x0 = min(s_appear - RUN_UP_M - CRUISE_M_S**2 / (2.0 * DECEL_M_S2), CROSSING_X_M - 8.0)
    t_appear = _nominal_time(s_appear - x0)
    u = np.array([math.cos(a), math.sin(a)])
    entry = np.array([x_entry, PATH_Y_M - lateral])
    start = entry - WALK_IN_M * u
    end = entry + (2.0 * lateral + 3.0) / math.sin(a) * u
    doc["path"] = {"start": [x0, PATH_Y_M, 0.0],
                   "segments": [{"type": "line", "length_m": CROSSING_X_M + BEYOND_M - x0}]}
    if obstacle:
        doc["obstacles"] = [{"id": "person", "shape": "cylinder", "radius_m": PERSON_RADIUS_M,
                             "path": [start.tolist(), end.tolist()], "speed_m_s": speed,
                             "start_s": max(t_appear - WALK_IN_M / speed, 0.0)}]
    doc["duration_s"] = _nominal_time(CROSSING_X_M + BEYOND_M - x0) + 30.0
    doc["reactive"] = reactive
    return doc


def run_one(model_name: str, case: tuple[str, float, float, float] | None, seed: int,
            obstacle: bool = True) -> dict[str, Any]:
    """One seeded run: a flat record of its outcome and reactive figures."""
    model = _models()[model_name]
    doc = scenario_doc(model, case, seed, obstacle)
    r = simulate(parse_scenario(yaml.safe_dump(doc, sort_keys=False), source=f"safety_{model_name}"))
    fig = r.reactive
    obs: dict[str, Any] = {"min_clearance_m": math.nan, "result": "none"}
    if fig.get("obstacles"):
        obs = next(iter(fig["obstacles"].values()))
    t_end = float(r.series["t"][-1]) - (r.scenario.end_hold_s if r.completed else 0.0)
    return {
        "outcome": r.outcome if r.reason is None else str(r.reason).split(" ")[0],
        "collision": r.reason == "collision",
        "min_clearance_m": float(obs["min_clearance_m"]),
        "result": obs["result"],
        "stops": int(fig.get("stops", 0)),
        "t_end": t_end,
        "completed": r.completed,
        "corridor_dev_m": float(fig.get("max_corridor_excess_m", math.nan)),
    }


def _task(args: tuple[str, tuple[str, float, float, float] | None, int, bool]) -> dict[str, Any]:
    return run_one(*args)


def _finite(values: list[float]) -> list[float]:
    return [v for v in values if math.isfinite(v)]


def summarise(model: str, case: str, zone: str, appear: float | None, runs: list[dict[str, Any]],
              baseline: float, stop: float | None = None) -> dict[str, Any]:
    """One table row from the runs of one (model, case); ``baseline`` the completion time without the obstacle."""
    clear = _finite([r["min_clearance_m"] for r in runs])
    lost = [r["t_end"] - baseline for r in runs if r["completed"]]
    dev = _finite([r["corridor_dev_m"] for r in runs])
    return {
        "model": model,
        "case": case,
        "zone": zone,
        "appear_m": appear,
        "stop_dist_m": stop,
        "runs": len(runs),
        "collisions": sum(r["collision"] for r in runs),
        "min_clearance_m": min(clear) if clear else None,
        "stops": float(np.mean([r["stops"] for r in runs])),
        "avoided": sum(r["result"] == "avoid" for r in runs),
        "time_lost_s": float(np.mean(lost)) if lost else None,
        "max_corridor_dev_m": max(dev) if dev else None,
        "outcomes": ", ".join(f"{k} {v}" for k, v in sorted(Counter(r["outcome"] for r in runs).items())),
    }


def run(quick: bool = False, seed: int = 0, progress: Callable[[int, int], None] | None = None) -> list[dict[str, Any]]:
    """One record per (model, case) over 20 seeds (2 with ``quick``) from ``seed`` on, then the two summaries."""
    n = 2 if quick else 20
    models = list(_models())
    D = design_distance()
    rows: list[tuple[str, tuple[str, float, float, float] | None]] = [
        (m, c) for m in models for c in [*person_cases(quick), None]
    ]
    tasks = [(m, c, seed + k, True) for m, c in rows for k in range(n)] + [(m, c, seed, False) for m, c in rows]
    workers = max(1, min(len(tasks), os.cpu_count() or 1))
    results: list[dict[str, Any]] = []
    if workers > 1:
        with ProcessPoolExecutor(workers) as pool:
            for i, res in enumerate(pool.map(_task, tasks, chunksize=1)):
                results.append(res)
                if progress is not None:
                    progress(i + 1, len(tasks))
    else:
        for i, t in enumerate(tasks):
            results.append(_task(t))
            if progress is not None:
                progress(i + 1, len(tasks))
    base = results[len(rows) * n:]
    out = []
    for i, (m, c) in enumerate(rows):
        runs = results[i * n:(i + 1) * n]
        if c is None:
            out.append(summarise(m, "lane: pallet, avoid", "-", None, runs, base[i]["t_end"]))
        else:
            stop = case_stop_distance(c[2], c[3])
            zone = "beyond" if c[1] * D >= stop - 1e-9 else "inside"
            out.append(summarise(m, c[0], zone, c[1] * D, runs, base[i]["t_end"], stop))
    return out + summary_rows(out)


def summary_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The closing rows: every crossing at/beyond its stopping distance, every one inside it, and (for
    transparency) every one at/beyond the static design distance ``D`` whatever the person's approach."""
    D = design_distance()
    crossings = [r for r in rows if r["zone"] in ("beyond", "inside")]
    groups = [
        ("ALL at/beyond their stopping distance", "beyond", [r for r in crossings if r["zone"] == "beyond"]),
        ("ALL inside their stopping distance", "inside", [r for r in crossings if r["zone"] == "inside"]),
        (f"ALL appearing at/beyond D = {D:.2f} m", "static", [r for r in crossings if r["appear_m"] >= D - 1e-9]),
    ]
    out = []
    for name, zone, sel in groups:
        clear = [r["min_clearance_m"] for r in sel if r["min_clearance_m"] is not None]
        out.append({
            "model": "all", "case": name, "zone": zone, "appear_m": None, "stop_dist_m": None,
            "runs": sum(r["runs"] for r in sel), "collisions": sum(r["collisions"] for r in sel),
            "min_clearance_m": min(clear) if clear else None,
            "stops": float(np.mean([r["stops"] for r in sel])) if sel else None, "avoided": 0,
            "time_lost_s": None, "max_corridor_dev_m": None, "outcomes": "",
        })
    return out
