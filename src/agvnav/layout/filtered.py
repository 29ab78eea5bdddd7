"""Predicted accuracy of the *filtered* estimate: the EKF's covariance recursion along the route.

The single-revolution CRLB (:mod:`agvnav.layout.prediction`) bounds one fix. The
vehicle's EKF also carries the previous fixes forward through odometry, so its
error is smaller. This module runs the EKF's own covariance recursion without
noise, bearing by bearing, in the coordinates the simulator scores: the base_link
pose ``[x_O, y_O, ψ]`` (not the head centre P, which sits ``mount`` ahead of it).

* The head turns at ``revolutions_per_m`` revolutions per metre of route (head rate over
  the vehicle's speed, so more per metre where it accelerates or brakes); reflector
  ``j`` is crossed when the head's world angle reaches its bearing, once per
  revolution while it is visible, so the bearings arrive in the order the
  goniometer delivers them.
* Between two bearings the covariance grows by the odometry model,
  ``P⁻ = F P Fᵀ + Q`` [seed002 eq14] with ``Q = G diag(k_d Δd, k_dθ Δd + k_θ |Δθ|) Gᵀ``
  [seed002 eq17] (the midpoint form of :func:`agvnav.odometry.motion_covariance`; the variances
  from the odometry kernel :func:`agvnav.odometry.increment_variances`).
* Each bearing ``θ_j = atan2(y_j - y_P, x_j - x_P) - ψ - θ_m`` [seed000 §2.2] updates
  ``P`` with its Jacobian with respect to base_link,
  ``H = [dy/d², -dx/d², -1 + (dy/d²) ∂x_P/∂ψ - (dx/d²) ∂y_P/∂ψ]``:
  ``P ← P - P Hᵀ H P / (H P Hᵀ + σ²)`` (the EKF's scalar update).
* The filter's ``P`` sets the gains; the actual error's covariance ``E`` follows them,
  ``E ← (I - K H) E (I - K H)ᵀ + K σ² Kᵀ`` (Joseph form), from the run's actual initial
  error (zero for a run started on the true pose) rather than from the filter's ``P₀``.
* The figure is the *time average* of ``trace E_xy`` over each interval of route
  (between bearings ``P`` grows about linearly, so the average of each gap is the
  mean of its two ends): what a position error sampled at every control step has
  as its mean square, so ``sqrt`` of its mean over a section is the predicted RMS of
  the position-error norm that :mod:`agvnav.layout.verify` measures.

It predicts an EKF whose models are right (odometry noise ``noise`` is the vehicle's,
bearing noise ``σ`` the head's, an exact map): :func:`agvnav.layout.verify.route_scenario`
builds its runs that way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvnav._jit import jit
from agvnav.geometry import wrap_angle
from agvnav.layout.prediction import information
from agvnav.odometry import OdometryNoise, increment_variances
from agvnav.positioning.bounds import inv_sym3

__all__ = ["FilteredPrediction", "base_link_information", "filtered_prediction", "single_fix_rms"]


@dataclass(frozen=True)
class FilteredPrediction:
    """Per route pose: ``mean_square`` (m²) the time average of ``trace P_xy`` over the interval that ends at
    the pose (the first pose: its initial value), ``post_rms`` (m) ``sqrt(trace P_xy)`` at the pose."""

    mean_square: NDArray[np.float64]
    post_rms: NDArray[np.float64]


@jit
def _recursion(pose: NDArray[np.float64], turn: NDArray[np.float64], visible: NDArray[np.bool_],
               refl: NDArray[np.float64], mount: NDArray[np.float64], bearing_var: float,
               rev_per_m: NDArray[np.float64], k_d: float, k_dth: float, k_th: float,
               p0: NDArray[np.float64], e0: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The bearing-by-bearing covariance recursion (compiled; see the module docstring).

    ``P`` is the filter's covariance (it sets the gains), ``E`` the covariance of the actual error
    under those gains (Joseph form), started at ``e0``; the outputs are of ``E``.
    """
    n_pose, n_refl = visible.shape
    mean_sq = np.empty(n_pose)
    post = np.empty(n_pose)
    P = p0.copy()
    E = e0.copy()
    mean_sq[0] = E[0, 0] + E[1, 1]
    post[0] = math.sqrt(max(mean_sq[0], 0.0))
    rev_total = 0.0  # head revolutions made so far
    for k in range(1, n_pose):
        rpm = rev_per_m[k]
        x0, y0, th0 = pose[k - 1, 0], pose[k - 1, 1], pose[k - 1, 2]
        ddx, ddy = pose[k, 0] - x0, pose[k, 1] - y0
        length = math.sqrt(ddx * ddx + ddy * ddy)
        dth = turn[k - 1]  # heading change of stretch k, wrapped by geometry.wrap_angle before the call
        # bearing events inside this stretch: reflector j is crossed when the head's revolution count
        # R (rev_total at its start, rev_total + rpm * length at its end) reaches m + phase_j
        cap = n_refl * (int(length * rpm) + 2)
        ev_s = np.empty(cap)
        ev_j = np.empty(cap, dtype=np.int64)
        n_ev = 0
        for j in range(n_refl):
            if not visible[k, j]:
                continue
            c, s = math.cos(th0), math.sin(th0)
            px = x0 + c * mount[0] - s * mount[1]
            py = y0 + s * mount[0] + c * mount[1]
            beta = math.atan2(refl[j, 1] - py, refl[j, 0] - px) - th0 - mount[2]
            phase = (beta / (2.0 * math.pi)) % 1.0
            m = math.floor(rev_total - phase) + 1.0
            while (m + phase - rev_total) / rpm <= length:
                if n_ev < cap:
                    ev_s[n_ev] = (m + phase - rev_total) / rpm
                    ev_j[n_ev] = j
                    n_ev += 1
                m += 1.0
        order = np.argsort(ev_s[:n_ev])
        at = 0.0
        acc = 0.0
        for e in range(n_ev + 1):
            to = ev_s[order[e]] if e < n_ev else length
            ds = to - at
            if ds > 0.0:
                frac_mid = (at + 0.5 * ds) / length if length > 0.0 else 0.0
                thm = th0 + dth * frac_mid
                dthe = dth * ds / length if length > 0.0 else 0.0
                cm, sm = math.cos(thm), math.sin(thm)
                tr0 = E[0, 0] + E[1, 1]
                F = np.eye(3)
                F[0, 2] = -ds * sm
                F[1, 2] = ds * cm
                G = np.zeros((3, 2))
                G[0, 0], G[0, 1] = cm, -0.5 * ds * sm
                G[1, 0], G[1, 1] = sm, 0.5 * ds * cm
                G[2, 1] = 1.0
                sig = np.zeros((2, 2))
                sig[0, 0], sig[1, 1] = increment_variances(ds, dthe, k_d, k_dth, k_th)
                Q = G @ sig @ G.T
                P = F @ P @ F.T + Q
                E = F @ E @ F.T + Q
                acc += 0.5 * (tr0 + E[0, 0] + E[1, 1]) * ds
                at = to
            if e == n_ev:
                break
            j = ev_j[order[e]]
            frac = at / length if length > 0.0 else 0.0
            x = x0 + ddx * frac
            y = y0 + ddy * frac
            th = th0 + dth * frac
            c, s = math.cos(th), math.sin(th)
            px = x + c * mount[0] - s * mount[1]
            py = y + s * mount[0] + c * mount[1]
            dx, dy = refl[j, 0] - px, refl[j, 1] - py
            d2 = max(dx * dx + dy * dy, 1e-12)
            hx, hy = dy / d2, -dx / d2
            hp = -1.0 + hx * (-s * mount[0] - c * mount[1]) + hy * (c * mount[0] - s * mount[1])
            H = np.array([hx, hy, hp])
            PH = P @ H
            S = H @ PH + bearing_var
            K = PH / S
            P = P - np.outer(PH, PH) / S
            P = 0.5 * (P + P.T)
            A = np.eye(3) - np.outer(K, H)
            E = A @ E @ A.T + np.outer(K, K) * bearing_var
            E = 0.5 * (E + E.T)
        rev_total += length * rpm
        mean_sq[k] = acc / length if length > 0.0 else E[0, 0] + E[1, 1]
        post[k] = math.sqrt(max(E[0, 0] + E[1, 1], 0.0))
    return mean_sq, post


