"""``agvnav bench safety``: does the vehicle stop in time for a person crossing, and avoid a pallet in its lane?

Two vehicles at a cruise of 1 m/s (assumptions: an indoor AGV's and an unladen stacker's
speed), braking at 0.5 m/s², positioned by the goniometer and the EKF, with a safety scanner
(270°, 0.5°, 25 Hz, 1 cm noise) in front: the differential AGV of ``safety_person_crossing``
and the seed-000 tricycle stacker (``guidance_test``'s vehicle, tracked point C). They drive
the open floor of the hall (the shipped map ``hall_open``: its outer walls and wall reflectors; the
pillar and the rack removed: the approach fields reach 4.1 m either side of the path at 1 m/s, and a wall inside
them stops the vehicle, as it would a real one). The fields follow the design rule of
:mod:`agvnav.reactive.fields` (ISO 13855 ``S = K T + C``): the strip ``H`` the vehicle sweeps
while it stops (``D = v t_r + v²/(2a) + C = 1.6 m`` long with ``t_r = 0.3 s``, ``C = 0.3 m``,
the body plus 0.1 m wide) widened all round by ``K T`` (``K = 1.6 m/s``,
``T = t_r + v/a = 2.3 s``: 3.68 m).

Cases:

* ``person``: a person (cylinder, radius 0.25 m) steps out (it is not there before; a doorway,
  something the map does not hold) and walks straight across the path at an angle (90°:
  square across; 45°: slanting the vehicle's way; 135°: slanting towards it) and a speed, on
  a collision course: without a reaction the vehicle's front would reach the person as it
  crosses the path's centre line. Where it appears is set by ``ratio``: its edge is
  ``appear_m = ratio x K T`` from the strip ``H`` of the vehicle (at cruise, nominal profile)
  at that instant. **Zone, decided by the design rule from the case geometry before any
  run** (:func:`zone_of`): ``beyond`` (at or beyond the designed stopping distance; target 0
  collisions) when the person appears outside the designed protective field, i.e. walking at
  up to K it needs at least the vehicle's stopping time ``T`` to reach the swept strip
  (``dist(person, H) >= K T``); ``inside`` otherwise (physics may not allow a stop; reported
  separately). A person walking towards the vehicle gets no special treatment: the rule
  covers every direction. The zone is the case's, from the nominal profile; whether the runs kept
  to it is measured: each run records ``dist(person, H) - r`` from the vehicle's **true** pose
  (the strip ``H`` at cruise, as the zone's) when the person appears (:func:`appear_distance_at`;
  the tracking error and the speed profile's discretisation put the vehicle a little ahead of or
  behind the nominal), and each row reports the smallest (``appear_dist_min_m``) and the number
  of runs in which it was below ``K T`` (``runs_below_design``). A ``1.0KT`` case lies on the
  boundary by construction: its runs fall either side of it by millimetres, and a ``beyond``
  row with ``runs_below_design > 0`` had runs that were, strictly, just inside;
* ``lane``: a pallet (1.2 m x 0.8 m) on the path in the right-hand lane of a two-way aisle;
  avoidance allowed on that segment within a corridor 2.0 m left and 0.6 m right of the path;
  the approach field stops the vehicle about 5 m short of the pallet, room to plan the detour
  (planned once its echoes have stood still for 0.5 s); the detour is driven at the slow fraction with the
  creep field set (the stopping-distance rectangle, no approach term: the pallet is passed at
  0.3 m, closer than any approach field allows). Target: avoided, never leaving the corridor
  (``max_corridor_dev_m`` 0).

Records per (model, case) over 20 seeds (2 with ``--quick``): ``collisions``,
``min_clearance_m`` (smallest over the runs), ``stops`` (mean per run), ``avoided`` (runs whose
encounter ended in a detour), ``time_lost_s`` (mean over the completed runs of each run's
completion time minus that of the same run without the obstacle: same seed, obstacle removed; one
baseline run per seed), ``max_corridor_dev_m`` (lane), ``appear_m`` (the person's distance to the
swept strip at appearance, nominal), ``appear_dist_min_m`` and ``runs_below_design`` (the same from
the true pose, see above), ``reach_m`` (``K T``), ``outcomes``. Two summary rows close the table:
every case at/beyond the designed distance, and every case inside it.
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
from numpy.typing import NDArray

from agvnav.reactive import ISO13855_K_M_S, approach_clearance, approach_reach, stopping_distance
from agvnav.sim import simulate
from agvnav.sim.build import build
from agvnav.world.scenario import builtin_scenario, parse_scenario

TITLE = "Reactive safety: people stepping out across the path, a pallet in the lane (truth-judged; issue 18)"

#: Columns a narrow terminal keeps, most important first.
PRIORITY = ("model", "case", "zone", "runs", "collisions", "min_clearance_m", "stops", "avoided", "time_lost_s",
            "max_corridor_dev_m", "appear_m", "appear_dist_min_m", "runs_below_design", "reach_m")

CRUISE_M_S = 1.0
DECEL_M_S2 = 0.5
REACTION_TIME_S = 0.3
MARGIN_M = 0.3
LATERAL_MARGIN_M = 0.1
APPROACH_M_S = ISO13855_K_M_S
PERSON_RADIUS_M = 0.25
#: Path along y = 8 m of the open hall floor; the crossing (or the pallet) at x = 16 m.
PATH_Y_M = 8.0
CROSSING_X_M = 16.0
#: Run-up at cruise before the appearance (m), and path beyond the crossing (m).
RUN_UP_M = 4.0
BEYOND_M = 5.0
#: The person walks on to this far beyond the path's centre line (m), outside every field, and stands.
WALK_ON_M = 6.5
#: Lane case: the pallet at x = 13 m, corridor either side of the path (m), path beyond the pallet (m)
#: (the warning field at cruise, 6.8 m, stays clear of the east wall at x = 30 m at the path's end).
LANE_X_M = 13.0
CORRIDOR = (2.0, 0.6)
LANE_BEYOND_M = 9.0
LANE_WARNING_S = 1.5


@dataclass(frozen=True)
class Model:
    """A bench vehicle: scenario sections, the tracked point's offset ahead of base_link, its body."""

    name: str
    vehicle: dict[str, Any]
    extra: dict[str, Any]
    point_offset: float  # tracked point ahead of base_link (m)
    front: float         # body front ahead of base_link (m)
    half_width: float    # body half-width (m)
    footprint: tuple[tuple[float, float], ...]  # body polygon in base_link (m)


