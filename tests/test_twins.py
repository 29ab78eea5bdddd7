"""One parametrized equivalence test over the twin table (``agvnav.twins``), and its guard.

Every row of ``agvnav.twins.TWINS`` has a case here that draws random inputs and
returns both forms' outputs; the test asserts they agree to the row's ``atol``.
The guard fails when the source holds a scalar twin (a public name of a
``*.scalar`` module, or a function/method named ``*_scalar``/``*_few``/``*_one``
that says it mirrors another form) that the table does not list.
"""

from __future__ import annotations

import ast
import contextlib
import importlib
import math
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

import agvnav
from agvnav import _jit
from agvnav.actuators import PID, MotorPair, WheelSpeedLoop
from agvnav.actuators.scalar import ScalarSpeedLoop
from agvnav.actuators.speed_profile import _profile_speed_scalar, profile_speed
from agvnav.actuators.steering import _steering_step_scalar, steering_step
from agvnav.geometry.angles import wrap_angle, wrap_angle_scalar
from agvnav.guidance.errors import tracking_errors, tracking_errors_scalar
from agvnav.guidance.paths import ArcSegment, LineSegment
from agvnav.guidance.paths import Path as GPath
from agvnav.kinematics import TricycleStacker, twist_step
from agvnav.kinematics.scalar import stacker_rate, stacker_rk4, stacker_rk4_values, track_twist, twist_pose
from agvnav.kinematics.tracked import TrackedVehicle, TrackSlipNoise
from agvnav.odometry import (
    calibration_jacobian,
    differential_increments,
    motion_covariance,
    steered_noise,
    tricycle_increments,
)
from agvnav.odometry.errors import NonSystematicErrors
from agvnav.odometry.scalar import differential_increments_scalar, track_increments, tricycle_increments_scalar
from agvnav.positioning import _fast as pos_fast
from agvnav.positioning import _integrity_fast as integrity_fast
from agvnav.positioning import triangulate
from agvnav.positioning.bounds import crlb, inv_sym3
from agvnav.positioning.ekf import CONSIDER_MAX_ENTRY, CONSIDER_MIN_DET, EkfEstimator
from agvnav.positioning.gating import BearingIndex, GateSpec
from agvnav.positioning.identification import Association, bearing_model, gate_reflection
from agvnav.positioning.triangulation import _nonlinear
from agvnav.sensors.beam import wrapped_offsets
from agvnav.sensors.goniometer import Goniometer
from agvnav.twins import TWINS, Twin, twin_names
from agvnav.world import load_builtin_map

SRC = Path(agvnav.__file__).parent
N_DRAWS = 40
Pair = tuple[object, object]


def _resolve(ref: str) -> object:
    module, _, qual = ref.partition(":")
    obj: object = importlib.import_module(module)
    for part in qual.split("."):
        obj = getattr(obj, part)
    return obj


def _wrap(rng: np.random.Generator) -> Pair:
    a = [float(v) for v in rng.uniform(-20, 20, 8)] + [math.pi, -math.pi, 3 * math.pi, 0.0]
    return [wrap_angle_scalar(v) for v in a], wrap_angle(np.array(a))


def _stacker_rk4(rng: np.random.Generator) -> Pair:
    model = TricycleStacker(1.1)
    model.substeps = 1
    x = np.array([*rng.normal(size=2), rng.uniform(-3, 3), rng.uniform(-1.4, 1.4)])
    u = rng.normal(size=2)
    return stacker_rk4(x, u[0], u[1], 1.1, 0.05)[0], model.step(x, u, 0.05)


def _stacker_rk4_values(rng: np.random.Generator) -> Pair:
    model = TricycleStacker(1.1)
    model.substeps = 1
    x = np.array([*rng.normal(size=2), rng.uniform(-3, 3), rng.uniform(-1.4, 1.4)])
    u = rng.normal(size=2)
    new, start, end = stacker_rk4_values(x.tolist(), u[0], u[1], 1.1, 0.05)
    ref = model.step(x, u, 0.05)
    return [*new, *start, *end], [*ref, *model.derivative(x, u), *model.derivative(ref, u)]


