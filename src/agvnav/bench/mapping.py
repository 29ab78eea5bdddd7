"""Reflector mapping (issue 17): a commissioning drive per hall and seed, every anchor kind.

The drive is a shipped scenario simulated with clutter (``goniometer.spurious_rate_hz``
spurious reflections per second) and the real reflectors exactly where the map says
(``world_truth.reflector_survey_std_m = 0``): the lab (``positioning_validation``, 9
reflectors, tricycle), the hall (``tricycle_rear_loop``, 14 reflectors, rear-drive tow tractor),
the hall with the differential AGV (``differential_loop``: 1 % track and 0.2 % wheel errors) and
the warehouse (``warehouse_mission``, 102 reflectors, racks occlude; the mission through aisles
B and A, the north lane, the charger and the dock is its commissioning drive).

Anchors, each drawn with its stated error: ``surveyed2`` (the two reflectors
farthest apart, surveyed with 1 mm std per axis), ``baseline`` (the same two, taped to 1 mm,
named by positions 10 cm off), ``start_pose`` (the true start pose with 1 mm / 0.05° std and
the odometry scale of a taped calibration run, :func:`calibrated_scale`), ``none`` (the command
refuses: "unobservable").

Records: ``reflectors_seen`` counts the true reflectors with at least ``min_sightings``
reflections in the drive (the hall's N2 and N3 sit behind the rack from the loop: never seen),
``not_seen`` names the others and ``seen_not_found`` the seen ones the map lacks;
``reflectors_found`` counts true reflectors with a mapped one within 0.25 m;
``spurious_created`` mapped ones with no true reflector within 0.25 m; ``map_rms_m`` and
``map_max_m`` over the found ones, in the map frame (no alignment: the anchor defines the
frame); ``map_rms_predicted_m`` what the map's own covariances predict for ``map_rms_m`` (``√mean tr C_j``: what
the drive supports); ``anchor_chi2`` the anchor's drawn errors against their stated std (:func:`_anchor_chi2`;
the summary sums them with the 95 % band of their chi-square, ``anchor_chi2_band``: the seeds' anchors may be
a good or a bad sample);
``nees_mean`` the mean of ``eᵀC⁻¹e`` over reflectors, each against its own covariance (2 expected);
its 95 % band counts that the reflectors of one map share the anchor's and the trajectory's errors
(:func:`marginal_band`: a chi-square with 2n dof would be far too narrow); ``nees_joint`` the NEES of
all reflectors together against their joint covariance, per reflector (2 expected), whose band
``chi2(2n)/n`` is exact and pools over runs (:func:`joint_band`); the summary pools runs.
``positioning_ratio``: position RMS of the EKF replaying the same drive (same seed, log and settings) on the
mapped map over its RMS on the true map; each map tells the EKF its own survey std and nothing else
(``map_std_m = 0``: the true map is exact, the mapped one states each reflector's frame-free std,
:mod:`agvnav.mapping.output`). ``frame_error_m``: the RMS move of the similarity that fits the mapped
reflectors onto the true ones (the anchor's frame error, shared by every reflector: no positioning filter
removes it); ``positioning_ratio_frame_free``: the ratio with the mapped map moved by that similarity,
what the mapping's own relative errors cost.
``--quick``: 2 seeds and no warehouse (its drive takes minutes); the full run gives the warehouse
``SLOW_SEEDS`` seeds. Positioning is replayed with the surveyed2 and baseline maps (the start-pose map's
frame is the start pose's, centimetres off the site's).
"""

from __future__ import annotations

import math
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from typing import Any

import numpy as np
from scipy.stats import chi2

from agvnav.campaign.overrides import apply_overrides, dump_yaml, load_base
from agvnav.geometry import wrap_angle_scalar
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
from agvnav.mapping.anchors import Anchor, apply_similarity, fit_similarity
from agvnav.sim.run import SimResult, simulate
from agvnav.world import WorldMap
from agvnav.world.scenario import parse_scenario

__all__ = ["HALLS", "TITLE", "joint_band", "log_from_result", "marginal_band", "nees_statistics", "run"]

TITLE = "Reflector mapping: reflectors found, spurious, map error and NEES per anchor; positioning on the mapped map"

#: hall name -> shipped scenario driven as the commissioning drive.
HALLS = {"lab": "positioning_validation", "hall": "tricycle_rear_loop", "hall_differential": "differential_loop",
         "warehouse": "warehouse_mission"}