#: The shipped map the bench drives: the hall's open floor (``hall`` without the pillar and the rack).
MAP = "hall_open"


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
    return Model(name, doc["vehicle"], extra, offset, float(np.max(fp[:, 0])), float(np.max(np.abs(fp[:, 1]))),
                 tuple((float(x), float(y)) for x, y in fp))


def design_distance() -> float:
    """The swept strip's length at cruise (m): the stopping distance ``D`` with its margin."""
    return float(stopping_distance(CRUISE_M_S, REACTION_TIME_S, DECEL_M_S2, MARGIN_M))


def design_reach() -> float:
    """``K T`` at cruise (m): how far a person at K walks while the vehicle reacts and brakes."""
    return approach_reach(CRUISE_M_S, REACTION_TIME_S, DECEL_M_S2, APPROACH_M_S)


def _nominal_time(distance: float) -> float:
    """Time (s) for the tracked point to cover ``distance`` m from rest at cruise after the ramp."""
    ramp = CRUISE_M_S**2 / (2.0 * DECEL_M_S2)  # accel equals decel here
    if distance <= ramp:
        return math.sqrt(2.0 * distance / DECEL_M_S2)
    return CRUISE_M_S / DECEL_M_S2 + (distance - ramp) / CRUISE_M_S


def person_cases(quick: bool) -> list[tuple[str, float, float, float]]:
    """``(case name, ratio of K T, angle deg, speed m/s)`` of the crossing cases."""
    ratios = (0.5, 1.0, 1.5) if not quick else (0.5, 1.0)
    kinds = ((90.0, 1.0), (90.0, 1.6), (45.0, 1.2), (135.0, 1.2)) if not quick else ((90.0, 1.2), (135.0, 1.2))
    return [(f"person {a:.0f}deg {u:.1f}m/s at {r:.1f}KT", r, a, u) for r in ratios for a, u in kinds]