def _stacker_rate(rng: np.random.Generator) -> Pair:
    x = np.array([*rng.normal(size=2), rng.uniform(-3, 3), rng.uniform(-1.4, 1.4)])
    u = rng.normal(size=2)
    return stacker_rate(x[2], x[3], u[0], u[1], 1.1), TricycleStacker(1.1).derivative(x, u)


def _twist_pose(rng: np.random.Generator) -> Pair:
    x, y, th = rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-7, 7)
    vx, vy = rng.uniform(-3, 3, 2)
    w = rng.choice([rng.uniform(-5, 5), 1e-7])
    h = rng.uniform(1e-4, 0.2)
    return twist_pose(x, y, th, vx, vy, w, h), twist_step(np.array([x, y, th]), vx, vy, w, h)


def _tracked(rng: np.random.Generator) -> object:
    return TrackedVehicle(0.33, 0.05, str(rng.choice(["concrete", "artificial_grass", "ideal"])))


def _track_twist(rng: np.random.Generator) -> Pair:
    veh, u = _tracked(rng), rng.uniform(-1, 1, 2)
    return track_twist(u[0], u[1], veh.twist_matrix.tolist()), veh.body_twist(u)  # type: ignore[attr-defined]


def _track_increments(rng: np.random.Generator) -> Pair:
    veh, d = _tracked(rng), rng.uniform(-0.2, 0.2, 2)
    twist = veh.body_twist(d)  # type: ignore[attr-defined]
    return track_increments(d[0], d[1], veh.twist_matrix.tolist()), [twist[0], twist[2]]  # type: ignore[attr-defined]


def _track_factors(rng: np.random.Generator) -> Pair:
    terrain = TrackSlipNoise(std=float(rng.uniform(0, 0.05)))
    seed, d = int(rng.integers(1 << 30)), float(rng.choice([rng.uniform(0, 2), 0.0]))
    return (terrain.factors_scalar(d, np.random.default_rng(seed)),
            terrain.factors(d, np.random.default_rng(seed)))


def _tricycle_increments(rng: np.random.Generator) -> Pair:
    ds, g = rng.uniform(-0.3, 0.3), rng.uniform(-1.5, 1.5)
    return tricycle_increments_scalar(ds, g, 1.2), np.asarray(tricycle_increments(ds, g, 1.2))


def _differential_increments(rng: np.random.Generator) -> Pair:
    dr, dl = rng.uniform(-0.3, 0.3, 2)
    return differential_increments_scalar(dr, dl, 0.5), np.asarray(differential_increments(dr, dl, 0.5))


def _perturb(rng: np.random.Generator) -> Pair:
    std = float(rng.uniform(0.0, 0.05))
    model = NonSystematicErrors(slip_k=std * std, bump_rate=float(rng.choice([0.0, 2.0])))
    seed, d = int(rng.integers(1 << 30)), float(rng.uniform(-0.3, 0.3))
    return model.perturb_scalar(d, np.random.default_rng(seed)), model.perturb(d, np.random.default_rng(seed))


def _speed_loop(rng: np.random.Generator) -> Pair:
    ref = WheelSpeedLoop(MotorPair(asymmetry=0.05), PID())
    fast = ScalarSpeedLoop(WheelSpeedLoop(MotorPair(asymmetry=0.05), PID()))
    a, b = [], []
    for _ in range(20):
        sp = rng.uniform(-6, 6, 2)
        a.append(ref.step(sp, 0.01))
        b.append(fast.step((float(sp[0]), float(sp[1])), 0.01))
    return b, a


