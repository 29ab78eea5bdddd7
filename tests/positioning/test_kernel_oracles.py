"""Each kernel of the positioning inner loops against its oracle: the NumPy (or public) form of its equation.

The leading-edge bearing and its Jacobian (seed 000 §2.1) against
:func:`~agvnav.positioning.edge_bearing.bearing_model`, the odometry noise [seed002 eq17] against
:func:`~agvnav.odometry.motion_covariance`, the gate against ``gate_one`` and the Schmidt-Kalman
update written in NumPy, the integrity check's fix against triangulate and the CRLB. One
parametrized test; the kernels' two modes agree to rounding (``tests/test_jit.py``), so these run
in the default one.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from agvnav.geometry.angles import wrap_angle, wrap_angle_scalar
from agvnav.odometry import OdometryNoise, calibration_jacobian, motion_covariance, steered_noise
from agvnav.positioning import _fast as pos_fast
from agvnav.positioning import _integrity_fast as integrity_fast
from agvnav.positioning import triangulate
from agvnav.positioning.bounds import crlb, inv_sym3
from agvnav.positioning.edge_bearing import bearing_model
from agvnav.positioning.ekf import CONSIDER_MAX_ENTRY, CONSIDER_MIN_DET
from agvnav.positioning.fix_covariance import _nonlinear
from agvnav.positioning.gating import BearingIndex, GateSpec
from agvnav.sensors.beam import wrapped_offsets
from agvnav.world import load_builtin_map

N_DRAWS = 40
Pair = tuple[object, object]


def _bearing_row(rng: np.random.Generator) -> Pair:
    """The EKF's measurement model (edge_bearing and bearing_jacobian kernels) against bearing_model, h and H."""
    pose = np.array([*rng.uniform(-10.0, 10.0, 2).tolist(), float(rng.uniform(-math.pi, math.pi))])
    mount = (*rng.uniform(-0.5, 0.5, 2).tolist(), float(rng.uniform(-0.3, 0.3)))
    rx, ry, r = *rng.uniform(-10.0, 10.0, 2).tolist(), float(rng.uniform(0.0, 0.1))
    c, s = math.cos(pose[2]), math.sin(pose[2])
    px, py = pose[0] + c * mount[0] - s * mount[1], pose[1] + s * mount[0] + c * mount[1]
    dpx, dpy = -s * mount[0] - c * mount[1], c * mount[0] - s * mount[1]
    h, dx, dy, d2, d = pos_fast.edge_bearing(px, py, float(pose[2]), mount[2], rx, ry, r)
    row = pos_fast.bearing_jacobian(dx, dy, d2, d, r, dpx, dpy)
    ref_h, ref_H, ref_d = bearing_model(pose, np.array(mount), np.array([rx, ry]), r)
    return [h, *row, d], [float(ref_h), *ref_H.tolist(), float(ref_d)]


