"""Maximum-likelihood pose from N bearings: Levenberg-Marquardt, vectorised over the batch.

Minimises ``sum_i (wrap(theta_i - h_i(x, y, psi)) / sigma_i)²`` with the bearing model
``h_i = atan2(y_i - y, x_i - x) - psi`` (see ``bounds``), plus ``(wrap(psi_est - psi) /
sigma_psi)²`` when a heading estimate with its std is given (then N >= 2 suffices).
Every element runs the same fixed number of iterations at most, with a per-element
damping factor and a convergence mask; the loop stops early once all have converged.
At the solution the covariance is ``(J^T R^-1 J)^-1`` (plus the prior's information).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry.angles import wrap_angle_scalar
from agvnav.positioning._three import Arr, wrap
from agvnav.positioning.bounds import inv_sym3
from agvnav.positioning.total import total_kernel

#: Iteration cap; from the ToTal start Gauss-Newton converges in 3-5 iterations.
MAX_ITER = 30
#: Step (m or rad, relative to 1 + |state|) below which an element has converged; the
#: step is still taken, and Gauss-Newton converges quadratically, so the error left is ~STEP_TOL².
STEP_TOL = 1e-10
#: A step this small that fails to lower the cost means the cost is flat to rounding: done.
ROUNDING_STEP = 1e-7
#: Damping beyond which the iteration stops. Stopping there is convergence only if the
#: *undamped* Gauss-Newton step is below ROUNDING_STEP too (a minimum); otherwise the
#: damping blew up away from one (e.g. no descent direction found): ``valid=False``.
LAM_MAX = 1e8


def _normal_equations(
    state: Arr, rx: Arr, ry: Arr, theta: Arr, w: Arr, prior: tuple[Arr, Arr] | None
) -> tuple[Arr, Arr, Arr]:
    """Information ``A = J^T W J`` (m,3,3), gradient ``g = J^T W r`` (m,3) and cost (m,).

    Internal layout is reflector-major: ``rx, ry`` ``(N, 1)`` or ``(N, m)``, ``theta, w``
    ``(N, m)``, so the sums over reflectors are contiguous vector adds.
    """
    dx = rx - state[:, 0]
    dy = ry - state[:, 1]
    d2 = dx * dx + dy * dy
    r = wrap(theta - (np.arctan2(dy, dx) - state[:, 2]))
    j0 = dy / d2  # Jacobian row [j0, j1, -1] (see bounds.bearing_jacobian)
    j1 = -dx / d2
    wj0, wj1, wr = w * j0, w * j1, w * r
    a = np.empty((state.shape[0], 3, 3))
    a[:, 0, 0] = np.sum(wj0 * j0, 0)
    a[:, 0, 1] = a[:, 1, 0] = np.sum(wj0 * j1, 0)
    a[:, 0, 2] = a[:, 2, 0] = -np.sum(wj0, 0)
    a[:, 1, 1] = np.sum(wj1 * j1, 0)
    a[:, 1, 2] = a[:, 2, 1] = -np.sum(wj1, 0)
    a[:, 2, 2] = np.sum(w, 0)
    g = np.stack([np.sum(wj0 * r, 0), np.sum(wj1 * r, 0), -np.sum(wr, 0)], axis=-1)
    cost = np.sum(wr * r, 0)
    if prior is not None:
        psi_est, w_psi = prior
        rp = wrap(psi_est - state[:, 2])
        a[:, 2, 2] += w_psi
        g[:, 2] += w_psi * rp
        cost = cost + w_psi * rp * rp
    return a, g, cost


def _cost(state: Arr, rx: Arr, ry: Arr, theta: Arr, w: Arr, prior: tuple[Arr, Arr] | None) -> Arr:
    """Weighted squared residuals (m,), same layout as ``_normal_equations``."""
    r = wrap(theta - (np.arctan2(ry - state[:, 1], rx - state[:, 0]) - state[:, 2]))
    cost = np.sum(w * r * r, 0)
    if prior is not None:
        rp = wrap(prior[0] - state[:, 2])
        cost = cost + prior[1] * rp * rp
    return cost


def _lines_start(rx: Arr, ry: Arr, theta: Arr, psi: Arr) -> Arr:
    """Least-squares intersection of the N lines at absolute angles ``psi + theta_i`` (start value)."""
    phi = psi[:, None] + theta
    nx, ny = -np.sin(phi), np.cos(phi)
    a00, a01, a11 = np.sum(nx * nx, -1), np.sum(nx * ny, -1), np.sum(ny * ny, -1)
    c = nx * rx + ny * ry
    b0, b1 = np.sum(nx * c, -1), np.sum(ny * c, -1)
    det = a00 * a11 - a01 * a01
    return np.stack([(a11 * b0 - a01 * b1) / det, (a00 * b1 - a01 * b0) / det, psi], axis=-1)


def initial_state(rx: Arr, ry: Arr, theta: Arr, psi_est: Arr | None) -> Arr:
    """Start value (m,3): ToTal on the first usable of up to four reflector triples, else the
    least-squares intersection of the lines of the heading estimate, else the centroid."""
    m, n = theta.shape
    state = np.full((m, 3), np.nan)
    triples = [(0, 1, 2), (0, 1, 3), (1, 2, 3), (0, 2, 3)] if n >= 4 else [(0, 1, 2)] if n == 3 else []
    rxb, ryb = np.broadcast_to(rx, theta.shape), np.broadcast_to(ry, theta.shape)
    for triple in triples:  # a triple on its critical circle gives no start: try the next
        missing = ~np.all(np.isfinite(state), axis=-1)
        if not np.any(missing):
            break
        fix = total_kernel(
            tuple(rxb[missing, k] for k in triple),
            tuple(ryb[missing, k] for k in triple),
            tuple(theta[missing, k] for k in triple),
        )
        start = np.stack([fix["x"], fix["y"], fix["heading"]], axis=-1)
        start[~fix["valid"]] = np.nan
        state[missing] = start
    missing = ~np.all(np.isfinite(state), axis=-1)
    if np.any(missing) and psi_est is not None:
        state[missing] = _lines_start(
            np.broadcast_to(rx, theta.shape)[missing],
            np.broadcast_to(ry, theta.shape)[missing],
            theta[missing],
            psi_est[missing],
        )
    missing = ~np.all(np.isfinite(state), axis=-1)
    if np.any(missing):  # last resort: centroid of the reflectors, heading from it
        cx = np.broadcast_to(np.mean(rx, -1, keepdims=True), (m, 1))[missing, 0]
        cy = np.broadcast_to(np.mean(ry, -1, keepdims=True), (m, 1))[missing, 0]
        rxm = np.broadcast_to(rx, theta.shape)[missing]
        rym = np.broadcast_to(ry, theta.shape)[missing]
        psi = np.arctan2(rym[:, 0] - cy, rxm[:, 0] - cx + 1e-9) - theta[missing, 0]
        state[missing] = np.stack([cx + 1e-3, cy + 1e-3, psi], axis=-1)
    return state


def least_squares_kernel(
    rx: Arr,
    ry: Arr,
    theta: Arr,
    bearing_std: Arr | None,
    heading_estimate: Arr | None,
    heading_std: Arr | None,
) -> dict[str, Arr]:
    """Levenberg-Marquardt ML fix for a flat batch.

    ``rx, ry`` ``(N,)`` or ``(m, N)`` (m), ``theta`` ``(m, N)`` (rad), ``bearing_std``
    broadcastable to ``(m, N)`` or None (unit weights; the solution does not depend on a
    common scale), ``heading_estimate``/``heading_std`` ``(m,)`` or None (prior used only
    when both are given). Returns ``x, y, heading, quality, valid, information (m,3,3)``;
    ``quality`` is ``1 / PDOP`` of the bearings alone at the solution (rad/m; 0 when
    they cannot fix the pose without the prior).
    """
    m, _ = theta.shape
    sigma = np.ones(1) if bearing_std is None else bearing_std
    w_t = np.ascontiguousarray(np.broadcast_to(1.0 / np.asarray(sigma, dtype=np.float64) ** 2, theta.shape).T)
    theta_t = np.ascontiguousarray(theta.T)
    shared = np.ndim(rx) == 1
    rx_t = rx[:, None] if shared else np.ascontiguousarray(rx.T)
    ry_t = ry[:, None] if shared else np.ascontiguousarray(ry.T)
    w_psi = None
    if heading_estimate is not None and heading_std is not None:
        w_psi = np.broadcast_to(1.0 / np.asarray(heading_std, dtype=np.float64) ** 2, (m,))

    def data(idx: NDArray[np.intp]) -> tuple[Arr, Arr, Arr, Arr, tuple[Arr, Arr] | None]:
        """The problem restricted to the elements ``idx`` (active set)."""
        prior = None if w_psi is None else (heading_estimate[idx], w_psi[idx])  # type: ignore[index]
        if shared:
            return rx_t, ry_t, theta_t[:, idx], w_t[:, idx], prior
        return rx_t[:, idx], ry_t[:, idx], theta_t[:, idx], w_t[:, idx], prior

    with np.errstate(all="ignore"):
        state = initial_state(rx, ry, theta, heading_estimate)
        lam = np.full(m, 1e-6)
        done = np.zeros(m, dtype=bool)
        active = np.arange(m)
        for _ in range(MAX_ITER):
            args = data(active)
            s = state[active]
            a, g, cost = _normal_equations(s, *args)
            inv, _ = inv_sym3(a + lam[active, None, None] * np.eye(3) * a)
            step = np.einsum("mij,mj->mi", inv, g)
            # Undamped size: the damped step is ~ the Gauss-Newton step / (1 + lam), so a tiny
            # step under heavy damping is not mistaken for convergence.
            rel = np.max(np.abs(step) / (1.0 + np.abs(s)), axis=-1) * (1.0 + lam[active])
            trial = s + step
            better = _cost(trial, *args) <= cost
            state[active] = np.where(better[:, None], trial, s)
            lam[active] = np.where(better, lam[active] * 0.1, lam[active] * 10.0)
            converged = (rel < STEP_TOL) | (~better & (rel < ROUNDING_STEP))
            converged |= ~np.all(np.isfinite(step), axis=-1)
            stalled = ~converged & (lam[active] > LAM_MAX)
            converged |= stalled & _at_minimum(a, g, s)
            finished = converged | stalled
            done[active[converged]] = True
            active = active[~finished]
            if active.size == 0:
                break
        everything = data(np.arange(m))
        info, _, _ = _normal_equations(state, *everything)
        unit_info, _, _ = _normal_equations(state, *everything[:2], theta_t, np.ones_like(w_t), None)
        _, observable = inv_sym3(info)
        unit_cov, bearings_only = inv_sym3(unit_info)
        quality = np.where(bearings_only, 1.0 / np.sqrt(unit_cov[:, 0, 0] + unit_cov[:, 1, 1]), 0.0)
        heading = wrap(state[:, 2])
    valid = done & observable & np.all(np.isfinite(state), axis=-1)
    return {
        "x": state[:, 0],
        "y": state[:, 1],
        "heading": heading,
        "quality": quality,
        "valid": valid,
        "information": info,
    }


def _at_minimum(a: Arr, g: Arr, s: Arr) -> NDArray[np.bool_]:
    """True where the undamped Gauss-Newton step ``a⁻¹ g`` is below ROUNDING_STEP (relative)."""
    inv, ok = inv_sym3(a)
    gn = np.einsum("mij,mj->mi", inv, g)
    return ok & (np.max(np.abs(gn) / (1.0 + np.abs(s)), axis=-1) < ROUNDING_STEP)


def _solve3(a: list[list[float]], g: list[float]) -> list[float]:
    """Solve a 3x3 system by Cramer's rule in floats (raises ZeroDivisionError if singular)."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    c0 = a11 * a22 - a12 * a21
    c1 = a12 * a20 - a10 * a22
    c2 = a10 * a21 - a11 * a20
    inv_det = 1.0 / (a00 * c0 + a01 * c1 + a02 * c2)
    return [
        (g[0] * c0 + a01 * (a12 * g[2] - g[1] * a22) + a02 * (g[1] * a21 - a11 * g[2])) * inv_det,
        (a00 * (g[1] * a22 - a12 * g[2]) + g[0] * c1 + a02 * (a10 * g[2] - g[1] * a20)) * inv_det,
        (a00 * (a11 * g[2] - g[1] * a21) + a01 * (g[1] * a20 - a10 * g[2]) + g[0] * c2) * inv_det,
    ]