def _steering_step(rng: np.random.Generator) -> Pair:
    g, r, cmd = rng.uniform(-1.5, 1.5), rng.uniform(-1, 1), rng.uniform(-2, 2)
    dt, tau = rng.uniform(0.01, 0.1), float(rng.choice([0.0, rng.uniform(0.01, 0.2)]))
    ref = steering_step(g, r, cmd, dt, tau, 1.0, 1.4)
    return _steering_step_scalar(g, r, cmd, dt, tau, 1.0, 1.4), [float(ref[0]), float(ref[1])]


def _profile_speed(rng: np.random.Generator) -> Pair:
    v, target, rem, dt = rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-0.1, 3), rng.uniform(0.01, 0.1)
    return _profile_speed_scalar(v, target, rem, dt, 0.3, 0.4), profile_speed(v, target, rem, dt, 0.3, 0.4)


def _path() -> object:
    line = LineSegment(np.array([1.0, 2.0]), 0.3, 3.0)
    arc = ArcSegment(line.end, 0.3, 1.5, 2.0)
    return GPath([line, arc])


def _segment(kind: str) -> object:
    return _path().segments[0 if kind == "line" else 1]  # type: ignore[attr-defined]


def _segment_point(kind: str) -> Callable[[np.random.Generator], Pair]:
    def case(rng: np.random.Generator) -> Pair:
        seg, u = _segment(kind), float(rng.uniform(-1, 4))
        return seg.point_scalar(u), seg.point_at(u)  # type: ignore[attr-defined]
    return case


def _segment_project(kind: str) -> Callable[[np.random.Generator], Pair]:
    def case(rng: np.random.Generator) -> Pair:
        seg, (x, y) = _segment(kind), rng.uniform(-1, 6, 2)
        lo = float(rng.uniform(0, 1))
        hi = lo + float(rng.uniform(0, 2))
        u = seg.project_scalar(x, y, lo, hi)[0]  # type: ignore[attr-defined]
        return u, seg.local_projection(np.array([x, y]), lo, hi)  # type: ignore[attr-defined]
    return case


def _path_project(rng: np.random.Generator) -> Pair:
    path, (x, y) = _path(), rng.uniform(-1, 6, 2)
    pr, ref = path.project_point(x, y), path.project(np.array([x, y]))  # type: ignore[attr-defined]
    length = float(path.length)  # type: ignore[attr-defined]
    hint, window = float(rng.uniform(0.0, length)), float(rng.uniform(0.05, 0.5 * length))  # a windowed search
    pw = path.project_point(x, y, hint, window)  # type: ignore[attr-defined]
    rw = path.project(np.array([x, y]), hint, window)  # type: ignore[attr-defined]
    return ([pr.s, pr.lateral, pr.heading, pw.s, pw.lateral, pw.heading],
            [float(ref.s), float(ref.lateral), float(ref.heading), float(rw.s), float(rw.lateral), float(rw.heading)])


def _tracking_errors(rng: np.random.Generator) -> Pair:
    path = _path()
    pose = (float(rng.uniform(0, 5)), float(rng.uniform(1, 5)), float(rng.uniform(-3, 3)))
    g, point = float(rng.uniform(-0.5, 0.5)), str(rng.choice(["C", "O"]))
    a = tracking_errors_scalar(path, pose, g, 1.0, point)  # type: ignore[arg-type]
    b = tracking_errors(path, np.array(pose), g, 1.0, point)  # type: ignore[arg-type]
    return [a.eps_c, a.eps_o, a.xi, a.xi_r], [float(b.eps_c), float(b.eps_o), float(b.xi), float(b.xi_r)]


def _goniometer() -> object:
    return Goniometer(rate_hz=8.0, mount=(0.3, 0.1, 0.2))


def _encoder_bearing(rng: np.random.Generator) -> Pair:
    gon, t = _goniometer(), rng.uniform(0, 3600, 5)
    return gon._encoder_bearing_few(t), gon.encoder_bearing(t)  # type: ignore[attr-defined]