def _relative(model: Model, angle_deg: float, speed: float, lead: float) -> NDArray[np.float64]:
    """The person's centre in base_link (m) ``lead`` s before it crosses the centre line (vehicle at cruise)."""
    a = math.radians(angle_deg)
    # base_link when the front touches the person on the centre line, then lead s of cruise earlier
    x_base = CROSSING_X_M - PERSON_RADIUS_M - model.front - CRUISE_M_S * lead
    return np.array([CROSSING_X_M - speed * lead * math.cos(a) - x_base, -speed * lead * math.sin(a)])


def _edge_to_strip(model: Model, p: NDArray[np.float64]) -> float:
    """``dist(p, H) - r`` (m) for a person centred at ``p`` (base_link, m), ``H`` the swept strip at cruise."""
    c = approach_clearance(p, np.asarray(model.footprint), CRUISE_M_S, REACTION_TIME_S, DECEL_M_S2, MARGIN_M,
                           LATERAL_MARGIN_M, APPROACH_M_S)
    return float(c) + design_reach() - PERSON_RADIUS_M


def appear_distance(model: Model, angle_deg: float, speed: float, lead: float) -> float:
    """The person's edge to the swept strip ``H`` (m) ``lead`` s before the crossing: ``dist(p, H) - r``
    (vehicle on the nominal profile)."""
    return _edge_to_strip(model, _relative(model, angle_deg, speed, lead))


def appear_distance_at(model: Model, person_xy: tuple[float, float], pose: tuple[float, float, float]) -> float:
    """The person's edge to the swept strip ``H`` at cruise (m), ``dist(p, H) - r``, the person centred at
    ``person_xy`` (map, m) and the vehicle's base_link at ``pose`` ``(x, y, psi)`` (map, m, rad): the distance
    a run actually had when the person appeared (``pose`` the true one)."""
    x, y, psi = pose
    dx, dy = person_xy[0] - x, person_xy[1] - y
    c, s = math.cos(psi), math.sin(psi)
    return _edge_to_strip(model, np.array([c * dx + s * dy, -s * dx + c * dy]))


def appear_lead(model: Model, angle_deg: float, speed: float, ratio: float) -> float:
    """Time (s) before the crossing at which the person is ``ratio x K T`` from the strip (bisection; the
    distance grows with the lead: the person and the strip move apart along a ray)."""
    target = ratio * design_reach()
    lo, hi = 0.0, 1.0
    while appear_distance(model, angle_deg, speed, hi) < target:
        hi *= 2.0
        if hi > 1e3:
            raise ValueError(f"the person never gets {target} m from the strip")
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if appear_distance(model, angle_deg, speed, mid) < target else (lo, mid)
    return hi


def zone_of(model: Model, angle_deg: float, speed: float, lead: float) -> str:
    """``beyond`` when the person appears outside the designed protective field (a person at up to K needs at
    least the stopping time T to reach the swept strip: ``dist(p, H) - r >= K T``), else ``inside``.
    Decided from the case geometry before any run (see the module docstring)."""
    return "beyond" if appear_distance(model, angle_deg, speed, lead) >= design_reach() - 1e-6 else "inside"


def _base_doc(model: Model, seed: int) -> dict[str, Any]:
    return {
        "name": f"safety_{model.name}", "seed": seed, "step_s": 0.05,
        "vehicle": model.vehicle,
        "traction": {"speed_m_s": CRUISE_M_S, "max_accel_m_s2": DECEL_M_S2, "max_decel_m_s2": DECEL_M_S2},
        "positioning": {"method": "ekf"}, "map": MAP,
        "scanner": {"fov_deg": 270.0, "step_deg": 0.5, "max_range_m": 10.0, "noise_std_m": 0.01, "rate_hz": 25.0},
        **model.extra,
    }


