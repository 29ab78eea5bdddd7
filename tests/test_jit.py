"""agvnav._jit: lazy kernels that run compiled (numba) or interpreted, agreeing to rounding.

Determinism is within one mode (issue 27): a seeded run repeats itself bit for bit in one mode
(``tests/positioning/test_fused.py``); the compiled and interpreted forms of every kernel agree to
about 1e-12 relative (NaN where NaN), checked here by one parametrized property test over every
kernel on seeded random inputs.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from agvnav import _jit
from agvnav.geometry import wrap_angle
from agvnav.geometry.angles import wrap_angle_kernel, wrap_angle_scalar
from agvnav.kinematics import twist
from agvnav.layout.filtered import filtered_prediction
from agvnav.odometry import OdometryNoise, increment_variances
from agvnav.positioning import _fast
from agvnav.positioning import _integrity_fast as fast_integrity
from agvnav.positioning._integrity_fast import _information_sums, best_triple
from agvnav.positioning.fix_validity import _layout_ok_kernel
from agvnav.positioning.gating import BearingIndex, GateSpec, near_rows
from agvnav.positioning.integrity import IntegrityMonitor, _fde_statistics, _window_tally
from agvnav.positioning.total import _div, _wrap, total_batch
from agvnav.routes.planning import astar_kernel
from agvnav.sensors import (
    beam,
    scanner,  # noqa: F401 - its kernel is in the property test
)
from agvnav.sim import bodies
from agvnav.traffic import _sipp  # noqa: F401 - its kernels are in the property test
from agvnav.traffic._collide import first_overlap, pad_footprints
from agvnav.vehicles.tricycle import hermite_poses

pytestmark = pytest.mark.usefixtures("restore_jit_mode")


Outputs = dict[str, list[Any]]


def _random_outputs() -> Outputs:
    """Every kernel on seeded random inputs (offsets over a 40 m hall, any heading): each kernel's outputs."""
    rng = np.random.default_rng(11)
    c = 5_000  # per direction: 1e4 calls of offset_one through offsets_at
    t = rng.uniform(0.0, 500.0, c)
    pose = np.column_stack([rng.uniform(-20, 20, c), rng.uniform(-20, 20, c), rng.uniform(-7, 7, c)])
    rx, ry, r = rng.uniform(-20, 20, c), rng.uniform(-20, 20, c), rng.uniform(0.01, 0.5, c)
    out: Outputs = {}
    for direction in (1, -1):
        head = (0.2, -0.1, 0.3, direction * 2 * math.pi * 8.0, direction)
        out[f"offsets_at {direction}"] = list(beam.offsets_at(t, pose, rx, ry, r, *head))
        grid, gpose = np.sort(t[:400]) / 100.0, pose[:400]
        out[f"grid_crossings {direction}"] = list(beam.grid_crossings(grid, gpose, rx[:60], ry[:60], r[:60], *head))
        interval, refl, f_lo, f_hi = beam.grid_crossings(grid, gpose, rx[:60], ry[:60], r[:60], *head)
        start = beam.chord_brackets(grid, interval, f_lo, f_hi, refl, rx[:60], ry[:60], r[:60])
        out[f"chord_brackets {direction}"] = list(start)
        lo, hi, slope, t1, trx, try_, tr, _ = start
        tpose = np.column_stack([lo * 0.1, hi * 0.2, lo])  # any finite poses at the chord instants
        for tol in (1e-10, 10.0):  # not converged (the next instants) and converged (the same ones)
            done, *arrays = beam.chord_step(t1, tpose, trx, try_, tr, *head[:4], direction, slope, lo, hi, tol)
            out[f"chord_step {direction} {tol}"] = [bool(done), *(a for a in arrays)]
    from agvnav.world import load_builtin_map

    lab = load_builtin_map("lab")
    seg = lab.wall_segments
    walls = (seg[:, 0, 0].copy(), seg[:, 0, 1].copy(), seg[:, 1, 0] - seg[:, 0, 0], seg[:, 1, 1] - seg[:, 0, 1])
    lx, ly = lab.reflector_xy[:, 0].copy(), lab.reflector_xy[:, 1].copy()
    scans = []
    for k in range(400):  # scan_motion (and _finite_poses) on random steps through the lab, both kinds
        p0 = np.array([rng.uniform(2.0, 18.0), rng.uniform(2.0, 10.0), rng.uniform(-4.0, 4.0)])
        table = np.array([p0, rng.normal(0.0, 0.05, 3), p0 + rng.normal(0.0, 0.04, 3), rng.normal(0.0, 0.05, 3)])
        grid = np.linspace(0.05 * k, 0.05 * k + 0.05, 3)
        motion = (beam.HERMITE, table, np.zeros((0, 3)), 0.05 * k, 0.05) if k % 2 else (
            beam.TWIST, table[[0, 2, 2]], np.array([[0.4, 0.0, 1.0], [0.3, 0.1, -0.5]]), 0.05 * k, 0.025)
        status, ts, rs = beam.scan_motion(*motion, grid, lx, ly, lab.reflector_radius, 0.3, 0.0,
                                           0.0, 2.0 * math.pi * 8.0, 1, *walls, 0.0, 30.0, 8.0, 1e-10, 2.2e-16, 6)
        scans += [status, ts, rs]
    out["scan_motion"] = scans
    ts = np.round(rng.uniform(0.0, 1.0, 300), 2)  # ties: a stable sort keeps their order
    picked = beam.seen_in_order(ts, np.arange(300, dtype=np.int64), rng.uniform(size=300) < 0.7)
    out["seen_in_order"] = list(picked)
    angles = np.concatenate([rng.uniform(-50.0, 50.0, 10_000), [math.pi, -math.pi, 3 * math.pi, 0.0, -0.0, 1e-300]])
    out["wrap_angle_kernel"] = [np.array([wrap_angle_kernel(float(a)) for a in angles[:5_000]])]
    f, worst = beam.wrapped_offsets(angles)
    out["wrapped_offsets"] = [f, worst]
    n, k = 200, 5_000
    refl = rng.integers(0, n, k)
    hx, hy = rng.uniform(-20, 20, k), rng.uniform(-20, 20, k)
    d = np.sqrt((rx[refl] - hx) ** 2 + (ry[refl] - hy) ** 2)
    w0x, w0y, wvx, wvy = rng.uniform(-20, 20, (4, 30))
    seen = beam.line_of_sight(refl, hx, hy, d, rx[:n], ry[:n], r[:n] * 0.2, w0x, w0y, wvx, wvy, 0.1, 30.0)
    out["line_of_sight"] = [np.asarray(seen)]
    out["near_rows"] = [
        np.asarray(near_rows(rx[:500], ry[:500], r[:500] ** 2, 0.5 * math.pi * r[:500], x, y, b, 1e-4, 1e-3, 15.0))

        for x, y, b in rng.uniform(-10, 10, (200, 3))
    ]
    out["hermite_poses"] = [
        np.asarray(hermite_poses(rng.normal(size=(4, 3)), 0.0, 0.05, rng.uniform(-0.01, 0.06, 1_000)))
        for _ in range(100)
    ]
    spec = GateSpec(1e-8, 15.0, 10.83, 0.005, 0.09)  # grid_rows (and _visit_box) through the index
    index = BearingIndex(np.column_stack([rx[:500], ry[:500]]), r[:500] * 0.2, (0.3, 0.1, 0.2), spec)
    P = (1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-5)
    out["grid_rows"] = [
        np.asarray(index.candidates(float(z), (float(x), float(y), float(p)), P))
        for x, y, p, z in rng.uniform(-10, 10, (200, 4))
    ]
    fits = []
    for _ in range(300):  # the RAIM's weighted least-squares fits, every row left out in turn
        n = int(rng.integers(4, 16))
        H, res, w = rng.normal(size=(n, 3)), rng.normal(size=n), rng.uniform(0.1, 10.0, n)
        fits.append(_fde_statistics(res, H.reshape(-1), w, 3))
    out["_fde_statistics"] = [np.concatenate(fits)]
    triples = []  # the cross-check's choice of triple (its CRLB per triple through position_crlb_one)
    for _ in range(2_000):
        n = int(rng.integers(3, 9))
        rx3, ry3, var3 = rng.uniform(-10, 10, n), rng.uniform(-10, 10, n), rng.uniform(1e-7, 1e-4, n)
        triples.append(best_triple(0.3, -0.2, rx3, ry3, var3, 1e-6, float(rng.uniform(1e-5, 1e-2))))
    out["best_triple"] = [np.array(triples)]
    rows = rng.normal(size=(3_000, 20))  # an integrity window: stamps, map rows of 40, flags 0/1, sums
    rows[:, 0] = np.sort(rng.uniform(0.0, 2.0, 3_000))
    rows[:, 2] = rng.integers(0, 40, 3_000)
    rows[:, [7, 8, 14]] = rng.integers(0, 2, (3_000, 3))
    excluded = (rng.uniform(size=40) < 0.1).astype(np.int64)
    tally = _window_tally(rows.reshape(-1), 0, 3_000, 2.1, 1.0, 0.125, excluded)
    out["_window_tally"] = [np.asarray(a) for a in tally]
    std = np.where(rng.uniform(size=200) < 0.05, 0.0, rng.uniform(1e-3, 1e-2, 200))
    info = [_information_sums(float(hx[i]), float(hy[i]), rx[:200], ry[:200], std) for i in range(50)]
    out["_information_sums"] = [np.array([[ok, *a, *b, sv] for ok, a, b, sv in info], dtype=np.float64)]
    out.update(_estimator_kernel_outputs(rng))
    return out