def inv3_single(a: list[list[float]]) -> list[list[float]]:
    """Inverse of a symmetric 3x3 matrix in floats by the adjugate (raises ZeroDivisionError if singular)."""
    (a00, a01, a02), (_, a11, a12), (_, _, a22) = a
    c00, c01, c02 = a11 * a22 - a12 * a12, a02 * a12 - a01 * a22, a01 * a12 - a02 * a11
    c11, c12, c22 = a00 * a22 - a02 * a02, a01 * a02 - a00 * a12, a00 * a11 - a01 * a01
    det = a00 * c00 + a01 * c01 + a02 * c02
    if abs(det) <= 1e-13 * (abs(a00 * c00) + abs(a01 * c01) + abs(a02 * c02)):
        raise ZeroDivisionError("singular information matrix")
    k = 1.0 / det
    return [[c00 * k, c01 * k, c02 * k], [c01 * k, c11 * k, c12 * k], [c02 * k, c12 * k, c22 * k]]


# The *_single functions repeat the batch maths of _normal_equations/_cost in Python floats on
# purpose: calling the NumPy kernels on one fix costs ~1 µs per NumPy call (dozens per
# iteration), which put a single fix near or above the 50 µs target; the float versions run one
# fix in a few µs. They are tested against the batch kernel to 1e-9 (same iteration, same stop
# rules), so the duplication cannot drift silently.
def _cost_single(
    state: list[float], pts: list[list[float]], theta: list[float], w: list[float], prior: tuple[float, float] | None
) -> float:
    """Float version of ``_cost`` for one fix."""
    x, y, psi = state
    cost = 0.0
    for (rx, ry), th, wi in zip(pts, theta, w, strict=True):
        r = wrap_angle_scalar(th - (math.atan2(ry - y, rx - x) - psi))
        cost += wi * r * r
    if prior is not None:
        rp = wrap_angle_scalar(prior[0] - psi)
        cost += prior[1] * rp * rp
    return cost