def _gate_one(rng: np.random.Generator) -> Pair:
    world = load_builtin_map("lab")
    xy, radius = world.reflector_xy, world.reflector_radius
    pose, mount = rng.uniform([2, 2, -math.pi], [18, 10, math.pi]), (0.3, 0.05, 0.01)
    a = rng.normal(0.0, 0.01, (3, 3))
    P = a @ a.T + 1e-6 * np.eye(3)
    h, _, _ = bearing_model(pose, mount, xy, radius)
    z = float(wrap_angle(h[int(rng.integers(xy.shape[0]))] + rng.normal(0.0, 3e-3)))
    ref = gate_reflection(z, pose, P, mount, xy, radius, 1e-7, gate=10.8, map_std=0.002)
    spec = GateSpec(bearing_var=1e-7, max_range=math.inf, gate=10.8, map_std=0.002, sweep=0.1)
    got = pos_fast.gate_one(z, tuple(pose.tolist()), tuple(P.reshape(9).tolist()), mount,
                            pos_fast.reflector_rows(xy, radius), spec, [-math.inf] * xy.shape[0], 1.05)
    if ref.index < 0:
        return [got[0], got[3]], [ref.index, ref.n_in_gate]
    return [got[0], got[3], got[1], got[2]], [ref.index, ref.n_in_gate, ref.innovation, ref.nis]


def _wrapped_offsets(rng: np.random.Generator) -> Pair:
    raw = np.concatenate([rng.uniform(-40, 40, 8), [math.pi, -math.pi, 3 * math.pi, 0.0]])
    f, worst = wrapped_offsets(raw)
    ref = wrap_angle(raw)
    return [*f, worst], [*ref, np.abs(ref).max()]


def _steered_noise(rng: np.random.Generator) -> Pair:
    front = bool(rng.integers(2))
    L = rng.uniform(0.8, 2.0)
    noise = steered_noise("tricycle" if front else "tricycle_rear", 1e-4, L, 1e-3, 0.02, 0.003, 0.004)
    pose = np.array([*rng.normal(size=2), rng.uniform(-math.pi, math.pi)])
    s, g = rng.uniform(-0.3, 0.3), rng.uniform(-1.2, 1.2)
    dd, dth = (s * math.cos(g), s * math.sin(g) / L) if front else (s, s * math.tan(g) / L)
    Q, W = pos_fast.steered_noise(float(pose[2]), dd, dth, front, L, noise.slip_k,
                                  noise.steering_std**2 * noise.step_m)
    ref = [*motion_covariance(pose, dd, dth, noise).ravel(), *calibration_jacobian(pose, dd, dth, noise).ravel()]
    return [*Q, *W], ref


def _random_state(rng: np.random.Generator) -> tuple[tuple[float, ...], ...]:
    """A pose, a covariance, a consider factor ``M`` and a calibration cross-covariance ``P_xc`` (flat tuples)."""
    pose = (*rng.uniform([2.0, 2.0], [18.0, 10.0]).tolist(), float(rng.uniform(-math.pi, math.pi)))
    a = rng.normal(0.0, 0.01, (3, 3))
    P = tuple((a @ a.T + 1e-6 * np.eye(3)).reshape(9).tolist())
    M = tuple((np.eye(3) + rng.normal(0.0, 0.3, (3, 3))).reshape(9).tolist())
    X = tuple(rng.normal(0.0, 1e-4, 6).tolist())
    return pose, P, M, X