#: anchors whose map is replayed by the EKF for the positioning ratio.
POSITIONING_ANCHORS = ("surveyed2", "baseline")

#: worker processes over the (hall, seed) drives (at most the CPU count).
WORKERS = 2

#: halls left out of ``--quick``, and run with only ``SLOW_SEEDS`` seeds in the full benchmark: one
#: warehouse drive (406 s, 44 000 reflections, 102 reflectors) takes about 10 CPU-minutes to simulate,
#: map with three anchors (a keyframe per odometry instant, the in-step noise blocks) and replay (a
#: runtime limit, stated in the table, not a result).
SLOW_HALLS = ("warehouse",)
SLOW_SEEDS = 2

#: Spurious reflections per second during the commissioning drive.
CLUTTER_HZ = 1.0

MATCH_M = 0.25

#: Calibration run: tape std per mark (m), wheel slip (m per √m, assumption), longest run (m).
TAPE_STD_M = 0.001
SLIP_STD = 0.01
CAL_MAX_M = 10.0


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


def calibrated_scale(log: RecordedLog, rng: np.random.Generator, tape_std: float = TAPE_STD_M,
                     slip_std: float = SLIP_STD) -> tuple[float, float, float]:
    """The odometry scale from a taped calibration run: ``(scale, std, length_m)``.

    The run is the drive's first straight (odometry heading within 0.5° of the start, at most
    ``CAL_MAX_M``): the distance between its end marks is taped (``tape_std`` m per mark, from the
    true positions) and divided by the odometry's distance over it. The std combines the tape and
    the wheel slip over the run (``slip_std`` m per √m, an assumption: the shipped vehicles' 1 cm).
    A drive that starts with less than 1 m straight gets the uncalibrated ``1 ± 0.2 %``.
    The scale comes from the run's measurement, never from the simulator's truth parameters.
    """
    assert log.truth is not None
    heading = np.concatenate([[0.0], np.cumsum(log.increments[:, 1])])
    rolled = np.concatenate([[0.0], np.cumsum(np.abs(log.increments[:, 0]))])
    straight = (np.abs(heading) < math.radians(0.5)) & (rolled <= CAL_MAX_M)
    n = int(np.argmin(straight)) if not straight.all() else straight.size
    end = max(n - 1, 0)
    odo = float(np.sum(log.increments[:end, 0]))
    if odo < 1.0:
        return 1.0, 0.002, 0.0
    taped = float(np.hypot(*(log.truth[end, :2] - log.truth[0, :2]))) + float(rng.normal(0.0, tape_std * math.sqrt(2)))
    std = math.hypot(tape_std * math.sqrt(2.0), slip_std * math.sqrt(odo)) / odo
    return taped / odo, std, odo


def _anchors(world: WorldMap, start: np.ndarray, rng: np.random.Generator,
             scale: tuple[float, float] = (1.0, 0.002), seen: np.ndarray | None = None) -> dict[str, Anchor | None]:
    """The anchors of one run; ``seen (N,)``: the reflectors the drive sees (the surveyed pair is the farthest
    apart among them: a site surveys reflectors its commissioning drive passes)."""
    xy = world.reflector_xy
    d = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    if seen is not None and int(np.sum(seen)) >= 2:
        d = np.where(seen[:, None] & seen[None, :], d, -1.0)
    i, j = np.unravel_index(int(np.argmax(d)), d.shape)
    surveyed = SurveyedAnchor((world.reflector_ids[i], world.reflector_ids[j]),
                              xy[[i, j]] + rng.normal(0.0, 0.001, (2, 2)), np.array([0.001, 0.001]))
    off = np.array([0.1, -0.1])
    baseline = BaselineAnchor(tuple((xy[i] + off).tolist()), tuple((xy[j] - off).tolist()),
                              float(d[i, j] + rng.normal(0.0, 0.001)), 0.001)
    sp = StartPoseAnchor()
    pose = start + rng.normal(0.0, 1.0, 3) * np.array(sp.pose_std)
    return {"surveyed2": surveyed, "baseline": baseline,
            "start_pose": StartPoseAnchor(tuple(pose.tolist()), sp.pose_std, scale[0], scale[1]), "none": None}