def _process_noise(rng: np.random.Generator) -> Pair:
    """``Q`` of one increment [seed002 eq17] against motion_covariance (arc rule, no lateral step)."""
    noise = OdometryNoise(*rng.uniform(1e-5, 1e-3, 3).tolist())
    pose = np.array([*rng.normal(size=2), rng.uniform(-math.pi, math.pi)])
    dd, dth = float(rng.uniform(-0.1, 0.1)), float(rng.choice([0.0, 1e-7, rng.uniform(-0.1, 0.1)]))
    Q = pos_fast.process_noise(float(pose[2]), dd, dth, noise.k_d, noise.k_dtheta, noise.k_theta)
    return list(Q), motion_covariance(pose, dd, dth, noise).ravel()


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
    """The prediction against the kernels it calls, in turn (every noise model, lateral or not)."""
    odom, pose, P, M, X = (*rng.normal(size=2).tolist(), 1.0), *_random_state(rng)
    kind, calibrated = int(rng.integers(3)), bool(rng.integers(2))
    L = float(rng.uniform(0.8, 2.0))
    steered = None if kind == 0 else (kind == 1, L, 1e-3, 4e-5, float(rng.choice([0.0, 0.5])))
    noise, cvar = (1e-4, 2e-4, 1e-5, 3e-4), (9e-6, 1.2e-5)
    dd, dth = float(rng.uniform(-0.05, 0.05)), float(rng.choice([0.0, 1e-6, rng.uniform(-0.05, 0.05)]))
    dl = 0.0 if rng.uniform() < 0.7 else float(rng.uniform(-0.02, 0.02))
    if rng.uniform() < 0.1:
        dd = 0.0  # a rear wheel that does not roll (steered_noise's s = 0)
    mc = pos_fast.move_constants(noise, steered, True, calibrated, cvar)
    o, x, Pn, Mn, Xn = pos_fast.move_state(odom, pose, P, M, X, dd, dth, dl, mc)
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
    """The gate kernel (index, sight, claims, consider or not) against ``gate_one`` on the same candidates."""
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
    """The gate and Schmidt update in one call against ``gate_one`` and the update written in NumPy."""
    z, pose, P, M, X, mount, spec, rows, index, sight, claimed, svar, C = _gate_setup(rng, True)
    calibrated = bool(rng.integers(2))
    bearing_var = 1e-7
    gc = pos_fast.gate_constants(spec, mount, None if index is None else index.grid_constants(), bearing_var,
                                 CONSIDER_MIN_DET, CONSIDER_MAX_ENTRY, calibrated)
    cells = (np.zeros(2, np.int64), np.zeros(0, np.int64)) if index is None else index.grid_cells()
    (j, y, _, n_in, *_), x1, P1, _, _, X1, _ = pos_fast.gate_accept(
        z, 1.05, pose, P, M, X, C.copy(), claimed, sight, pos_fast.gate_table(rows, svar), gc, *cells)
    cand = range(len(rows)) if index is None else index.candidates(z, pose, P)
    ref = pos_fast.gate_one(z, pose, P, mount, rows, spec, claimed.tolist(), 1.05, [c for c in cand if sight[c]],
                            (M, C, svar.tolist()))
    if ref[0] < 0:
        return [j, n_in, *x1, *P1], [ref[0], ref[3], *pose, *P]
    # the Schmidt-Kalman update [module docstring of positioning.ekf] in NumPy: e' = A e - K (H_p p + w)
    H, Hp = np.array(ref[4]), -np.array(ref[4][:2])
    Pm, Pxp = np.reshape(P, (3, 3)), np.reshape(M, (3, 3)) @ C[ref[0]].reshape(2, 3).T  # P_xp,j (3, 2)
    v, b = Pxp @ Hp, svar[ref[0]] * float(Hp @ Hp)
    S = float(H @ Pm @ H + 2.0 * H @ v + b + bearing_var)
    K = (Pm @ H + v) / S
    A = np.eye(3) - np.outer(K, H)
    Pn = A @ Pm @ A.T - np.outer(A @ v, K) - np.outer(K, A @ v) + (b + bearing_var) * np.outer(K, K)
    xn = np.array(pose) + K * ref[1]
    xn[2] = wrap_angle_scalar(float(xn[2]))
    Xn = (A @ np.reshape(X, (3, 2))).ravel() if calibrated else np.array(X)
    return [j, y, *x1, *P1, *X1], [ref[0], ref[1], *xn, *Pn.ravel(), *Xn]


def _three_bearings(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, tuple[float, ...]]:
    """Three reflectors (m), the bearings (rad) of a random head among them, and three bearing stds (rad)."""
    r = rng.uniform(-10.0, 10.0, (3, 2))
    p, psi = rng.uniform(-10.0, 10.0, 2), rng.uniform(-math.pi, math.pi)
    z = np.array([wrap_angle_scalar(v) for v in (np.arctan2(r[:, 1] - p[1], r[:, 0] - p[0]) - psi).tolist()])
    return r, z + rng.normal(0.0, 1e-3, 3), tuple(rng.uniform(1e-4, 5e-3, 3).tolist())


def _total_fix(rng: np.random.Generator) -> Pair:
    r, z, _ = _three_bearings(rng)
    code, px, py = integrity_fast.total_fix(*r.reshape(-1).tolist(), *z.tolist())
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
    ok, *inv = integrity_fast._inverse3(*a[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]].tolist())
    ref, valid = inv_sym3(a)
    return (float(ok), *inv), (float(valid), *ref[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]].tolist())


CASES: dict[str, Callable[[np.random.Generator], Pair]] = {
    "bearing_row": _bearing_row, "process_noise": _process_noise, "steered_noise": _steered_noise,
    "move_state": _move_state, "gate_rows": _gate_rows, "gate_accept": _gate_accept,
    "wrapped_offsets": _wrapped_offsets, "total_fix": _total_fix, "fix_covariance": _fix_covariance,
    "nonlinear_fix": _nonlinear_fix, "edge_bearing": _edge_bearing, "inverse3": _inverse3,
}
ATOL = {"nonlinear_fix": 0.0, "total_fix": 1e-9}


@pytest.mark.parametrize("name", sorted(CASES))
def test_kernel_agrees_with_its_oracle(name: str) -> None:
    """The kernel and its oracle on random inputs: equal to 1e-12 (absolute, SI units of the output)."""
    rng = np.random.default_rng(11)
    for _ in range(N_DRAWS):
        got, ref = CASES[name](rng)
        np.testing.assert_allclose(np.asarray(got, dtype=float), np.asarray(ref, dtype=float).reshape(np.shape(got)),
                                   rtol=0, atol=ATOL.get(name, 1e-12), err_msg=name)