def _move_state(rng: np.random.Generator) -> Pair:
    """The compiled prediction against the plain functions it fuses (every noise model, lateral or not)."""
    odom, pose, P, M, X = (*rng.normal(size=2).tolist(), 1.0), *_random_state(rng)
    kind, calibrated = int(rng.integers(3)), bool(rng.integers(2))
    L = float(rng.uniform(0.8, 2.0))
    steered = None if kind == 0 else (kind == 1, L, 1e-3, 4e-5, float(rng.choice([0.0, 0.5])))
    noise, cvar = (1e-4, 2e-4, 1e-5, 3e-4), (9e-6, 1.2e-5)
    dd, dth = float(rng.uniform(-0.05, 0.05)), float(rng.choice([0.0, 1e-6, rng.uniform(-0.05, 0.05)]))
    dl = 0.0 if rng.uniform() < 0.7 else float(rng.uniform(-0.02, 0.02))
    if rng.uniform() < 0.1:
        dd = 0.0  # a rear wheel that does not roll (steered_noise's s = 0)
    hyp = math.hypot(dd, dl) if steered is None or dl != 0.0 else math.hypot(dd, L * dth) if steered[0] else 0.0
    mc = pos_fast.move_constants(noise, steered, True, calibrated, cvar)
    o, x, Pn, Mn, Xn = pos_fast.move_state(odom, pose, P, M, X, dd, dth, dl, hyp, mc)
    ro = pos_fast.twist_step(*odom, dd, dth, dl)[:3]
    nx, ny, npsi, f02, f12 = pos_fast.twist_step(*pose, dd, dth, dl)
    W = None
    if steered is None or dl != 0.0:
        Q = pos_fast.process_noise(pose[2], dd, dth, *noise[:3], dl, noise[3])
    else:
        Q, W = pos_fast.steered_noise(pose[2], dd, dth, *steered)
    rP, rX = pos_fast.predict_covariance(P, f02, f12, Q), X
    if W is not None and calibrated:
        rP, rX = pos_fast.calibration_predict(rP, X, f02, f12, W, cvar)
    return [*o, *x, *Pn, *Mn, *Xn], [*ro, nx, ny, pos_fast.wrap(npsi), *rP, *pos_fast.shear(M, f02, f12), *rX]


def _gate_setup(rng: np.random.Generator, consider: bool) -> tuple[object, ...]:
    world = load_builtin_map("lab")
    n_extra = int(rng.choice([0, 40]))  # 40 more: the index's grid pre-selects the candidates
    xy = np.vstack([world.reflector_xy, rng.uniform([0.5, 0.5], [19.5, 11.5], (n_extra, 2))])
    radius = np.concatenate([world.reflector_radius, rng.uniform(0.02, 0.05, n_extra)])
    mount = (0.3, 0.05, 0.01)
    spec = GateSpec(bearing_var=1e-7, max_range=25.0, gate=10.8, map_std=0.002, sweep=0.1, consider=consider)
    pose, P, M, X = _random_state(rng)
    h, _, _ = bearing_model(np.array(pose), mount, xy, radius)
    z = float(wrap_angle(h[int(rng.integers(xy.shape[0]))] + rng.normal(0.0, 3e-3)))
    sight = rng.uniform(size=xy.shape[0]) < 0.9
    claimed = np.where(rng.uniform(size=xy.shape[0]) < 0.1, 1.0, -math.inf)
    svar = rng.uniform(1e-6, 4e-6, xy.shape[0])
    C = rng.normal(0.0, 1e-3, (xy.shape[0], 6))
    rows = pos_fast.reflector_rows(xy, radius)
    index = BearingIndex(xy, radius, mount, spec) if n_extra else None
    return z, pose, P, M, X, mount, spec, rows, index, sight, claimed, svar, C