def _positioning_rms(log: RecordedLog, world: WorldMap) -> float | None:
    """Position RMS (m) of the EKF replaying ``log`` on ``world``, told the map's own ``survey_std_m`` and
    nothing else (``map_std_m = 0``): the exact map is told it is exact, a mapped one its stated errors."""
    assert log.truth is not None
    loc = localize(log, estimator_from_settings({**log.settings, "map_std_m": 0.0}, world, "ekf"))
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
    index = np.asarray(result.events["reflections"]["reflector_index"]).astype(np.int64)
    spurious_in = int(np.sum(index < 0))
    seen_mask = np.bincount(index[index >= 0], minlength=true.shape[0]) >= opt.init.min_sightings
    seen = int(np.sum(seen_mask))
    rows = []
    cal = calibrated_scale(log, np.random.default_rng([seed, 171]))
    for name, anchor in _anchors(world, start, rng, cal[:2], seen_mask).items():
        rec: dict[str, Any] = {"hall": hall, "seed": seed, "anchor": name, "reflectors_true": int(true.shape[0]),
                               "reflectors_seen": seen}
        t1 = time.perf_counter()
        try:
            res = solve_anchored(fe, [] if anchor is None else [anchor], None, opt, start)
        except ScaleUnobservable:
            rec.update(reflectors_found="unobservable", spurious_created=None, map_rms_m=None, map_max_m=None,
                       nees_mean=None, nees_band=None, runtime_s=round(time.perf_counter() - t1, 3))
            rows.append(rec)
            continue
        except ValueError as exc:  # an anchor that matches no mapped reflector: a failed run, recorded
            rec.update(reflectors_found=0, spurious_created=0, map_rms_m=None, map_max_m=None, nees_mean=None,
                       nees_band=None, error=str(exc), runtime_s=round(time.perf_counter() - t1, 3))
            rows.append(rec)
            continue
        d = np.hypot(*(res.xy[:, None, :] - true[None]).transpose(2, 0, 1))
        nearest, dist = np.argmin(d, axis=1), np.min(d, axis=1)
        ok = dist < MATCH_M
        err = res.xy[ok] - true[nearest[ok]]
        nees = np.array([e @ np.linalg.solve(c, e) for e, c in zip(err, res.covariance[ok], strict=True)])
        n = max(int(ok.sum()), 1)
        consistency = nees_statistics(err, res.joint_covariance, np.flatnonzero(ok)) if ok.any() else {}
        rec.update(consistency)
        found_idx = set(nearest[ok].tolist())
        rec.update(
            seen_not_found=[world.reflector_ids[j] for j in np.flatnonzero(seen_mask) if j not in found_idx],
            not_seen=[world.reflector_ids[j] for j in np.flatnonzero(~seen_mask)],
            reflectors_found=len(found_idx),
            spurious_created=int((~ok).sum()),
            map_rms_m=float(np.sqrt(np.mean(np.sum(err ** 2, axis=1)))) if ok.any() else None,
            map_max_m=float(dist[ok].max()) if ok.any() else None,
            map_rms_predicted_m=float(np.sqrt(np.mean(np.trace(res.covariance[ok], axis1=1, axis2=2))))
            if ok.any() else None,
            **_anchor_chi2(anchor, world),
            nees_mean=float(nees.mean()) if nees.size else None,
            nees_band=_band(*marginal_band(2.0 * n, consistency["nees_sum_sq"], n)) if ok.any() else None,
            odometry_scale=round(res.scale, 5),
            calibrated_scale=round(cal[0], 5) if name == "start_pose" else None,
            heading_rate=round(res.heading_rate, 5),
            runtime_s=round(fe.runtime_s + time.perf_counter() - t1, 2),
        )
        if with_positioning and name in POSITIONING_ANCHORS:
            mapped = result_to_map(res, opt.radius, world)
            rms_mapped = _positioning_rms(log, mapped)
            # the same map with its frame's error removed (moved by the similarity that fits it onto the truth):
            # what the mapping's relative errors alone cost; the rest is the anchor's frame error
            T = fit_similarity(res.xy[ok], true[nearest[ok]]) if int(ok.sum()) >= 2 else None
            rms_free = _positioning_rms(log, _moved(mapped, T)) if T is not None else None
            rec.update(positioning_rms_mapped_m=rms_mapped, positioning_rms_true_m=rms_true,
                       positioning_ratio=(round(rms_mapped / rms_true, 3)
                                          if rms_mapped is not None and rms_true else None),
                       positioning_ratio_frame_free=(round(rms_free / rms_true, 3)
                                                     if rms_free is not None and rms_true else None),
                       frame_error_m=_frame_error(res.xy[ok], T) if T is not None else None)
        rec.update(spurious_reflections=spurious_in, sim_s=round(sim_s, 1))
        rows.append(rec)
    return rows