def _estimator_kernel_outputs(rng: np.random.Generator) -> Outputs:
    """The streaming EKF's compiled path (``positioning._fast``): prediction, gate, gate and update."""
    from agvnav.positioning import _fast

    out: Outputs = {"move_state": [], "gate_rows": [], "gate_accept": []}
    n = 60
    xy, radius = rng.uniform(0.0, 20.0, (n, 2)), rng.uniform(0.02, 0.05, n)
    rows = _fast.reflector_rows(xy, radius)
    tab = _fast.gate_table(rows, rng.uniform(1e-6, 4e-6, n))
    spec = GateSpec(1e-7, 25.0, 10.8, 0.002, 0.1, True)
    index = BearingIndex(xy, radius, (0.3, 0.05, 0.01), spec)
    gc = _fast.gate_constants(spec, (0.3, 0.05, 0.01), index.grid_constants(), 1e-7, 0.05, 20.0, True)
    gc_plain = _fast.gate_constants(GateSpec(1e-7, 25.0, 10.8, 0.002, 0.1), (0.3, 0.05, 0.01), None, 1e-7)
    sight, claimed = rng.uniform(size=n) < 0.9, np.where(rng.uniform(size=n) < 0.1, 1.0, -math.inf)
    for k in range(500):
        pose = (*rng.uniform(2.0, 18.0, 2).tolist(), float(rng.uniform(-4.0, 4.0)))
        a = rng.normal(0.0, 0.01, (3, 3))
        P = tuple((a @ a.T + 1e-6 * np.eye(3)).reshape(9).tolist())
        M = tuple((np.eye(3) + rng.normal(0.0, 0.3, (3, 3))).reshape(9).tolist())
        X = tuple(rng.normal(0.0, 1e-4, 6).tolist())
        steered = (bool(k % 2), 1.2, 1e-3, 4e-5, 0.5) if k % 3 else None
        mc = _fast.move_constants((1e-4, 2e-4, 1e-5, 3e-4), steered, True, True, (9e-6, 1.2e-5))
        dd, dth, dl = rng.uniform(-0.05, 0.05, 3).tolist()
        moved = _fast.move_state((0.1, 0.2, 0.3), pose, P, M, X, dd, dth, dl if k % 5 == 0 else 0.0, mc)
        out["move_state"].append(np.array([v for part in moved for v in part]))
        z = float(rng.uniform(-math.pi, math.pi))
        C = rng.normal(0.0, 1e-3, (n, 6))
        for consts in (gc, gc_plain):
            got = _fast.gate_rows(z, 1.05, pose, P, M, C, claimed, sight, tab, consts, *index.grid_cells())
            out["gate_rows"].append(np.array(got, dtype=np.float64))
        res = _fast.gate_accept(z, 1.05, pose, P, M, X, C, claimed, sight, tab, gc, *index.grid_cells())
        flat = [float(v) for part in res[:-1] for v in part] + [float(res[-1])]
        out["gate_accept"] += [np.array(flat), C.copy()]
    return out