def _gate_rows(rng: np.random.Generator) -> Pair:
    """The compiled gate (index, sight, claims, consider or not) against ``gate_one`` on the same candidates."""
    consider = bool(rng.integers(2))
    z, pose, P, M, _, mount, spec, rows, index, sight, claimed, svar, C = _gate_setup(rng, consider)
    gc = pos_fast.gate_constants(spec, mount, None if index is None else index.grid_constants(), 1e-7)
    cells = (np.zeros(2, np.int64), np.zeros(0, np.int64)) if index is None else index.grid_cells()
    got = pos_fast.gate_rows(z, 1.05, pose, P, M, C, claimed, sight, pos_fast.gate_table(rows, svar), gc, *cells)
    cand = range(len(rows)) if index is None else index.candidates(z, pose, P)
    j, y, nis, n_in, H, S, R = pos_fast.gate_one(z, pose, P, mount, rows, spec, claimed.tolist(), 1.05,
                                                 [c for c in cand if sight[c]],
                                                 (M, C, svar.tolist()) if consider else None)
    return list(got), [j, y, nis, n_in, *H, S, R]


def _gate_accept(rng: np.random.Generator) -> Pair:
    """The compiled gate and Schmidt update against ``gate_one`` and the EKF's plain ``_accept``."""
    z, pose, P, M, X, mount, spec, rows, index, sight, claimed, svar, C = _gate_setup(rng, True)
    calibrated = bool(rng.integers(2))
    if rng.uniform() < 0.2:
        M = tuple((0.2 * np.asarray(M)).tolist())  # |det M| small: the update asks for a fold
    bearing_std = 1e-7**0.5
    gc = pos_fast.gate_constants(spec, mount, None if index is None else index.grid_constants(), bearing_std**2,
                                 CONSIDER_MIN_DET, CONSIDER_MAX_ENTRY, calibrated)
    cells = (np.zeros(2, np.int64), np.zeros(0, np.int64)) if index is None else index.grid_cells()
    C_got = C.copy()
    (j, _, _, n_in, *_), x1, P1, _, M1, X1, fold = pos_fast.gate_accept(
        z, 1.05, pose, P, M, X, C_got, claimed, sight, pos_fast.gate_table(rows, svar), gc, *cells)
    cand = range(len(rows)) if index is None else index.candidates(z, pose, P)
    ref = pos_fast.gate_one(z, pose, P, mount, rows, spec, claimed.tolist(), 1.05, [c for c in cand if sight[c]],
                            (M, C, svar.tolist()))
    if ref[0] < 0:
        return [j, n_in, *x1, *P1, *C_got.ravel()], [ref[0], ref[3], *pose, *P, *C.ravel()]
    est = object.__new__(EkfEstimator)  # the plain update on this state (no map, no run: the method's own arithmetic)
    est._x_t, est._P_t, est._M, est._Pxc, est._C = pose, P, M, X, C.copy()
    est._svar, est._calibrated, est.bearing_std = svar.tolist(), calibrated, bearing_std
    assoc = Association(ref[0], ref[1], ref[2], ref[3], np.array(ref[4]), ref[5], ref[6])
    with _plain_mode():
        est._accept(1.05, z, assoc)
    if fold:  # the kernel leaves C and the fold to the caller: compare its pose and covariance only
        return [j, *x1, *P1, *X1], [ref[0], *est._x_t, *est._P_t, *est._Pxc]
    return [j, *x1, *P1, *M1, *X1, *C_got.ravel()], [ref[0], *est._x_t, *est._P_t, *est._M, *est._Pxc, *est._C.ravel()]


def _three_bearings(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, tuple[float, ...]]:
    """Three reflectors (m), the bearings (rad) of a random head among them, and three bearing stds (rad)."""
    r = rng.uniform(-10.0, 10.0, (3, 2))
    p, psi = rng.uniform(-10.0, 10.0, 2), rng.uniform(-math.pi, math.pi)
    z = np.array([wrap_angle_scalar(v) for v in (np.arctan2(r[:, 1] - p[1], r[:, 0] - p[0]) - psi).tolist()])
    return r, z + rng.normal(0.0, 1e-3, 3), tuple(rng.uniform(1e-4, 5e-3, 3).tolist())