def _anchor_chi2(anchor: Anchor | None, world: WorldMap) -> dict[str, Any]:
    """``anchor_chi2``: the anchor's drawn errors against their stated std (surveyed: 2 reflectors x 2 axes, 4 dof;
    baseline: the taped distance, 1 dof), and ``anchor_dof``; None for the others. Pooled over seeds it tells
    whether the runs' anchors happened to be good or bad draws (a share of the joint NEES is theirs)."""
    if isinstance(anchor, SurveyedAnchor):
        xy = world.reflector_xy[[world.reflector_ids.index(i) for i in anchor.ids]]
        return {"anchor_chi2": float(np.sum(((anchor.xy - xy) / np.asarray(anchor.std)[:, None]) ** 2)),
                "anchor_dof": 4}
    if isinstance(anchor, BaselineAnchor):
        xy = world.reflector_xy
        i, j = (int(np.argmin(np.hypot(*(xy - np.asarray(p)).T))) for p in (anchor.first, anchor.second))
        return {"anchor_chi2": float(((anchor.distance - np.hypot(*(xy[i] - xy[j]))) / anchor.std) ** 2),
                "anchor_dof": 1}
    return {"anchor_chi2": None, "anchor_dof": None}


def _moved(world: WorldMap, T: np.ndarray) -> WorldMap:
    """``world`` with every reflector moved by the similarity ``T`` (:func:`~agvnav.mapping.anchors.fit_similarity`)."""
    xy = apply_similarity(T, world.reflector_xy)
    moved = (replace(r, x=float(p[0]), y=float(p[1])) for r, p in zip(world.reflectors, xy, strict=True))
    return WorldMap(tuple(moved), world.walls)


def _frame_error(xy: np.ndarray, T: np.ndarray) -> float:
    """RMS (m) over the reflectors ``xy`` of the move the similarity ``T`` makes: the map frame's realised error."""
    return float(np.sqrt(np.mean(np.sum((apply_similarity(T, xy) - xy) ** 2, axis=1))))


def joint_band(n: int, level: float = 0.95) -> tuple[float, float]:
    """The ``level`` band of the joint NEES per reflector of ``n`` reflectors: ``chi2(2n) / n`` (exact when the
    joint covariance is right, pooled over independent runs as well)."""
    q = 0.5 * (1.0 - level)
    return float(chi2.ppf(q, 2 * n) / n), float(chi2.ppf(1.0 - q, 2 * n) / n)


def marginal_band(sum_w: float, sum_sq: float, n: int, level: float = 0.95) -> tuple[float, float]:
    """The ``level`` band of the mean marginal NEES of ``n`` reflectors whose errors are correlated.

    ``Σ_j e_jᵀ C_jj⁻¹ e_j = Σ_i λ_i χ²₁`` with ``λ`` the eigenvalues of ``D C`` (``C`` the joint covariance,
    ``D`` the inverse diagonal blocks): ``Σλ = 2n`` always, and the spread grows with ``Σλ²`` (``2n`` when the
    reflectors are independent, up to ``4n²`` when one shared error moves them all). Welch-Satterthwaite:
    ``g χ²(dof)`` with ``g = Σλ² / Σλ``, ``dof = (Σλ)² / Σλ²``. Pooled runs add their ``Σλ`` and ``Σλ²``.
    """
    q = 0.5 * (1.0 - level)
    g, nu = sum_sq / sum_w, sum_w ** 2 / sum_sq
    return float(g * chi2.ppf(q, nu) / n), float(g * chi2.ppf(1.0 - q, nu) / n)