def filtered_prediction(pose: NDArray[np.float64], visible: NDArray[np.bool_], refl: NDArray[np.float64],
                        mount: tuple[float, float, float], bearing_std: float,
                        revolutions_per_m: float | NDArray[np.float64],
                        noise: OdometryNoise, initial_cov: NDArray[np.float64],
                        initial_error_cov: NDArray[np.float64] | None = None) -> FilteredPrediction:
    """The predicted error covariance of the EKF along the consecutive base_link poses ``pose`` ``(K, 3)``.

    ``visible`` ``(K, S)`` reflectors ``refl`` ``(S, 2)`` in sight at each pose (m); ``mount`` the head
    in base_link (m, m, rad); ``bearing_std`` (rad); ``revolutions_per_m`` head rate over speed (rev/m), one
    value or ``(K,)`` (entry k for the stretch that ends at pose k: a speed profile);
    ``noise`` the odometry model [seed002 eq17]; ``initial_cov`` ``(3, 3)`` (m², rad²) the filter's covariance
    at the first pose (it sets the gains) and ``initial_error_cov`` that of the actual initial error (default
    the same; a run started on the true pose has zero). Until the two meet, the actual error follows the
    gains of ``P`` with its own covariance ``E`` (Joseph form); the figures are of ``E``.
    """
    rpm = np.broadcast_to(np.asarray(revolutions_per_m, dtype=np.float64), (np.shape(pose)[0],)).copy()
    if not (np.all(np.isfinite(rpm)) and np.all(rpm > 0.0)):
        raise ValueError(f"revolutions_per_m must be positive and finite, got {revolutions_per_m}")
    if not (math.isfinite(bearing_std) and bearing_std > 0.0):
        raise ValueError(f"bearing_std must be positive, got {bearing_std}")
    pose = np.ascontiguousarray(pose, dtype=np.float64).reshape(-1, 3)
    vis = np.ascontiguousarray(visible, dtype=np.bool_)
    if vis.shape != (pose.shape[0], refl.shape[0]):
        raise ValueError(f"visible must have shape {(pose.shape[0], refl.shape[0])}, got {vis.shape}")
    p0 = np.ascontiguousarray(initial_cov, dtype=np.float64).reshape(3, 3)
    e0 = p0 if initial_error_cov is None else np.ascontiguousarray(initial_error_cov, dtype=np.float64).reshape(3, 3)
    turn = wrap_angle(np.diff(pose[:, 2]))
    ms, post = _recursion(pose, turn, vis, np.ascontiguousarray(refl, dtype=np.float64).reshape(-1, 2),
                              np.asarray(mount, dtype=np.float64), bearing_std**2, rpm,
                              noise.k_d, noise.k_dtheta, noise.k_theta, p0, e0)
    return FilteredPrediction(ms, post)