def _total_fix(rng: np.random.Generator) -> Pair:
    while True:
        r, z, _ = _three_bearings(rng)
        code, px, py = integrity_fast.total_fix(*r.reshape(-1).tolist(), *z.tolist())
        if code != integrity_fast.TOTAL_FALLBACK:  # the rare path is triangulate itself
            break
    fix = triangulate(r, z, method="total")
    valid = code == integrity_fast.TOTAL_VALID
    return (float(valid), px if valid else math.nan, py if valid else math.nan), (
        float(bool(fix.valid)), float(fix.x), float(fix.y))


def _fix_covariance(rng: np.random.Generator) -> Pair:
    r, _, std = _three_bearings(rng)
    p = rng.uniform(-10.0, 10.0, 2)
    _ok, *c = integrity_fast.fix_covariance(tuple(r[:, 0].tolist()), tuple(r[:, 1].tolist()), *p.tolist(), std)
    ref = crlb(r, np.array([*p.tolist(), 0.3]), np.array(std))
    return c, ref[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]


def _nonlinear_fix(rng: np.random.Generator) -> Pair:
    r = rng.uniform(-5.0, 5.0, (3, 2))
    px, py = rng.uniform(-5.0, 5.0, 2).tolist()
    c00, c11, c01 = rng.uniform(1e-4, 1e-1), rng.uniform(1e-4, 1e-1), rng.uniform(-1e-5, 1e-5)
    cov = np.array([[[c00, c01, 0.0], [c01, c11, 0.0], [0.0, 0.0, 1.0]]])
    got = integrity_fast.nonlinear_fix(tuple(r[:, 0].tolist()), tuple(r[:, 1].tolist()), px, py, c00, c01, c11)
    return float(got), float(_nonlinear(r, np.array([px]), np.array([py]), cov, np.array([False]))[0])


def _py_hypot(rng: np.random.Generator) -> Pair:
    x, y = (rng.standard_normal(2) * 10.0 ** rng.uniform(-6, 6, 2)).tolist()
    return integrity_fast.py_hypot(x, y), math.hypot(x, y)


def _edge_bearing(rng: np.random.Generator) -> Pair:
    pose, mount = rng.uniform(-10.0, 10.0, 3), (*rng.uniform(-0.5, 0.5, 2).tolist(), float(rng.uniform(-0.3, 0.3)))
    rx, ry, r = *rng.uniform(-10.0, 10.0, 2).tolist(), float(rng.uniform(0.0, 0.1))
    head = integrity_fast._head(*pose.tolist(), *mount)
    got = integrity_fast._edge_bearing(*head, rx, ry, r)
    h, _, d = bearing_model(pose, np.array(mount), np.array([rx, ry]), r)
    return got, (float(h), float(d))


def _inverse3(rng: np.random.Generator) -> Pair:
    a = rng.normal(size=(3, 3))
    a = a @ a.T + 0.1 * np.eye(3)  # symmetric positive definite, as the information matrices
    ok, *inv = integrity_fast._inverse3(*a[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]].tolist(), 3.0)
    ref, valid = inv_sym3(a)
    return (float(ok), *inv), (float(valid), *ref[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]].tolist())


@contextlib.contextmanager
def _plain_mode() -> Iterator[None]:
    """The kernels interpreted while inside: the estimators take their plain Python path."""
    before = _jit.compiled()
    _jit.set_compiled(False)
    try:
        yield
    finally:
        _jit.set_compiled(before)