def _scalar_kernel_outputs(rng: np.random.Generator) -> Outputs:
    """The estimators' scalar kernels (``positioning._fast``) one by one, on random states and increments."""
    out: Outputs = {}
    n = 400
    for _ in range(n):
        x, y, psi = rng.uniform(-20.0, 20.0, 2).tolist() + [float(rng.uniform(-4.0, 4.0))]
        dd, dth, dl = rng.uniform(-0.05, 0.05, 3).tolist()
        dth = dth if rng.uniform() < 0.8 else 1e-6 * dth  # the series branch of sinc too
        a = rng.normal(0.0, 0.01, (3, 3))
        P = tuple((a @ a.T + 1e-6 * np.eye(3)).reshape(9).tolist())
        M = tuple((np.eye(3) + rng.normal(0.0, 0.3, (3, 3))).reshape(9).tolist())
        X = tuple(rng.normal(0.0, 1e-4, 6).tolist())
        K = tuple(rng.normal(0.0, 0.3, 3).tolist())
        H = tuple(rng.normal(0.0, 0.5, 3).tolist())
        v = tuple(rng.normal(0.0, 1e-5, 3).tolist())
        rx, ry, r = float(rng.uniform(-20.0, 20.0)), float(rng.uniform(-20.0, 20.0)), float(rng.uniform(0.02, 0.3))
        rows = {
            "_sinc": [_fast._sinc(dth)], "_dsinc": [_fast._dsinc(dth)],
            "twist_step": list(_fast.twist_step(x, y, psi, dd, dth, dl)),
            "increment_variances": list(increment_variances(dd, dth, 1e-4, 2e-4, 1e-5)),
            "process_noise": list(_fast.process_noise(psi, dd, dth, 1e-4, 2e-4, 1e-5, dl, 3e-4)),
            "steered_noise": [w for part in _fast.steered_noise(psi, dd, dth, bool(rng.uniform() < 0.5), 1.2, 1e-3,
                                                                4e-5, float(rng.choice([0.0, 0.5]))) for w in part],
            "predict_covariance": list(_fast.predict_covariance(P, dd, dl, P)),
            "calibration_predict": [w for part in _fast.calibration_predict(P, X, dd, dl, X, (9e-6, 1.2e-5))
                                    for w in part],
            "calibration_update": list(_fast.calibration_update(X, K, H)),
            "consider_cross": list(_fast.consider_cross(M, X[:3], X[3:], dd, dl)),
            "schmidt_update": [w for part in _fast.schmidt_update((x, y, psi), P, dth, H, 1e-6, v, 1e-7)
                               for w in (part if isinstance(part, tuple) else (part,))],
            "left_update": list(_fast.left_update(M, K, H)), "shear": list(_fast.shear(M, dd, dl)),
            "det3": [_fast.det3(M)], "solve3": list(_fast.solve3(M, K, _fast.det3(M))),
            "edge_bearing": list(_fast.edge_bearing(x, y, psi, 0.01, rx, ry, r)),
            "bearing_jacobian": list(_fast.bearing_jacobian(rx - x, ry - y, (rx - x) ** 2 + (ry - y) ** 2,
                                                            math.hypot(rx - x, ry - y), r, 0.3, -0.1)),
            "surely_outside": [_fast.surely_outside(dth, 4.0, r, 1e-6, 1e-4, 0.3, 10.8),
                               _fast.surely_outside(dth, 4.0, r, 1e-6, 1e-4, 0.3, 10.8, 1e-6, True)],
        }
        for name, values in rows.items():
            out.setdefault(name, []).append(np.array(values, dtype=np.float64))
    return out