def _normal_equations_single(
    state: list[float], pts: list[list[float]], theta: list[float], w: list[float], prior: tuple[float, float] | None
) -> tuple[list[list[float]], list[float], float]:
    """Float version of ``_normal_equations`` for one fix."""
    a = [[0.0] * 3 for _ in range(3)]
    g = [0.0, 0.0, 0.0]
    cost = 0.0
    x, y, psi = state
    for (rx, ry), th, wi in zip(pts, theta, w, strict=True):
        dx, dy = rx - x, ry - y
        d2 = dx * dx + dy * dy
        r = wrap_angle_scalar(th - (math.atan2(dy, dx) - psi))
        j0, j1 = dy / d2, -dx / d2  # third Jacobian entry is -1
        a[0][0] += wi * j0 * j0
        a[0][1] += wi * j0 * j1
        a[0][2] -= wi * j0
        a[1][1] += wi * j1 * j1
        a[1][2] -= wi * j1
        a[2][2] += wi
        g[0] += wi * j0 * r
        g[1] += wi * j1 * r
        g[2] -= wi * r
        cost += wi * r * r
    a[1][0], a[2][0], a[2][1] = a[0][1], a[0][2], a[1][2]
    if prior is not None:
        rp = wrap_angle_scalar(prior[0] - psi)
        a[2][2] += prior[1]
        g[2] += prior[1] * rp
        cost += prior[1] * rp * rp
    return a, g, cost


