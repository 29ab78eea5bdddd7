"""Reflector mapping (issue 17): a commissioning drive per hall and seed, every anchor kind.

The drive is a shipped scenario simulated with clutter (``goniometer.spurious_rate_hz``
spurious reflections per second) and the real reflectors exactly where the map says
(``world_truth.reflector_survey_std_m = 0``): the lab (``positioning_validation``, 9
reflectors) and the hall (``differential_loop``, 14 reflectors). The warehouse's map
comes from the layout planner and has no shipped driving scenario: not benchmarked here.

Anchors, each drawn with its stated error from the seed: ``surveyed2`` (the two reflectors
farthest apart, surveyed with 1 mm std per axis), ``baseline`` (the same two, taped to 1 mm,
named by positions 10 cm off), ``start_pose`` (the true start pose with 1 mm / 0.05° std and
the odometry scale 1 ± 0.2 %), ``none`` (the command refuses: "unobservable").

Records: ``reflectors_found`` counts true reflectors with a mapped one within 0.25 m;
``spurious_created`` mapped ones with no true reflector within 0.25 m; ``map_rms_m`` and
``map_max_m`` over the found ones, in the map frame (no alignment: the anchor defines the
frame); ``nees_mean`` the mean of ``eᵀC⁻¹e`` over reflectors (2 expected) with its 95 % band
from chi-square with 2n dof divided by n; positioning RMS of the EKF replaying the same drive
with the mapped map and with the true map.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from scipy.stats import chi2

from agvnav.campaign.overrides import apply_overrides, dump_yaml, load_base
from agvnav.logs import RecordedLog, estimator_from_settings, localize, positioning_settings
from agvnav.mapping import (
    BaselineAnchor,
    MappingOptions,
    ScaleUnobservable,
    StartPoseAnchor,
    SurveyedAnchor,
    front_end,
    result_to_map,
    solve_anchored,
)
from agvnav.mapping.anchors import Anchor
from agvnav.sim.run import SimResult, simulate
from agvnav.world import WorldMap
from agvnav.world.scenario import parse_scenario

__all__ = ["HALLS", "TITLE", "log_from_result", "run"]

TITLE = "Reflector mapping: reflectors found, spurious, map error and NEES per anchor; positioning on the mapped map"

#: hall name -> shipped scenario driven as the commissioning drive.
HALLS = {"lab": "positioning_validation", "hall": "tricycle_rear_loop"}

#: Spurious reflections per second during the commissioning drive.
CLUTTER_HZ = 1.0

MATCH_M = 0.25


def log_from_result(result: SimResult) -> RecordedLog:
    """The drive of a simulated run as a :class:`RecordedLog` (what ``agvnav simulate --log`` records)."""
    s = result.series
    n = s["t"].shape[0]
    inc = np.column_stack([s.get(c, np.zeros(n)) for c in ("odo_dd", "odo_dtheta", "odo_dlat")])[1:]
    ev = result.events.get("reflections", {})
    t = np.asarray(ev.get("t", np.zeros(0)), dtype=np.float64)
    return RecordedLog(s["t"].copy(), inc, t.copy(), np.asarray(ev.get("stamp", t), dtype=np.float64).copy(),
                       np.asarray(ev.get("bearing", np.zeros(0)), dtype=np.float64).copy(),
                       positioning_settings(result.scenario, s), truth=np.column_stack([s["x"], s["y"], s["psi"]]))


def _drive(scenario: str, seed: int) -> SimResult:
    base = load_base(scenario)
    mapping = apply_overrides(base.mapping, {"world_truth.reflector_survey_std_m": 0.0,
                                             "goniometer.spurious_rate_hz": CLUTTER_HZ, "seed": int(seed)})
    return simulate(parse_scenario(dump_yaml(mapping), source=scenario, base_dir=base.base_dir))


def _anchors(world: WorldMap, start: np.ndarray, rng: np.random.Generator) -> dict[str, Anchor | None]:
    xy = world.reflector_xy
    d = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    i, j = np.unravel_index(int(np.argmax(d)), d.shape)
    surveyed = SurveyedAnchor((world.reflector_ids[i], world.reflector_ids[j]),
                              xy[[i, j]] + rng.normal(0.0, 0.001, (2, 2)), np.array([0.001, 0.001]))
    off = np.array([0.1, -0.1])
    baseline = BaselineAnchor(tuple((xy[i] + off).tolist()), tuple((xy[j] - off).tolist()),
                              float(d[i, j] + rng.normal(0.0, 0.001)), 0.001)
    sp = StartPoseAnchor()
    pose = start + rng.normal(0.0, 1.0, 3) * np.array(sp.pose_std)
    return {"surveyed2": surveyed, "baseline": baseline,
            "start_pose": StartPoseAnchor(tuple(pose.tolist()), sp.pose_std, 1.0, sp.scale_std), "none": None}


def _positioning_rms(log: RecordedLog, world: WorldMap) -> float | None:
    assert log.truth is not None
    loc = localize(log, estimator_from_settings(log.settings, world, "ekf"))
    err = np.hypot(loc.series["est_x"] - log.truth[:, 0], loc.series["est_y"] - log.truth[:, 1])
    ok = np.isfinite(err)
    return float(np.sqrt(np.mean(err[ok] ** 2))) if np.any(ok) else None


def _record(hall: str, seed: int, with_positioning: bool) -> list[dict[str, Any]]:
    t0 = time.perf_counter()
    result = _drive(HALLS[hall], seed)
    sim_s = time.perf_counter() - t0
    log = log_from_result(result)
    assert log.truth is not None
    world = result.world
    true = world.reflector_xy
    rng = np.random.default_rng([seed, 17])
    start = log.truth[0].copy()
    opt = MappingOptions()
    fe = front_end(log, start, opt)
    rms_true = _positioning_rms(log, world) if with_positioning else None
    spurious_in = int(np.sum(np.asarray(result.events["reflections"]["reflector_index"]) < 0))
    rows = []
    for name, anchor in _anchors(world, start, rng).items():
        rec: dict[str, Any] = {"hall": hall, "seed": seed, "anchor": name, "reflectors_true": int(true.shape[0])}
        t1 = time.perf_counter()
        try:
            res = solve_anchored(fe, [] if anchor is None else [anchor], None, opt, start)
        except ScaleUnobservable:
            rec.update(reflectors_found="unobservable", spurious_created=None, map_rms_m=None, map_max_m=None,
                       nees_mean=None, nees_band=None, runtime_s=round(time.perf_counter() - t1, 3))
            rows.append(rec)
            continue
        d = np.hypot(*(res.xy[:, None, :] - true[None]).transpose(2, 0, 1))
        nearest, dist = np.argmin(d, axis=1), np.min(d, axis=1)
        ok = dist < MATCH_M
        err = res.xy[ok] - true[nearest[ok]]
        nees = np.array([e @ np.linalg.solve(c, e) for e, c in zip(err, res.covariance[ok], strict=True)])
        n = max(int(ok.sum()), 1)
        lo, hi = chi2.ppf(0.025, 2 * n) / n, chi2.ppf(0.975, 2 * n) / n
        rec.update(
            reflectors_found=len(set(nearest[ok].tolist())),
            spurious_created=int((~ok).sum()),
            map_rms_m=float(np.sqrt(np.mean(np.sum(err ** 2, axis=1)))) if ok.any() else None,
            map_max_m=float(dist[ok].max()) if ok.any() else None,
            nees_mean=float(nees.mean()) if nees.size else None,
            nees_band=f"{lo:.2f}-{hi:.2f}",
            odometry_scale=round(res.scale, 5),
            runtime_s=round(fe.runtime_s + time.perf_counter() - t1, 2),
        )
        if with_positioning:
            rms_mapped = _positioning_rms(log, result_to_map(res, opt.radius, world))
            rec.update(positioning_rms_mapped_m=rms_mapped, positioning_rms_true_m=rms_true,
                       positioning_ratio=(round(rms_mapped / rms_true, 3)
                                          if rms_mapped is not None and rms_true else None))
        rec.update(spurious_reflections=spurious_in, sim_s=round(sim_s, 1))
        rows.append(rec)
    return rows


def _summary(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    out = []
    for hall in dict.fromkeys(r["hall"] for r in rows):
        for anchor in dict.fromkeys(r["anchor"] for r in rows):
            rs = [r for r in rows if r["hall"] == hall and r["anchor"] == anchor]
            if not rs:
                continue
            if anchor == "none":
                out.append({"hall": hall, "seed": f"all {len(rs)}", "anchor": anchor,
                            "reflectors_true": rs[0]["reflectors_true"],
                            "reflectors_found": "unobservable" if all(r["reflectors_found"] == "unobservable"
                                                                      for r in rs) else "MAPPED"})
                continue
            n = sum(r["reflectors_true"] for r in rs)
            nees = [r["nees_mean"] for r in rs if r["nees_mean"] is not None]
            k = sum(r["reflectors_found"] for r in rs)
            lo, hi = chi2.ppf(0.025, 2 * k) / k, chi2.ppf(0.975, 2 * k) / k
            rms = [r["map_rms_m"] for r in rs if r["map_rms_m"] is not None]
            ratio = [float(r["positioning_ratio"]) for r in rs if r.get("positioning_ratio") is not None]
            out.append({
                "hall": hall, "seed": f"all {len(rs)}", "anchor": anchor, "reflectors_true": n,
                "reflectors_found": k, "spurious_created": sum(r["spurious_created"] for r in rs),
                "map_rms_m": float(np.sqrt(np.mean(np.square(rms)))) if rms else None,
                "map_max_m": max(r["map_max_m"] for r in rs if r["map_max_m"] is not None),
                "nees_mean": float(np.mean(nees)) if nees else None, "nees_band": f"{lo:.2f}-{hi:.2f}",
                "runtime_s": round(float(np.mean([r["runtime_s"] for r in rs])), 2),
                "positioning_ratio": round(float(np.mean(ratio)), 3) if ratio else None,
            })
    return out


def run(quick: bool, seed: int) -> list[dict[str, Any]]:
    """Per hall, seed and anchor one record, then one summary record per hall and anchor.

    ``quick``: 2 seeds per hall; else 10.
    """
    seeds = [seed + k for k in range(2 if quick else 10)]
    rows: list[dict[str, Any]] = []
    for hall in HALLS:
        for s in seeds:
            rows += _record(hall, s, with_positioning=True)
    for r in rows:
        for key in ("map_rms_m", "map_max_m", "nees_mean", "positioning_rms_mapped_m", "positioning_rms_true_m"):
            if isinstance(r.get(key), float):
                r[key] = float(f"{r[key]:.3g}") if math.isfinite(r[key]) else None
    return rows + _summary(rows)