def nees_statistics(err: np.ndarray, joint: np.ndarray | None, rows: np.ndarray) -> dict[str, Any]:
    """Consistency of one map: ``nees_joint`` (``eᵀC⁻¹e / n`` over the matched reflectors ``rows`` with their
    joint covariance), its exact band, ``nees_sum_sq`` (``Σλ²`` of :func:`marginal_band`) and ``nees_n``."""
    n = int(rows.size)
    if joint is None:
        raise ValueError("the map has no joint covariance")
    cols = np.ravel(np.column_stack([2 * rows, 2 * rows + 1]))
    C = joint[np.ix_(cols, cols)]
    e = np.asarray(err, dtype=np.float64).ravel()
    D = np.zeros_like(C)
    for j in range(n):
        D[2 * j:2 * j + 2, 2 * j:2 * j + 2] = np.linalg.inv(C[2 * j:2 * j + 2, 2 * j:2 * j + 2])
    DC = D @ C
    return {"nees_joint": float(e @ np.linalg.solve(C, e)) / n, "nees_joint_band": _band(*joint_band(n)),
            "nees_sum_sq": float(np.trace(DC @ DC)), "nees_n": n}


def _band(lo: float, hi: float) -> str:
    return f"{lo:.2f}-{hi:.2f}"


def _record_task(task: tuple[str, int]) -> list[dict[str, Any]]:
    """The records of one drive; a drive whose mapping raises is one error record (the table goes on)."""
    try:
        return _record(task[0], task[1], with_positioning=True)
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
        return [{"hall": task[0], "seed": task[1], "anchor": "all", "reflectors_true": None,
                 "reflectors_found": 0, "spurious_created": 0, "error": f"{type(exc).__name__}: {exc}"}]


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
            rs = [r for r in rs if "error" not in r or r.get("reflectors_true") is not None]
            if not rs:
                continue
            n = sum(r["reflectors_true"] for r in rs)
            # pooled over runs x reflectors (the band's definition), not the mean of the runs' means
            k = sum(r["reflectors_found"] for r in rs)
            with_nees = [r for r in rs if r.get("nees_mean") is not None and r.get("nees_n")]
            m = sum(r["nees_n"] for r in with_nees)
            marg = sum(r["nees_mean"] * r["nees_n"] for r in with_nees) / m if m else None
            joint = sum(r["nees_joint"] * r["nees_n"] for r in with_nees) / m if m else None
            sum_sq = sum(r["nees_sum_sq"] for r in with_nees)
            rms = [r["map_rms_m"] for r in rs if r["map_rms_m"] is not None]
            pred = [r["map_rms_predicted_m"] for r in rs if r.get("map_rms_predicted_m") is not None]
            a_chi2 = [r for r in rs if r.get("anchor_chi2") is not None]
            a_dof = sum(r["anchor_dof"] for r in a_chi2)
            ratio = [float(r["positioning_ratio"]) for r in rs if r.get("positioning_ratio") is not None]
            free = [float(r["positioning_ratio_frame_free"]) for r in rs
                    if r.get("positioning_ratio_frame_free") is not None]
            frame = [float(r["frame_error_m"]) for r in rs if r.get("frame_error_m") is not None]
            out.append({
                "hall": hall, "seed": f"all {len(rs)}", "anchor": anchor, "reflectors_true": n,
                "reflectors_seen": sum(r["reflectors_seen"] for r in rs),
                "reflectors_found": k, "spurious_created": sum(r["spurious_created"] for r in rs),
                "map_rms_m": float(np.sqrt(np.mean(np.square(rms)))) if rms else None,
                "map_max_m": max((r["map_max_m"] for r in rs if r["map_max_m"] is not None), default=None),
                "map_rms_predicted_m": float(np.sqrt(np.mean(np.square(pred)))) if pred else None,
                "anchor_chi2": round(sum(r["anchor_chi2"] for r in a_chi2), 2) if a_chi2 else None,
                "anchor_chi2_band": _band(*(float(chi2.ppf(q, a_dof)) for q in (0.025, 0.975))) if a_dof else None,
                "nees_mean": marg, "nees_band": _band(*marginal_band(2.0 * m, sum_sq, m)) if m else None,
                "nees_joint": joint, "nees_joint_band": _band(*joint_band(m)) if m else None, "nees_n": m,
                "runtime_s": round(float(np.mean([r["runtime_s"] for r in rs])), 2),
                "positioning_ratio": round(float(np.mean(ratio)), 3) if ratio else None,
                "positioning_ratio_frame_free": round(float(np.mean(free)), 3) if free else None,
                "frame_error_m": float(np.sqrt(np.mean(np.square(frame)))) if frame else None,
            })
    return out