def _integrity_kernel_outputs(rng: np.random.Generator) -> Outputs:
    """The integrity monitor's check (``positioning._integrity_fast``) on random windows and triples."""
    out: Outputs = {}

    def add(name: str, values: Any) -> None:
        out.setdefault(name, []).append(np.array(values, dtype=np.float64))

    for _ in range(300):
        r = rng.uniform(-10.0, 10.0, (3, 2))
        p, psi = rng.uniform(-10.0, 10.0, 2), float(rng.uniform(-math.pi, math.pi))
        z = (np.arctan2(r[:, 1] - p[1], r[:, 0] - p[0]) - psi + rng.normal(0.0, 1e-3, 3)).tolist()
        code, px, py = fast_integrity.total_fix(*r.reshape(-1).tolist(), *z)
        add("total_fix", (code, px, py))
        rx, ry, std = tuple(r[:, 0].tolist()), tuple(r[:, 1].tolist()), tuple(rng.uniform(1e-4, 5e-3, 3).tolist())
        cov = fast_integrity.fix_covariance(rx, ry, float(p[0]), float(p[1]), std)
        add("fix_covariance", cov)
        add("nonlinear_fix", [fast_integrity.nonlinear_fix(rx, ry, float(p[0]), float(p[1]), *cov[1:3], cov[4])])
        add("_inverse3", fast_integrity._inverse3(*rng.normal(size=6).tolist()))
        add("_head", fast_integrity._head(*rng.normal(size=6).tolist()))
        add("_edge_bearing", fast_integrity._edge_bearing(*p.tolist(), psi, *r[0].tolist(), 0.04))
    for _ in range(60):
        n_map = int(rng.integers(5, 30))
        mon = IntegrityMonitor(rng.uniform(0.0, 20.0, (n_map, 2)), rng.uniform(0.02, 0.05, n_map),
                               (0.3, 0.05, 0.01), 1e-3, 0.125, map_std=rng.uniform(1e-3, 1e-2, n_map),
                               odometry_noise=(1e-4, 2e-4, 1e-3))
        for tk in np.sort(rng.uniform(9.1, 10.0, int(rng.integers(0, 80)))).tolist():
            odom = (float(rng.uniform(8, 12)), float(rng.uniform(8, 12)), float(rng.uniform(-3, 3)))
            mon.accepted(tk, float(rng.uniform(0, 3)), int(rng.integers(0, n_map)),
                         float(rng.uniform(-math.pi, math.pi)), odom, None, (float(rng.normal(0.0, 1e-3)),
                         float(rng.uniform(1e-6, 1e-4)), *rng.normal(0.0, 0.3, 3).tolist()))
        tally = mon._tally(10.0)
        buf, start = mon._entries.buffer()
        x = (float(rng.uniform(8, 12)), float(rng.uniform(8, 12)), float(rng.uniform(-3, 3)))
        odom = (float(rng.uniform(8, 12)), float(rng.uniform(8, 12)), float(rng.uniform(-3, 3)))
        rx, ry, radius, map_std = mon._tables
        add("crosscheck_fix", fast_integrity.crosscheck_fix(buf, start, tally.newest, x, odom, mon._mount_t, rx, ry,
                                                            radius, map_std, mon.odometry_noise, 1e-6, 0.05**2))
        sightings = (rng.uniform(size=n_map) < 0.5).astype(np.float64)
        add("information", fast_integrity.information(*x, sightings, rx, ry, map_std, mon._mount_t))
        excluded = (rng.uniform(size=n_map) < 0.1).astype(np.int64)
        add("in_range", [fast_integrity.in_range(x[0], x[1], rx, ry, float(rng.uniform(2.0, 12.0)), excluded)])
        att, n = np.zeros((0, 7)), len(mon._entries)
        sums = fast_integrity.revolution_innovations(buf, start, n, 10.0, 0.5, excluded, att, 0)
        add("revolution_innovations", sums.reshape(-1))
        rows = np.flatnonzero(sums[:, 5])
        add("mean_innovations", np.concatenate([a.reshape(-1) for a in
                                                fast_integrity.mean_innovations(sums, rows, map_std, 1e-6)]))
        add("revolution_offset", fast_integrity.revolution_offset(buf, start, n, 10.0, 0.5, excluded, att, 0, map_std,
                                                                  1e-6))
        found, stats, positive = fast_integrity.window_fde(sums, map_std, 1e-6)
        add("window_fde", np.concatenate([found, stats, [positive]]))
        add("nis_per_reflector", [fast_integrity.nis_per_reflector(buf, start, n, tally.sightings, tally.first,
                                                                   tally.nis)])
    return out


#: Kernels called only by other kernels, checked through the outputs of the kernel named (nested kernels
#: run in the caller's mode).
NESTED = {
    "wrap_angle_scalar": "wrap_angle_kernel", "offset_one": "offsets_at", "_hits_wall": "line_of_sight",
    "_hits_disc": "line_of_sight", "near_one": "near_rows", "_visit_box": "grid_rows", "_finite_poses": "scan_motion",
    "motion_poses": "scan_motion",
    "_solve_augmented": "_fde_statistics", "_normal_equations": "_fde_statistics", "position_crlb_one": "best_triple",
    "schmidt_accept": "gate_accept", "total_core": "total_batch",
    "_turn": "sipp", "_slot": "sipp", "_push_state": "sipp", "_chain": "sipp",
    "_node_intervals": "sipp", "_search": "sipp", "_n_classes": "sipp", "scratch_size": "sipp",
    "twist_table_pose": "twist_table_poses", "segment_hits_box": "bodies_block_sight",
    "_segments_gap": "footprint_gaps", "point_in_polygon": "points_in_polygon",
    "place": "first_overlap", "_separates": "first_overlap", "polygons_overlap": "first_overlap",
    "release_held": "reserve", "chain_occupations": "reserve", "_heap_up": "dijkstra_to", "_heap_down": "dijkstra_to",
}