def scenario_doc(model: Model, case: tuple[str, float, float, float] | None, seed: int,
                 obstacle: bool = True) -> dict[str, Any]:
    """The scenario of one run: ``case`` a crossing (name, ratio, angle, speed) or None for the lane."""
    doc = _base_doc(model, seed)
    reactive: dict[str, Any] = {"reaction_time_s": REACTION_TIME_S, "margin_m": MARGIN_M,
                                "lateral_margin_m": LATERAL_MARGIN_M, "approach_speed_m_s": APPROACH_M_S,
                                "resume_after_s": 1.0}
    front = model.front - model.point_offset  # body front ahead of the tracked point
    if case is None:  # the lane: a pallet on the path at the crossing point
        x0 = LANE_X_M - 10.0
        doc["path"] = {"start": [x0, PATH_Y_M, 0.0], "segments": [{"type": "line", "length_m": 10.0 + LANE_BEYOND_M}]}
        if obstacle:
            doc["obstacles"] = [{"id": "pallet", "shape": "box", "length_m": 1.2, "width_m": 0.8,
                                 "position": [LANE_X_M, PATH_Y_M]}]
        reactive.update(avoid_segments=[0], corridor_left_m=CORRIDOR[0], corridor_right_m=CORRIDOR[1],
                        avoid_after_s=0.5, warning_time_s=LANE_WARNING_S, detour_fields="creep")
        doc["duration_s"] = 60.0
        doc["reactive"] = reactive
        return doc
    _, ratio, angle_deg, speed = case
    a = math.radians(angle_deg)
    lead = appear_lead(model, angle_deg, speed, ratio)
    u = np.array([math.cos(a), math.sin(a)])
    cross = np.array([CROSSING_X_M, PATH_Y_M])
    start = cross - speed * lead * u
    end = cross + WALK_ON_M / math.sin(a) * u
    s_appear = CROSSING_X_M - PERSON_RADIUS_M - front - CRUISE_M_S * lead  # the tracked point then
    x0 = min(s_appear - RUN_UP_M - CRUISE_M_S**2 / (2.0 * DECEL_M_S2), CROSSING_X_M - 8.0)
    t_appear = _nominal_time(s_appear - x0)
    doc["path"] = {"start": [x0, PATH_Y_M, 0.0],
                   "segments": [{"type": "line", "length_m": CROSSING_X_M + BEYOND_M - x0}]}
    if obstacle:
        doc["obstacles"] = [{"id": "person", "shape": "cylinder", "radius_m": PERSON_RADIUS_M,
                             "path": [start.tolist(), end.tolist()], "speed_m_s": speed,
                             "start_s": t_appear, "appears_at_start": True}]
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
    appear_true = math.nan
    if case is not None and obstacle:  # the true pose when the person appears, interpolated between steps
        person = doc["obstacles"][0]
        t, t_a = r.series["t"], float(person["start_s"])
        pose = tuple(float(np.interp(t_a, t, r.series[k])) for k in ("x", "y"))
        psi = float(np.interp(t_a, t, np.unwrap(r.series["psi"])))
        appear_true = appear_distance_at(model, (float(person["path"][0][0]), float(person["path"][0][1])),
                                         (pose[0], pose[1], psi))
    return {
        "outcome": r.outcome if r.reason is None else str(r.reason).split(" ")[0],
        "collision": r.reason == "collision",
        "min_clearance_m": float(obs["min_clearance_m"]),
        "result": obs["result"],
        "stops": int(fig.get("stops", 0)),
        "t_end": t_end,
        "completed": r.completed,
        "corridor_dev_m": float(fig.get("max_corridor_excess_m", math.nan)),
        "appear_dist_m": appear_true,
    }