CASES: dict[str, Callable[[np.random.Generator], Pair]] = {
    "wrap_angle": _wrap, "stacker_rk4": _stacker_rk4, "stacker_rk4_values": _stacker_rk4_values,
    "stacker_rate": _stacker_rate, "twist_pose": _twist_pose,
    "track_twist": _track_twist, "track_factors": _track_factors, "tricycle_increments": _tricycle_increments,
    "track_increments": _track_increments, "differential_increments": _differential_increments,
    "perturb": _perturb, "speed_loop": _speed_loop, "steering_step": _steering_step,
    "profile_speed": _profile_speed, "tracking_errors": _tracking_errors,
    "line_point": _segment_point("line"), "line_project": _segment_project("line"),
    "arc_point": _segment_point("arc"), "arc_project": _segment_project("arc"),
    "path_project": _path_project, "encoder_bearing": _encoder_bearing, "gate_one": _gate_one,
    "wrapped_offsets": _wrapped_offsets, "steered_noise": _steered_noise,
    "move_state": _move_state, "gate_rows": _gate_rows, "gate_accept": _gate_accept,
    "total_fix": _total_fix, "fix_covariance": _fix_covariance, "nonlinear_fix": _nonlinear_fix,
    "py_hypot": _py_hypot, "edge_bearing": _edge_bearing, "inverse3": _inverse3,
}


@pytest.mark.parametrize("twin", TWINS, ids=lambda t: t.name)
def test_twin_forms_agree(twin: Twin) -> None:
    """Both forms exist and agree to the row's tolerance on random inputs."""
    assert callable(_resolve(twin.scalar)) and callable(_resolve(twin.reference))
    assert twin.name in CASES, f"twin {twin.name!r} has no equivalence case in tests/test_twins.py"
    rng = np.random.default_rng(11)
    for _ in range(N_DRAWS):
        got, ref = CASES[twin.name](rng)
        np.testing.assert_allclose(np.asarray(got, dtype=float), np.asarray(ref, dtype=float).reshape(np.shape(got)),
                                   rtol=0, atol=twin.atol, err_msg=twin.name)


def test_twin_names_unique_and_every_case_listed() -> None:
    names = [t.name for t in TWINS]
    assert len(names) == len(set(names))
    assert set(CASES) == set(names)


_SUFFIXES = ("_scalar", "_few", "_one")
_MIRROR_WORDS = ("fast path", "mirrors", "same arithmetic", "same operations", "same equations")


def _scalar_twins_in_source() -> set[str]:
    """``module:qualname`` of every scalar twin the source declares (see the module doc)."""
    found: set[str] = set()
    for path in SRC.rglob("*.py"):
        rel = path.relative_to(SRC.parent).with_suffix("")
        module = ".".join(p for p in rel.parts if p != "__init__")
        tree = ast.parse(path.read_text(encoding="utf-8"))
        is_scalar_module = path.stem == "scalar"
        for node in tree.body:
            items = [(node, node.name)] if isinstance(node, (ast.FunctionDef, ast.ClassDef)) else []
            if isinstance(node, ast.ClassDef):
                items += [(m, f"{node.name}.{m.name}") for m in node.body if isinstance(m, ast.FunctionDef)]
            for item, qual in items:
                doc = (ast.get_docstring(item) or "").lower()
                named = item.name.endswith(_SUFFIXES) and any(w in doc for w in _MIRROR_WORDS)
                top_level_public = is_scalar_module and "." not in qual and not item.name.startswith("_")
                if named or (top_level_public and isinstance(item, ast.FunctionDef)):
                    found.add(f"{module}:{qual}")
                if top_level_public and isinstance(item, ast.ClassDef):
                    found.update(f"{module}:{qual}.{m.name}" for m in item.body
                                 if isinstance(m, ast.FunctionDef) and not m.name.startswith("_"))
    return found


def test_every_scalar_twin_in_the_source_is_in_the_table() -> None:
    missing = sorted(_scalar_twins_in_source() - twin_names())
    assert not missing, "scalar twins missing from agvnav.twins.TWINS (add a row and a case):\n" + "\n".join(missing)


def test_guard_sees_known_twins() -> None:
    """The guard is not vacuous: it finds the scalar modules' kernels and a ``*_scalar`` method."""
    found = _scalar_twins_in_source()
    assert "agvnav.kinematics.scalar:twist_pose" in found
    assert "agvnav.guidance.paths:ArcSegment.project_scalar" in found