class _TouchZones:
    """A conflict relation for the traffic kernels: a node conflicts with itself and the edges at it, an edge
    with its twin and its end nodes."""

    def __init__(self, network: Any) -> None:
        self.net = network

    def conflicts(self, model_a: str, res: tuple[str, str], model_b: str) -> frozenset[tuple[str, str]]:
        if res[0] == "node":
            at = {("edge", e.id) for e in self.net.edges.values() if res[1] in (e.source, e.target)}
            return frozenset({res} | at)
        e = self.net.edges[res[1]]
        twin = {("edge", x.id) for x in self.net.edges.values() if {x.source, x.target} == {e.source, e.target}}
        return frozenset({res, ("node", e.source), ("node", e.target)} | twin)


def _traffic_kernel_outputs(rng: np.random.Generator) -> Outputs:
    """The traffic planner's kernels (``traffic._sipp``) through a fleet plan on a 10 x 10 grid: planned times."""
    from agvnav.routes.layouts import grid_network
    from agvnav.routes.network import network_from_dict
    from agvnav.routes.planning import VehicleLimits
    from agvnav.traffic.plan import Goal, VehicleTask, plan_fleet

    net = network_from_dict(grid_network(10, 5.0))
    nodes = list(net.nodes)
    pick = rng.choice(len(nodes), 24, replace=False)
    lim = VehicleLimits("differential", 1.0)
    tasks = [VehicleTask(f"V{i}", lim, nodes[int(pick[i])], (Goal(nodes[int(pick[12 + i])], 2.0),))
             for i in range(12)]
    plan = plan_fleet(net, tasks, _TouchZones(net))
    times = [np.array([(s.t_start, s.t_end) for s in p.steps] or [(0.0, 0.0)]) for p in plan.plans.values()]
    return {name: list(times) for name in ("sipp", "dijkstra_to", "reserve", "release", "safe_intervals")}


def _collide_kernel_outputs(rng: np.random.Generator) -> Outputs:
    """The executor's collision kernel (``traffic._collide``): the first overlapping pair of random boxes."""
    out = []
    for _ in range(300):
        n = int(rng.integers(2, 10))
        half = rng.uniform(0.2, 0.8, (n, 2))
        feet = [np.array([[a, -b], [a, b], [-a, b], [-a, -b]]) for a, b in half]
        fps, counts = pad_footprints(feet)
        xs, ys, hs = rng.uniform(0.0, 4.0, n), rng.uniform(0.0, 4.0, n), rng.uniform(-math.pi, math.pi, n)
        out.append(first_overlap(xs, ys, hs, np.hypot(half[:, 0], half[:, 1]), fps, counts, np.zeros((4, 2)),
                                 np.zeros((4, 2))))
    from agvnav.traffic._adg_fast import visit_pairs  # the ADG's pair visit on random occupations

    visits = []
    for _ in range(50):
        n, n_veh, n_keys = int(rng.integers(2, 40)), int(rng.integers(2, 5)), int(rng.integers(1, 6))
        key_of = rng.integers(-1, n_keys, n)
        members = rng.integers(0, n, 3 * n_keys)
        indptr = np.concatenate([[0], np.sort(rng.integers(0, 3 * n_keys, n_keys - 1)), [3 * n_keys]])
        t0 = rng.uniform(0.0, 100.0, n)
        t1 = t0 + rng.uniform(0.0, 1.0, n)
        veh, acq = rng.integers(0, n_veh, n), rng.integers(-1, 6, n)
        rel = np.where(rng.uniform(size=n) < 0.1, 1 << 60, acq + 1)
        slots = n_veh * 6 * n_veh
        arrays = [np.zeros(slots, dtype=np.int64) for _ in range(3)] + [np.full(slots, -1, dtype=np.int64),
                                                                       np.zeros(3, dtype=np.int64)]
        count = visit_pairs(indptr.astype(np.int64), members, key_of, veh, t0, t1, acq, rel,
                            np.arange(n_veh, dtype=np.int64) * 6, n_veh, 1 << 60, *arrays)
        visits.append(np.concatenate([[count], *arrays]).astype(np.float64))
    return {"first_overlap": [np.array(out, dtype=np.float64)], "visit_pairs": visits}