def least_squares_single(
    pts: list[list[float]],
    theta: list[float],
    w: list[float],
    prior: tuple[float, float] | None,
    start: list[float],
) -> tuple[list[float], bool, list[list[float]]]:
    """Levenberg-Marquardt for one fix in Python floats (the fast single-fix path).

    Same iteration as ``least_squares_kernel`` (tested against it); ``w`` are the bearing
    weights ``1/sigma²``, ``prior`` ``(psi_est, 1/sigma_psi²)`` or None. Returns
    ``(state, converged, information)``; raises ArithmeticError on a singular system so
    the caller can fall back to the batch path, which flags it.
    """
    state = list(start)
    lam = 1e-6
    converged = False
    for _ in range(MAX_ITER):
        a, g, cost = _normal_equations_single(state, pts, theta, w, prior)
        damped = [[a[i][j] * (1.0 + lam) if i == j else a[i][j] for j in range(3)] for i in range(3)]
        step = _solve3(damped, g)
        trial = [s + d for s, d in zip(state, step, strict=True)]
        rel = max(abs(d) / (1.0 + abs(s)) for d, s in zip(step, state, strict=True)) * (1.0 + lam)
        better = _cost_single(trial, pts, theta, w, prior) <= cost
        if better:
            state = trial
            lam *= 0.1
        else:
            lam *= 10.0
        if rel < STEP_TOL or (not better and rel < ROUNDING_STEP):
            converged = True
            break
        if lam > LAM_MAX:  # converged only at a minimum: the undamped step is negligible there
            gn = _solve3(a, g)
            converged = max(abs(d) / (1.0 + abs(v)) for d, v in zip(gn, state, strict=True)) < ROUNDING_STEP
            break
    info = _normal_equations_single(state, pts, theta, w, prior)[0]
    return state, converged, info
