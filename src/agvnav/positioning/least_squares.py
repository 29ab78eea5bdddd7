"""Maximum-likelihood pose from N bearings: Levenberg-Marquardt, vectorised over the batch.

Minimises ``sum_i (wrap(theta_i - h_i(x, y, psi)) / sigma_i)²`` with the bearing model
``h_i = atan2(y_i - y, x_i - x) - psi`` (see ``bounds``), plus ``(wrap(psi_est - psi) /
sigma_psi)²`` when a heading estimate with its std is given (then N >= 2 suffices).
Every element runs the same fixed number of iterations at most, with a per-element
damping factor and a convergence mask; the loop stops early once all have converged.
At the solution the covariance is ``(J^T R^-1 J)^-1`` (plus the prior's information).
"""

from __future__ import annotations

import numpy as np

from agvnav.positioning._three import Arr, wrap
from agvnav.positioning.bounds import inv_sym3
from agvnav.positioning.total import total_kernel

#: Iteration cap; from the ToTal start Gauss-Newton converges in 3-5 iterations.
MAX_ITER = 30
#: Step (m or rad, relative to 1 + |state|) below which an element has converged.
STEP_TOL = 1e-12


def _normal_equations(
    state: Arr, rx: Arr, ry: Arr, theta: Arr, w: Arr, prior: tuple[Arr, Arr] | None
) -> tuple[Arr, Arr, Arr]:
    """Information ``A = J^T W J`` (m,3,3), gradient ``g = J^T W r`` (m,3) and cost (m,)."""
    dx = rx - state[:, 0:1]
    dy = ry - state[:, 1:2]
    d2 = dx * dx + dy * dy
    r = wrap(theta - (np.arctan2(dy, dx) - state[:, 2:3]))
    jac = np.stack([dy / d2, -dx / d2, -np.ones_like(d2)], axis=-1)
    a = np.einsum("mni,mn,mnj->mij", jac, w, jac)
    g = np.einsum("mni,mn,mn->mi", jac, w, r)
    cost = np.sum(w * r * r, axis=-1)
    if prior is not None:
        psi_est, w_psi = prior
        rp = wrap(psi_est - state[:, 2])
        a[:, 2, 2] += w_psi
        g[:, 2] += w_psi * rp
        cost = cost + w_psi * rp * rp
    return a, g, cost


def _cost(state: Arr, rx: Arr, ry: Arr, theta: Arr, w: Arr, prior: tuple[Arr, Arr] | None) -> Arr:
    r = wrap(theta - (np.arctan2(ry - state[:, 1:2], rx - state[:, 0:1]) - state[:, 2:3]))
    cost = np.sum(w * r * r, axis=-1)
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
    """Start value (m,3): ToTal on the first three reflectors, else the lines of the heading estimate."""
    m, n = theta.shape
    state = np.full((m, 3), np.nan)
    if n >= 3:
        x3 = tuple(np.broadcast_to(rx, theta.shape)[:, k] for k in range(3))
        y3 = tuple(np.broadcast_to(ry, theta.shape)[:, k] for k in range(3))
        t3 = tuple(theta[:, k] for k in range(3))
        fix = total_kernel(x3, y3, t3)  # type: ignore[arg-type]
        ok = fix["valid"]
        state[ok] = np.stack([fix["x"], fix["y"], fix["heading"]], axis=-1)[ok]
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
    m = theta.shape[0]
    sigma = np.ones(1) if bearing_std is None else bearing_std
    w = np.broadcast_to(1.0 / np.asarray(sigma, dtype=np.float64) ** 2, theta.shape)
    prior = None
    if heading_estimate is not None and heading_std is not None:
        prior = (heading_estimate, np.broadcast_to(1.0 / np.asarray(heading_std) ** 2, (m,)))
    with np.errstate(all="ignore"):
        state = initial_state(rx, ry, theta, heading_estimate)
        lam = np.full(m, 1e-6)
        done = np.zeros(m, dtype=bool)
        for _ in range(MAX_ITER):
            a, g, cost = _normal_equations(state, rx, ry, theta, w, prior)
            damped = a + lam[:, None, None] * np.eye(3) * a
            inv, _ = inv_sym3(damped)
            step = np.einsum("mij,mj->mi", inv, g)
            trial = state + step
            better = _cost(trial, rx, ry, theta, w, prior) <= cost
            state = np.where((better & ~done)[:, None], trial, state)
            lam = np.where(better, lam * 0.1, lam * 10.0)
            small = np.max(np.abs(step) / (1.0 + np.abs(state)), axis=-1) < STEP_TOL
            done |= (better & small) | (lam > 1e8) | ~np.all(np.isfinite(step), axis=-1)
            if np.all(done):
                break
        info, _, _ = _normal_equations(state, rx, ry, theta, w, prior)
        unit_info, _, _ = _normal_equations(state, rx, ry, theta, np.ones_like(w), None)
        _, observable = inv_sym3(info)
        unit_cov, bearings_only = inv_sym3(unit_info)
        quality = np.where(bearings_only, 1.0 / np.sqrt(unit_cov[:, 0, 0] + unit_cov[:, 1, 1]), 0.0)
    valid = done & observable & np.all(np.isfinite(state), axis=-1)
    return {
        "x": state[:, 0],
        "y": state[:, 1],
        "heading": wrap(state[:, 2]),
        "quality": quality,
        "valid": valid,
        "information": info,
    }