def _task(args: tuple[str, tuple[str, float, float, float] | None, int, bool]) -> dict[str, Any]:
    return run_one(*args)


def _finite(values: list[float]) -> list[float]:
    return [v for v in values if math.isfinite(v)]


def summarise(model: str, case: str, zone: str, appear: float | None, runs: list[dict[str, Any]],
              baselines: list[dict[str, Any]], reach: float | None = None) -> dict[str, Any]:
    """One table row from the runs of one (model, case); ``baselines[i]`` the run of ``runs[i]``'s seed without
    the obstacle (time lost: each completed run's time minus its own baseline's; runs whose baseline did not
    complete are left out)."""
    if len(baselines) != len(runs):
        raise ValueError(f"one baseline per run: {len(runs)} runs, {len(baselines)} baselines")
    clear = _finite([r["min_clearance_m"] for r in runs])
    lost = [r["t_end"] - b["t_end"] for r, b in zip(runs, baselines, strict=True) if r["completed"] and b["completed"]]
    dev = _finite([r["corridor_dev_m"] for r in runs])
    seen = _finite([r.get("appear_dist_m", math.nan) for r in runs])
    return {
        "model": model,
        "case": case,
        "zone": zone,
        "appear_m": appear,
        "appear_dist_min_m": min(seen) if seen else None,
        "runs_below_design": sum(d < reach - 1e-6 for d in seen) if reach is not None and seen else None,
        "reach_m": reach,
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
    rows: list[tuple[str, tuple[str, float, float, float] | None]] = [
        (m, c) for m in models for c in [*person_cases(quick), None]
    ]
    # the zones, from the design rule and the case geometry, before any run
    zones = ["-" if c is None else zone_of(_models()[m], c[2], c[3], appear_lead(_models()[m], c[2], c[3], c[1]))
             for m, c in rows]
    # each run, then the same run without the obstacle (same seed) for its time lost
    tasks = [(m, c, seed + k, obstacle) for obstacle in (True, False) for m, c in rows for k in range(n)]
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
        runs, baselines = results[i * n:(i + 1) * n], base[i * n:(i + 1) * n]
        if c is None:
            out.append(summarise(m, "lane: pallet, avoid", "-", None, runs, baselines))
        else:
            model = _models()[m]
            lead = appear_lead(model, c[2], c[3], c[1])
            out.append(summarise(m, c[0], zones[i], appear_distance(model, c[2], c[3], lead), runs,
                                 baselines, design_reach()))
    return out + summary_rows(out)


def summary_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The closing rows: every crossing at/beyond the designed distance (zone ``beyond``), every one inside it."""
    crossings = [r for r in rows if r["zone"] in ("beyond", "inside")]
    groups = [
        ("ALL at/beyond the designed distance", "beyond", [r for r in crossings if r["zone"] == "beyond"]),
        ("ALL inside the designed distance", "inside", [r for r in crossings if r["zone"] == "inside"]),
    ]
    out = []
    for name, zone, sel in groups:
        clear = [r["min_clearance_m"] for r in sel if r["min_clearance_m"] is not None]
        lost = [r["time_lost_s"] for r in sel if r["time_lost_s"] is not None]
        seen = [r["appear_dist_min_m"] for r in sel if r.get("appear_dist_min_m") is not None]
        out.append({
            "model": "all", "case": name, "zone": zone, "appear_m": None,
            "appear_dist_min_m": min(seen) if seen else None,
            "runs_below_design": sum(r.get("runs_below_design") or 0 for r in sel), "reach_m": None,
            "runs": sum(r["runs"] for r in sel), "collisions": sum(r["collisions"] for r in sel),
            "min_clearance_m": min(clear) if clear else None,
            "stops": float(np.mean([r["stops"] for r in sel])) if sel else None,
            "avoided": sum(r["avoided"] for r in sel),
            "time_lost_s": float(np.mean(lost)) if lost else None, "max_corridor_dev_m": None, "outcomes": "",
        })
    return out