def _triangulation_kernel_outputs(rng: np.random.Generator) -> Outputs:
    """The batch triangulation's kernels (``positioning.total``, ``positioning.fix_validity``) on random fixes."""
    m = 400
    r = rng.uniform(-10.0, 10.0, (m, 3, 2))
    r[: m // 5, :, 1] = r[: m // 5, :1, 1]  # collinear layouts, as many walls
    p, psi = rng.uniform(-10.0, 10.0, (m, 2)), rng.uniform(-math.pi, math.pi, m)
    b = np.arctan2(r[..., 1] - p[:, None, 1], r[..., 0] - p[:, None, 0]) - psi[:, None] + rng.normal(0, 1e-3, (m, 3))
    rx, ry = np.ascontiguousarray(r[..., 0]), np.ascontiguousarray(r[..., 1])
    d = (r - np.roll(r, -1, axis=1)) ** 2
    scale2 = d.sum(axis=(1, 2)) / 3.0
    o = [np.empty(m) for _ in range(4)] + [np.empty(m, dtype=np.bool_)]
    with np.errstate(all="ignore"):  # interpreted, the elements are NumPy scalars: inf * 0 warns
        total_batch(rx, ry, scale2, np.ascontiguousarray(b), *o)
    ok = np.empty(m, dtype=np.bool_)
    _layout_ok_kernel(np.ascontiguousarray(r), np.ascontiguousarray(b), False, False, False, ok)
    vals = [0.0, -0.0, 1.0, -2.5, math.inf, -math.inf, math.nan, 1e-310, 1e308]
    return {
        "total_batch": list(o), "_layout_ok_kernel": [ok],
        "_wrap": [np.array([_wrap(float(v)) for v in rng.uniform(-15.0, 15.0, 2_000)])],
        "_div": [np.array([_div(x, y) for x in vals for y in vals])],
    }


def _motion_kernel_outputs(rng: np.random.Generator) -> Outputs:
    """The SE(2) exponential's kernels (``kinematics.twist``), the fleet's bodies (``sim.bodies``) and the
    scanner's rays (``sensors.scanner``) on random motion tables and scenes."""
    from agvnav.geometry.polygon import points_in_polygon
    from agvnav.sensors.scanner import ray_ranges, scan_poses

    n, g = 8, 5
    pose = np.column_stack([rng.uniform(-10, 10, (400, 2)), rng.uniform(-7, 7, 400)])
    vx, vy, w, dt = rng.uniform(-2, 2, 400), rng.uniform(-1, 1, 400), rng.uniform(-3, 3, 400), rng.uniform(0, 0.2, 400)
    w[:50] *= 1e-6  # the series branch
    stepped = twist.twist_steps(pose, vx, vy, w, dt)
    logs = np.array([twist.twist_log(*pose[i], *stepped[i]) for i in range(400)])
    states = np.cumsum(rng.normal(0.0, 0.02, (n, g + 1, 3)), axis=1) + rng.uniform(0, 10, (n, 1, 3))
    twists = np.zeros((n, g, 3))
    twist.fleet_twist_tables(states, 0.01, twists)
    t0, h, n_sub = np.full(n, 1.0), np.full(n, 0.01), np.full(n, g, dtype=np.int64)
    rows, t = rng.integers(0, n, 300), rng.uniform(0.99, 1.06, 300)
    p0, p1 = rng.uniform(-1, 11, (500, 2)), rng.uniform(-1, 11, (500, 2))
    boxes = np.column_stack([-rng.uniform(0.2, 1, n), rng.uniform(0.2, 1, n), -rng.uniform(0.2, 1, n),
                             rng.uniform(0.2, 1, n)])
    radius = np.hypot(np.abs(boxes[:, :2]).max(axis=1), np.abs(boxes[:, 2:]).max(axis=1))
    sight = bodies.bodies_block_sight(p0, p1, rng.uniform(1.0, 1.05, 500), np.arange(n), states, twists, n_sub, t0, h,
                                      boxes, radius)
    seg = rng.uniform(-15, 15, (40, 4))
    circ = np.column_stack([rng.uniform(-10, 10, (5, 2)), rng.uniform(0.1, 1.0, 5)])
    angles = rng.uniform(-math.pi, math.pi, (3, 1)) + np.radians(np.arange(0.0, 270.0, 1.0))[None, :]
    rays = [np.asarray(a, dtype=np.float64) for reach in (math.inf, 8.0)
            for a in ray_ranges(rng.uniform(-8, 8, (3, 2)), angles, seg, circ, reach)]
    return {
        "twist_steps": [stepped], "twist_pose": [np.array([twist.twist_pose(*pose[i], vx[i], vy[i], w[i], dt[i])
                                                            for i in range(100)])],
        "twist_log": [logs], "fleet_twist_tables": [twists],
        "twist_table_poses": [twist.twist_table_poses(states[0], twists[0], 1.0, 0.01, t)],
        "fleet_twist_poses": [twist.fleet_twist_poses(states, twists, n_sub, t0, h, rows, t)],
        "bodies_block_sight": [sight], "bodies_edges": [bodies.bodies_edges(states, twists, n_sub, t0, h, boxes, 1.02)],
        "ray_ranges": rays,
        "scan_poses": [np.asarray(a, dtype=np.float64) for a in scan_poses(
            np.column_stack([rng.uniform(-5, 5, (3, 2)), rng.uniform(-9, 9, 3)]), 0.4, 0.1, 0.2,
            np.radians(np.arange(-135.0, 135.5, 1.0)), seg, circ, 8.0, rng.normal(0.0, 0.05, (3, 271)))],
        "points_in_polygon": [points_in_polygon(rng.uniform(-2, 2, (500, 2)), rng.uniform(-2, 2, (9, 2)))
                              for _ in range(5)],
        "footprint_gaps": [bodies.footprint_gaps(rng.uniform(0.0, 4.0, (30, 5, 2)), *np.triu_indices(30, 1))],
    }


def _outputs(compiled: bool) -> Outputs:
    _jit.set_compiled(compiled)
    out = _random_outputs()
    out.update(_motion_kernel_outputs(np.random.default_rng(17)))
    rng = np.random.default_rng(13)
    out.update(_scalar_kernel_outputs(rng))
    out.update(_integrity_kernel_outputs(rng))
    out.update(_triangulation_kernel_outputs(rng))
    out.update(_planning_kernel_outputs(rng))
    out.update(_traffic_kernel_outputs(rng))
    out.update(_collide_kernel_outputs(rng))
    out.update(_layout_kernel_outputs())
    return out


def _layout_kernel_outputs() -> Outputs:
    """The layout planner's bearing-by-bearing covariance recursion along a 10 m straight past five reflectors."""
    pose = np.zeros((101, 3))
    pose[:, 0] = np.linspace(-5.0, 5.0, 101)
    pose[:, 1] = -4.0
    refl = np.array([[-15.0, 5.0], [-5.0, 5.0], [5.0, 5.0], [15.0, 5.0], [0.0, -10.0]])
    vis = np.ones((101, 5), dtype=bool)
    vis[::7, 2] = False
    p0 = np.diag([4e-4, 4e-4, 3e-4])
    out = filtered_prediction(pose, vis, refl, (0.3, 0.0, 0.0), 1e-4, 8.0, OdometryNoise(1e-4, 2e-4, 1e-5), p0)
    return {"_recursion": [out.mean_square, out.post_rms]}


def _planning_kernel_outputs(rng: np.random.Generator) -> Outputs:
    """The route planner's A* on a random sparse graph of 300 states (goal, times, predecessors)."""
    n = 300
    rows, cols = rng.integers(0, n, 2400), rng.integers(0, n, 2400)
    order = np.lexsort((cols, rows))
    rows, cols = rows[order], cols[order]
    indptr = np.searchsorted(rows, np.arange(n + 1)).astype(np.int64)
    x, y = rng.uniform(0.0, 50.0, n), rng.uniform(0.0, 50.0, n)
    w = np.hypot(x[rows] - x[cols], y[rows] - y[cols]) * rng.uniform(1.0, 2.0, len(rows))
    goal = np.zeros(n, dtype=np.int64)
    goal[[7, 8]] = 1
    dist, pred, arc, stamp = (np.zeros(n), np.full(n, -1, dtype=np.int64), np.full(n, -1, dtype=np.int64),
                              np.zeros(n, dtype=np.int64))
    lm_from, lm_to = np.abs(x[:, None] - x[None, :2]) * 0.1, np.abs(y[:, None] - y[None, :2]) * 0.1
    best = astar_kernel(indptr, cols.astype(np.int64), w, x, y, np.array([0, 1], dtype=np.int64), goal,
                        float(x[7]), float(y[7]), 0.5, lm_from, lm_to, lm_from[[7, 8]].min(axis=0),
                        lm_to[[7, 8]].max(axis=0), dist, pred, arc, stamp, 1, np.zeros(3000), np.zeros(3000),
                        np.zeros(3000, np.int64))
    return {"astar_kernel": [np.array([best, dist[best]]), np.where(stamp == 1, dist, -1.0), pred.astype(float),
                             arc.astype(float)]}


@pytest.fixture(scope="module")
def both_modes() -> Iterator[tuple[Outputs, Outputs]]:
    """Every kernel's outputs interpreted and compiled (the same seeded inputs), the mode restored after."""
    before = _jit.compiled()
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv("AGVNAV_JIT", raising=False)
        try:
            yield _outputs(False), _outputs(True)
        finally:
            _jit.set_compiled(before)


def _agree(got: Any, want: Any, rtol: float = 1e-12) -> None:
    """``got`` equals ``want`` to ``rtol`` relative to the output's scale; NaN where NaN, inf where inf."""
    g, w = np.asarray(got, dtype=np.float64), np.asarray(want, dtype=np.float64)
    assert g.shape == w.shape
    assert np.array_equal(np.isnan(g), np.isnan(w))
    assert np.array_equal(np.isinf(g), np.isinf(w)) and np.array_equal(g[np.isinf(g)], w[np.isinf(w)])
    fin = np.isfinite(w)
    scale = float(np.max(np.abs(w[fin]), initial=0.0))
    np.testing.assert_allclose(g[fin], w[fin], rtol=rtol, atol=rtol * scale)


def _kernel_names() -> list[str]:
    """Every kernel's name (the modules that define kernels imported), for the parametrized test."""
    return sorted({k.py_func.__name__ for k in _jit.kernels()})


@pytest.mark.parametrize("name", _kernel_names())
def test_every_kernel_s_two_modes_agree_to_rounding(name: str, both_modes: tuple[Outputs, Outputs]) -> None:
    """Interpreted and compiled, each kernel's outputs on the same seeded inputs agree to 1e-12 relative.

    A kernel called only by other kernels is checked through its caller's outputs (:data:`NESTED`).
    """
    interpreted, compiled = both_modes
    key = NESTED.get(name, name)
    cases = [k for k in compiled if k == key or k.startswith(key + " ")]  # "offsets_at 1": one case of offsets_at
    assert cases, f"kernel {name}: no outputs in this test (add its inputs)"
    for case in cases:
        assert len(interpreted[case]) == len(compiled[case]) > 0
        for got, want in zip(compiled[case], interpreted[case], strict=True):
            _agree(got, want)


def test_agree_tells_a_difference_beyond_rounding() -> None:
    """The property's comparison fails on a relative difference of 1e-9 and on NaN against a number."""
    _agree([1.0, math.nan, math.inf, 0.0], [1.0 + 1e-15, math.nan, math.inf, 1e-20])
    for got, want in (([1.0 + 1e-9], [1.0]), ([math.nan], [1.0]), ([math.inf], [-math.inf])):
        with pytest.raises(AssertionError):
            _agree(got, want)


def test_mode_switches_and_environment_wins(monkeypatch: pytest.MonkeyPatch) -> None:
    _jit.set_compiled(False)
    assert not _jit.compiled()
    k = beam.offset_one
    k(0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.04, 0.0, 0.0, 0.0, 1.0, 1)
    assert k._impl is k.py_func  # type: ignore[attr-defined]
    monkeypatch.setenv("AGVNAV_JIT", "1")
    _jit.set_compiled(False)
    assert _jit.compiled()
    monkeypatch.setenv("AGVNAV_JIT", "0")
    assert _jit.compiled()  # the environment is read when the mode is resolved, not on every call
    monkeypatch.setenv("AGVNAV_JIT", "maybe")
    with pytest.raises(ValueError, match="AGVNAV_JIT"):
        _jit.set_compiled(True)
    monkeypatch.delenv("AGVNAV_JIT")


def test_a_forced_mode_wins_over_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    """``set_compiled(on, force=True)`` (``agvnav simulate --jit``) wins over ``AGVNAV_JIT``; ``mode`` names it."""
    monkeypatch.setenv("AGVNAV_JIT", "1")
    _jit.set_compiled(False)
    assert _jit.compiled() and _jit.mode() == "compiled"  # not forced: the environment wins
    _jit.set_compiled(False, force=True)
    assert not _jit.compiled() and _jit.mode() == "interpreted"
    _jit.set_compiled(False)
    assert _jit.compiled()  # a later call without force gives the environment back its say


def test_by_mode_runs_the_implementation_of_the_mode_in_force(monkeypatch: pytest.MonkeyPatch) -> None:
    """``by_mode`` looks the mode up at each call: the caller never asks which mode runs."""
    monkeypatch.delenv("AGVNAV_JIT", raising=False)
    before = _jit.compiled()
    run = _jit.by_mode(lambda x, k=1: ("compiled", x, k), lambda x, k=1: ("interpreted", x, k))
    try:
        _jit.set_compiled(True)
        assert run(2, k=3) == ("compiled", 2, 3)
        _jit.set_compiled(False)
        assert run(2) == ("interpreted", 2, 1)
    finally:
        _jit.set_compiled(before)


def test_set_compiled_for_run_picks_by_work() -> None:
    assert not _jit.set_compiled_for_run(26.0, 9)  # the default scenario: numba's start-up costs more
    assert _jit.set_compiled_for_run(406.0, 102)  # warehouse_mission: compiled pays
    assert _jit.compiled()
    with pytest.raises(ValueError, match="sim_seconds"):
        _jit.set_compiled_for_run(-1.0, 3)


def test_a_safety_scanner_s_rays_tip_a_short_run_to_compiled() -> None:
    """The scanner's rays cost ~0.8 us per ray and surface as plain Python: a 26 s run scanning at 12.5 Hz
    compiles (issue 28: the rays are a kernel now)."""
    from agvnav.sensors.scanner import SafetyScanner

    extra = SafetyScanner(rate_hz=12.5).interpreted_cost_s(26.0, 28)
    assert 2.0 < extra < 10.0
    assert _jit.set_compiled_for_run(26.0, 9, extra)
    assert not _jit.set_compiled_for_run(26.0, 9, 0.0)
    with pytest.raises(ValueError, match="extra_s"):
        _jit.set_compiled_for_run(26.0, 9, -1.0)


def test_set_compiled_for_run_reports_the_mode_in_force(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AGVNAV_JIT", "1")
    assert _jit.set_compiled_for_run(26.0, 9)  # the estimate says interpreted; the environment wins
    monkeypatch.setenv("AGVNAV_JIT", "0")
    assert not _jit.set_compiled_for_run(406.0, 102)


def test_the_wrap_kernel_is_wrap_angle_in_both_modes() -> None:
    """One scalar wrap (geometry.angles), compiled or not: wrap_angle's values, NaN for NaN and +-inf."""
    rng = np.random.default_rng(5)
    a = np.concatenate([rng.uniform(-40.0, 40.0, 2_000), rng.normal(0.0, 1e-3, 200),
                        [math.pi, -math.pi, 3 * math.pi, -3 * math.pi, 0.0, -0.0, 5e-324, 1e300, -1e300]])
    want = wrap_angle(a)
    for on in (False, True):
        _jit.set_compiled(on)
        got = np.array([wrap_angle_kernel(float(v)) for v in a])
        assert np.array_equal(got, want)  # exact: the wrap is fmod (exact) and a comparison
        assert all(math.isnan(wrap_angle_kernel(v)) for v in (math.nan, math.inf, -math.inf))
    assert np.array_equal(np.array([wrap_angle_scalar(float(v)) for v in a]), want)


def test_the_public_module_is_the_cli_s_way_in() -> None:
    """agvnav.jit exposes the mode functions; the CLI uses it, not the private agvnav._jit."""
    import agvnav.jit as public

    assert public.set_compiled_for_run is _jit.set_compiled_for_run and public.compiled is _jit.compiled
    cli = Path(public.__file__).parent / "cli"
    users = [p.name for p in cli.rglob("*.py") if "agvnav._jit" in p.read_text(encoding="utf-8")]
    assert users == []


def test_kernel_bound_follows_the_mode() -> None:
    """``Kernel.bound`` is what a call runs: the plain function interpreted, the dispatcher compiled."""
    k = _fast.MOVE_STATE
    _jit.set_compiled(False)
    assert k.bound() is k.py_func
    _jit.set_compiled(True)
    assert k.bound() is k.dispatcher()
    args = ((0.0, 0.0, 0.0), (1.0, 2.0, 0.3), (1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-5),
            (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (0.0,) * 6, 0.01, 0.002, 0.0,
            _fast.move_constants((1e-3, 3e-3, 1e-3, 1e-3), None, True, False, (0.0, 0.0)))
    assert k.bound()(*args) == k.py_func(*args) == k(*args)