def base_link_information(pose: NDArray[np.float64], head: NDArray[np.float64], refl: NDArray[np.float64],
                          visible: NDArray[np.bool_], mount: tuple[float, float, float],
                          bearing_std: float) -> NDArray[np.float64]:
    """Fisher information ``(K, 3, 3)`` of one revolution about the base_link pose ``[x_O, y_O, ψ]``.

    The head's information ``I_P`` (:func:`agvnav.layout.prediction.information`, [seed000 §2.2]) mapped
    through ``T = ∂(x_P, y_P, ψ)/∂(x_O, y_O, ψ)``: ``I_O = Tᵀ I_P T``.
    """
    i6 = information(head, refl, visible, bearing_std)
    ip = np.stack([np.stack([i6[:, 0], i6[:, 1], i6[:, 2]], -1), np.stack([i6[:, 1], i6[:, 3], i6[:, 4]], -1),
                   np.stack([i6[:, 2], i6[:, 4], i6[:, 5]], -1)], -2)
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    T = np.broadcast_to(np.eye(3), ip.shape).copy()
    T[:, 0, 2] = -s * mount[0] - c * mount[1]
    T[:, 1, 2] = c * mount[0] - s * mount[1]
    return np.asarray(np.swapaxes(T, -1, -2) @ ip @ T)


def single_fix_rms(info: NDArray[np.float64]) -> NDArray[np.float64]:
    """``sqrt(trace P_xy)`` (m) of the CRLB ``P = I⁻¹`` of information ``(..., 3, 3)``; inf where singular."""
    cov, valid = inv_sym3(info)
    tr = cov[..., 0, 0] + cov[..., 1, 1]
    with np.errstate(invalid="ignore"):
        return np.where(valid & (tr > 0.0), np.sqrt(np.abs(tr)), np.inf)