def run(quick: bool, seed: int) -> list[dict[str, Any]]:
    """Per hall, seed and anchor one record, then one summary record per hall and anchor, then the
    solver comparison (:func:`compare_solvers`, GTSAM rows only where it is installed).

    ``quick``: 2 seeds per hall and no warehouse; else 10 (the warehouse ``SLOW_SEEDS``).
    """
    seeds = [seed + k for k in range(2 if quick else 10)]
    # the slow drives first, so that they run beside the short ones
    halls = sorted((h for h in HALLS if not (quick and h in SLOW_HALLS)), key=lambda h: h not in SLOW_HALLS)
    tasks = [(hall, s) for hall in halls for s in seeds[:SLOW_SEEDS if hall in SLOW_HALLS else None]]
    rows: list[dict[str, Any]] = []
    workers = min(WORKERS, len(tasks), os.cpu_count() or 1)
    if workers > 1:  # each (hall, seed) is independent and seeded: the same records in the same order
        with ProcessPoolExecutor(max_workers=workers) as pool:
            for part in pool.map(_record_task, tasks):
                rows += part
    else:
        for task in tasks:
            rows += _record_task(task)
    for r in rows:
        for key in ("map_rms_m", "map_max_m", "map_rms_predicted_m", "anchor_chi2", "nees_mean", "nees_joint",
                    "nees_sum_sq", "positioning_rms_mapped_m", "positioning_rms_true_m", "frame_error_m"):
            if isinstance(r.get(key), float):
                r[key] = float(f"{r[key]:.3g}") if math.isfinite(r[key]) else None
    return rows + _summary(rows) + compare_solvers(seed)


def _comparison_problem(seed: int, n_poses: int) -> dict[str, Any]:
    """A planar loop with point reflectors seen from every pose (bearings 1e-4 rad, odometry noise):
    the same problem for both solvers, scale held at 1 (GTSAM's Pose2 graph has no scale)."""
    rng = np.random.default_rng([seed, 170])
    lm = np.array([[0.0, 0.0], [10.0, -1.0], [11.0, 8.0], [4.0, 10.0], [-2.0, 6.0], [6.0, 4.5], [14.0, 3.0]])
    ang = np.linspace(0.0, 2.0 * np.pi, n_poses, endpoint=False)
    poses = np.column_stack([5.0 + 4.0 * np.cos(ang), 4.0 + 3.0 * np.sin(ang), ang + np.pi / 2])
    odo_std = np.array([0.002, 0.002, 0.002])
    z = np.array([np.asarray(_between(poses[k], poses[k + 1])) for k in range(n_poses - 1)])
    z_meas = z + rng.normal(0.0, 1.0, z.shape) * odo_std
    sigma = 1e-4
    k_grid, j_grid = np.meshgrid(np.arange(n_poses), np.arange(lm.shape[0]), indexing="ij")
    k_idx, j_idx = k_grid.ravel(), j_grid.ravel()
    d = lm[j_idx] - poses[k_idx, :2]
    bearing = np.arctan2(d[:, 1], d[:, 0]) - poses[k_idx, 2] + rng.normal(0.0, sigma, k_idx.size)
    init = np.zeros_like(poses)
    init[0] = poses[0]
    for k in range(n_poses - 1):
        c, s = np.cos(init[k, 2]), np.sin(init[k, 2])
        init[k + 1] = [init[k, 0] + c * z_meas[k, 0] - s * z_meas[k, 1],
                       init[k, 1] + s * z_meas[k, 0] + c * z_meas[k, 1], init[k, 2] + z_meas[k, 2]]
    return {"truth_poses": poses, "truth_lm": lm, "z": z_meas, "odo_std": odo_std, "k": k_idx, "j": j_idx,
            "bearing": bearing, "sigma": sigma, "init_poses": init, "init_lm": lm + rng.normal(0.0, 0.3, lm.shape)}


def _between(a: np.ndarray, b: np.ndarray) -> list[float]:
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return [c * dx + s * dy, -s * dx + c * dy, wrap_angle_scalar(b[2] - a[2])]


def _solve_scipy(p: dict[str, Any]) -> tuple[np.ndarray, float]:
    from agvnav.mapping.graph import (  # noqa: PLC0415 - only this comparison builds a graph by hand
        BearingFactors,
        FactorGraph,
        OdometryFactors,
        PosePriors,
        ReflectorPriors,
    )
    from agvnav.mapping.solve import solve  # noqa: PLC0415

    K, N = p["init_poses"].shape[0], p["init_lm"].shape[0]
    t0 = time.perf_counter()
    e = np.arange(K - 1)
    W = np.broadcast_to(np.diag(1.0 / p["odo_std"]), (K - 1, 3, 3)).copy()
    g = FactorGraph(
        K, N, OdometryFactors(e, e + 1, p["z"], W),
        BearingFactors(p["k"], p["j"], np.zeros((p["k"].size, 3)), p["bearing"], np.full(p["k"].size, p["sigma"]),
                       np.zeros(3)),
        PosePriors(np.array([0]), p["truth_poses"][:1], np.eye(3)[None] * 1e4),
        ReflectorPriors(np.array([0, 1]), p["truth_lm"][:2], np.broadcast_to(np.eye(2) * 1e3, (2, 2, 2)).copy()),
        scale_prior=(1.0, 1e-9))
    sol = solve(g, g.pack(p["init_poses"], p["init_lm"], 1.0), max_iterations=100)
    _, lm, _ = g.unpack(sol.x)
    return lm, time.perf_counter() - t0


def _solve_gtsam(p: dict[str, Any], incremental: bool) -> tuple[np.ndarray, float]:
    import gtsam  # type: ignore[import-not-found]  # noqa: PLC0415 - optional (the slam extra)

    K, N = p["init_poses"].shape[0], p["init_lm"].shape[0]
    X, L = gtsam.symbol_shorthand.X, gtsam.symbol_shorthand.L
    t0 = time.perf_counter()
    odo_noise = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(p["odo_std"], dtype=float))
    b_noise = gtsam.noiseModel.Isotropic.Sigma(1, p["sigma"])
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    graph.add(gtsam.PriorFactorPose2(X(0), gtsam.Pose2(*p["truth_poses"][0]),
                                     gtsam.noiseModel.Isotropic.Sigma(3, 1e-4)))
    for j in (0, 1):
        graph.add(gtsam.PriorFactorPoint2(L(j), p["truth_lm"][j], gtsam.noiseModel.Isotropic.Sigma(2, 1e-3)))
    isam = gtsam.ISAM2() if incremental else None
    seen: set[int] = set()
    by_pose: dict[int, list[int]] = {}
    for r, k in enumerate(p["k"].tolist()):
        by_pose.setdefault(k, []).append(r)
    for k in range(K):
        values.insert(X(k), gtsam.Pose2(*p["init_poses"][k]))
        if k:
            graph.add(gtsam.BetweenFactorPose2(X(k - 1), X(k), gtsam.Pose2(*p["z"][k - 1]), odo_noise))
        for r in by_pose.get(k, []):
            j = int(p["j"][r])
            if j not in seen:
                seen.add(j)
                values.insert(L(j), p["init_lm"][j])
            graph.add(gtsam.BearingFactor2D(X(k), L(j), gtsam.Rot2(float(p["bearing"][r])), b_noise))
        if isam is not None and (k % 10 == 9 or k == K - 1):
            isam.update(graph, values)
            graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    if isam is not None:
        for _ in range(3):  # a few more relinearisations at the end, as a batch would iterate
            isam.update()
        est = isam.calculateEstimate()
    else:
        params = gtsam.LevenbergMarquardtParams()
        params.setMaxIterations(100)
        est = gtsam.LevenbergMarquardtOptimizer(graph, values, params).optimize()
    lm = np.array([np.asarray(est.atPoint2(L(j))) for j in range(N)])
    return lm, time.perf_counter() - t0


def compare_solvers(seed: int = 0, n_poses: int = 400) -> list[dict[str, Any]]:
    """SciPy sparse LM (this package) against GTSAM's LM and iSAM2 on one problem: map RMS and time.

    GTSAM is optional (``pip install gtsam``, 4.3 wheels); without it only the SciPy row.
    """
    p = _comparison_problem(seed, n_poses)
    rows = []
    solvers: list[tuple[str, Any]] = [("scipy_sparse_lm", _solve_scipy)]
    try:
        import gtsam  # noqa: F401, PLC0415

        solvers += [("gtsam_lm", lambda q: _solve_gtsam(q, False)), ("gtsam_isam2", lambda q: _solve_gtsam(q, True))]
    except ImportError:
        pass
    for name, fn in solvers:
        lm, secs = fn(p)
        err = np.hypot(*(lm - p["truth_lm"]).T)
        rows.append({"solver": name, "poses": n_poses, "bearings": int(p["k"].size),
                     "map_rms_m": float(np.sqrt(np.mean(err ** 2))), "runtime_s": round(secs, 3)})
    return rows
