"""A recorded drive cut into keyframes: odometry between keyframes and each reflection's offset from its keyframe.

The factor graph (:mod:`agvnav.mapping.graph`) has one pose per keyframe (every
``keyframe_s`` seconds of odometry instants). Odometry between consecutive
keyframes becomes one between-factor, its covariance propagated step by step with
the odometry noise model ([seed002 eq17] via :func:`agvnav.odometry.propagate`).
A reflection measured at instant ``τ`` inside the odometry step ``(t_k, t_{k+1}]``
hangs on the last keyframe ``a`` at or before ``t_k``: its base_link pose is the
keyframe pose composed with the odometry offset ``u`` from ``t_a`` to ``τ`` (the
step's increment split in proportion to time, as :mod:`agvnav.logs.localize`
does); the offset's own small covariance is carried to the bearing's variance. The batch
interpolates instead (:func:`interpolate_drive`): the reflection's pose lies between its keyframe
and the next, both in the state, and with a keyframe at every odometry instant (the default) the
bearing carries no odometry noise; hung on one keyframe, the offset's error was common to every
bearing of the interval and, taken as independent bearing noise, over-weighted them.

The odometry covariance is linear in Crowley's coefficients ``(k_d, k_dθ, k_θ)``: besides the
covariances for the given noise, the drive keeps the three parts propagated with unit
coefficients (``between_cov_parts``, ``refl_offset_cov_parts``) so that the batch can estimate
the coefficients from the drive itself (variance components, :mod:`agvnav.mapping.slam`).
It also keeps the signed distance rolled and the heading turned by odometry per keyframe
step and per reflection offset: the graph's systematic odometry errors (a heading rate per
metre, a turn scale: :mod:`agvnav.mapping.graph`) act on them.

Increments are composed with the midpoint heading (as :func:`agvnav.logs.integrate_odometry`).
The translation of every relative pose is linear in the odometry scale factor ``s``
(a scale multiplies every ``ΔD`` and ``Δlateral`` and leaves ``Δθ`` alone), so the
offsets are stored at ``s = 1`` and scaled in the graph.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import between
from agvnav.odometry import OdometryNoise, increment_jacobian, integrate_pose, pose_jacobian

__all__ = ["Drive", "interpolate_drive", "odometry_poses", "prepare_drive", "repeated_readings",
           "unit_increment_cov"]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

#: Floor (m², m², rad²) added to every between-keyframe covariance so a vehicle standing still
#: (zero increments, zero modelled noise) does not make the odometry factor infinitely stiff.
ODOMETRY_FLOOR = (1e-8, 1e-8, 1e-10)


@dataclass(frozen=True)
class Drive:
    """A drive prepared for mapping.

    Attributes
    ----------
    keyframe_t : (K,) keyframe instants (s).
    odom_poses : (K, 3) dead-reckoned keyframe poses in the odom frame (start = origin), s = 1.
    between : (K - 1, 3) relative pose of keyframe k+1 in keyframe k (m, m, rad), s = 1.
    between_cov : (K - 1, 3, 3) its covariance (m², rad²).
    refl_keyframe : (B,) keyframe index of each reflection.
    refl_offset : (B, 3) base_link pose at the reflection's stamp relative to its keyframe, s = 1.
    refl_offset_cov : (B, 3, 3) covariance of that offset.
    refl_t : (B,) stamps (s).
    bearing : (B,) bearings in the head frame (rad).
    mount : (3,) head mount on base_link (m, m, rad).
    between_cov_parts : (3, K - 1, 3, 3) the between covariance for unit ``k_d``, ``k_dθ``, ``k_θ``
        in turn (m², rad² per unit coefficient); ``between_cov = Σ k_c · part_c + floor``.
    refl_offset_cov_parts : (3, B, 3, 3) the same for each reflection's offset.
    between_dist : (K - 1,) signed distance rolled between keyframes (m, s = 1).
    refl_offset_dist : (B,) signed distance rolled from the keyframe to the reflection (m, s = 1).
    odometry_k : (3,) the coefficients ``k_d``, ``k_dθ``, ``k_θ`` of ``between_cov`` and ``refl_offset_cov``.
    refl_alpha : (B,) None, or the reflections are interpolated between keyframes (:func:`interpolate_drive`).
    interp_alpha : (B,) each reflection's time fraction of its keyframe interval, for :func:`interpolate_drive`.
    interp_bridge_parts : (3, B, 3, 3) the interpolated offset's covariance per unit coefficient.
    step_id, step_frac, step_parts : each reflection's odometry step, the fraction ``f`` of it at the stamp and
    the step's covariance per unit coefficient ``(3, B, 3, 3)`` (keyframe frame): slip that acts within the
    step (a wheel slipping continuously) moves the pose off the interpolation by a Brownian bridge,
    ``cov = (f_i − f_i f_j) C_S`` between two reflections ``f_i <= f_j`` of one step, common to its bearings.
    """

    keyframe_t: F64
    odom_poses: F64
    between: F64
    between_cov: F64
    refl_keyframe: I64
    refl_offset: F64
    refl_offset_cov: F64
    refl_t: F64
    bearing: F64
    mount: F64
    between_cov_parts: F64 | None = None
    refl_offset_cov_parts: F64 | None = None
    between_dist: F64 | None = None
    refl_offset_dist: F64 | None = None
    odometry_k: F64 | None = None
    refl_alpha: F64 | None = None
    interp_alpha: F64 | None = None
    interp_bridge_parts: F64 | None = None
    step_id: I64 | None = None
    step_frac: F64 | None = None
    step_parts: F64 | None = None


def interpolate_drive(drive: Drive) -> Drive:
    """The drive with each reflection interpolated between its keyframe and the next (graph's BearingFactors).

    ``refl_alpha (B,)`` the fraction of the keyframe interval's time at the stamp; the offsets become
    ``v = u − α z`` (``z`` the interval's odometry, ``u`` the offset to the stamp) and their covariance the
    bridge's (``interp_bridge_parts``, :func:`prepare_drive`): zero when every odometry instant is a keyframe.
    """
    if drive.interp_alpha is None or drive.interp_bridge_parts is None or drive.odometry_k is None:
        raise ValueError("interpolate_drive needs a drive from prepare_drive (interp_alpha, interp_bridge_parts)")
    a_kf = drive.refl_keyframe
    alpha = drive.interp_alpha
    v = drive.refl_offset - alpha[:, None] * drive.between[a_kf]
    vd = None if drive.refl_offset_dist is None or drive.between_dist is None else \
        drive.refl_offset_dist - alpha * drive.between_dist[a_kf]
    parts = drive.interp_bridge_parts
    cov = np.einsum("c,cnij->nij", drive.odometry_k, parts)
    return Drive(drive.keyframe_t, drive.odom_poses, drive.between, drive.between_cov, a_kf, v, cov, drive.refl_t,
                 drive.bearing, drive.mount, drive.between_cov_parts, parts, drive.between_dist, vd, drive.odometry_k,
                 alpha, alpha, parts, drive.step_id, drive.step_frac, drive.step_parts)


def _clip_diagonal(cov: F64) -> F64:
    """``cov (..., 3, 3)`` with negative diagonal entries (rounding of the bridge formula) set to 0."""
    out = cov.copy()
    for i in range(3):
        out[..., i, i] = np.maximum(out[..., i, i], 0.0)
    return out


#: Length (m) below which a turn's radius no longer scales the slip's heading error with the distance: the traction
#: slip's increment covariance is ``z zᵀ / max(|ΔD|, SLIP_LENGTH |Δθ|)`` (:func:`unit_increment_cov`), bounded
#: when a steered wheel turns the vehicle on the spot (``ΔD → 0``). An assumption (about a wheelbase); no shipped
#: drive turns tighter than a 1.5 m radius, where it does not act.
SLIP_LENGTH = 0.5


def unit_increment_cov(dd: Any, dth: Any) -> F64:
    """``(..., 3, 2, 2)``: the covariance of the increment ``z = (ΔD, Δθ)`` (m, rad) for unit ``k_d``, ``k_dθ``,
    ``k_θ`` in turn.

    ``k_d`` is the traction slip, variance per metre rolled: a wheel that slips rolls more or less of the same
    arc, so the slip scales the whole increment, ``δz = z ε`` with ``var ε = k_d / |ΔD|``: its part is
    ``z zᵀ / |ΔD|``, the distance's ``k_d |ΔD|`` and the turn's ``k_d |ΔD| κ²`` perfectly correlated (``κ = Δθ/ΔD``;
    [seed002 eq17] has the distance part alone, and a steered vehicle's turns then carried the slip's heading
    error as independent ``k_θ`` noise). For a differential drive with independent wheel slips the common mode
    has this form too (``cov(ΔD, Δθ) = k_d Δθ``); the wheels' difference is ``k_dθ``. ``k_dθ``: heading variance
    per metre, ``k_θ``: per radian turned, as in [seed002 eq17].
    """
    dd = np.asarray(dd, dtype=np.float64)
    dth = np.asarray(dth, dtype=np.float64)
    out = np.zeros(dd.shape + (3, 2, 2))
    norm = np.maximum(np.abs(dd), SLIP_LENGTH * np.abs(dth))
    inv = np.divide(1.0, norm, out=np.zeros_like(norm), where=norm > 0.0)
    out[..., 0, 0, 0] = dd * dd * inv
    out[..., 0, 0, 1] = out[..., 0, 1, 0] = dd * dth * inv
    out[..., 0, 1, 1] = dth * dth * inv
    out[..., 1, 1, 1] = np.abs(dd)
    out[..., 2, 1, 1] = np.abs(dth)
    return out


def _propagate_parts(local: F64, parts: F64, dd: float, dth: float) -> tuple[F64, F64]:
    """One midpoint step of the three unit-coefficient covariances ``(3, 3, 3)`` ([seed002 eq14] [seed002 eq17])."""
    F = pose_jacobian(local, dd, dth, rule="midpoint")
    G = increment_jacobian(local, dd, dth, rule="midpoint")
    new = F @ parts @ F.T + G @ unit_increment_cov(dd, dth) @ G.T
    return integrate_pose(local, dd, dth, rule="midpoint"), new


def _step_poses(inc: F64) -> F64:
    """Relative pose ``(n, 3)`` of each step (midpoint heading), in the step's start frame."""
    dd, dth, dl = inc[:, 0], inc[:, 1], inc[:, 2]
    c, s = np.cos(0.5 * dth), np.sin(0.5 * dth)
    return np.column_stack([dd * c - dl * s, dd * s + dl * c, dth])


def odometry_poses(increments: F64) -> F64:
    """Poses ``(n + 1, 3)`` integrated from body increments ``(n, 3)`` (start at the origin), vectorised.

    Heading ``θ_k = Σ Δθ`` (unwrapped), each step's displacement rotated by the heading at its start
    and the midpoint rule inside the step.
    """
    inc = np.asarray(increments, dtype=np.float64)
    local = _step_poses(inc)
    theta = np.concatenate([[0.0], np.cumsum(inc[:, 1])])
    c, s = np.cos(theta[:-1]), np.sin(theta[:-1])
    dx = c * local[:, 0] - s * local[:, 1]
    dy = s * local[:, 0] + c * local[:, 1]
    return np.column_stack([np.concatenate([[0.0], np.cumsum(dx)]), np.concatenate([[0.0], np.cumsum(dy)]), theta])


def repeated_readings(stamp: F64, bearing: F64, rate_hz: float) -> NDArray[np.bool_]:
    """``(B,)`` True for the reflections to drop: all but the middle one of each run of identical readings.

    A head that sees a reflector at the same encoder count revolution after revolution (standing, or moving
    so slowly that the bearing stays inside one pulse) repeats one reading with one quantisation error: the
    run is one measurement, not ``n`` independent ones. A run is the same bearing value (rad, exactly: another
    reflector at the same count is a 1-in-65535 chance) again within 1.5 revolutions (``rate_hz``, Hz) of
    ``stamp`` (s); its middle reading is kept (moving through the pulse, the middle is where the bearing is
    nearest the pulse's centre). :func:`prepare_drive` applies it to the readings taken standing. Warehouse
    drive, seed 0: 1758 of 44 000 readings dropped (the stops at the stations); the quantisation errors of one
    reflector summed over 64 readings had 2.2 times the variance of independent ones, 0.99 times without
    those runs, and the reflector covariances were ~2x optimistic (joint NEES 4.4 with the simulator's
    quantisation against 2.0 with independent errors, same drive).
    """
    order = np.argsort(stamp, kind="stable")
    drop = np.zeros(stamp.shape[0], dtype=bool)
    runs: dict[float, list[int]] = {}
    last: dict[float, float] = {}
    window = 1.5 / rate_hz

    def close(run: list[int]) -> None:
        if len(run) > 1:
            mid = run[len(run) // 2]
            drop[[i for i in run if i != mid]] = True

    for i in order.tolist():
        v = float(bearing[i])
        if v in last and stamp[i] - last[v] <= window:
            runs[v].append(i)
        else:
            if v in runs:
                close(runs[v])
            runs[v] = [i]
        last[v] = float(stamp[i])
    for run in runs.values():
        close(run)
    return drop


def prepare_drive(log: Any, keyframe_s: float = 0.0, noise: OdometryNoise | None = None,
                  mount: Any = None, drop_repeats: bool = True) -> Drive:
    """Cut ``log`` (a :class:`agvnav.logs.RecordedLog`) into keyframes every ``keyframe_s`` seconds (0: every
    odometry instant, where interpolated bearings carry no odometry noise of their own).

    ``noise`` defaults to the log's ``odometry_noise`` setting, else :class:`OdometryNoise`'s
    defaults; ``mount`` (m, m, rad) to the log's ``mount`` setting, else the origin.
    Reflections stamped at or before the first odometry instant or after the last are dropped, and with
    ``drop_repeats`` all but one of each run of identical readings while the vehicle stands (the odometry step
    reads zero; :func:`repeated_readings`, the log's ``rate_hz``, default 8 Hz).
    """
    if not (math.isfinite(keyframe_s) and keyframe_s >= 0.0):
        raise ValueError(f"keyframe_s must be a non-negative number of seconds, got {keyframe_s!r}")
    settings = getattr(log, "settings", {}) or {}
    if noise is None:
        noise = OdometryNoise(*settings["odometry_noise"]) if settings.get("odometry_noise") else OdometryNoise()
    mount_arr = np.asarray(mount if mount is not None else settings.get("mount") or (0.0, 0.0, 0.0), dtype=np.float64)
    t = np.asarray(log.t, dtype=np.float64)
    inc = np.asarray(log.increments, dtype=np.float64)
    n = t.shape[0]
    # keyframes: the first instant, then the first instant at least keyframe_s after the previous keyframe
    kf = [0]
    for k in range(1, n):
        if t[k] - t[kf[-1]] >= keyframe_s - 1e-9:
            kf.append(k)
    if kf[-1] != n - 1:
        kf.append(n - 1)
    kf_idx = np.array(kf, dtype=np.int64)
    poses = odometry_poses(inc)
    # covariance of the odometry from the last keyframe at or before each instant
    parts_from_kf = np.zeros((n, 3, 3, 3))  # (instant, component, 3, 3)
    kf_of_step = np.searchsorted(kf_idx, np.arange(n), side="right") - 1  # keyframe index at or before k
    is_kf = np.zeros(n, dtype=bool)
    is_kf[kf_idx] = True
    local = np.zeros(3)
    parts = np.zeros((3, 3, 3))
    for k in range(1, n):  # parts_from_kf[k]: pose k relative to the last keyframe before it
        if is_kf[k - 1]:
            local, parts = np.zeros(3), np.zeros((3, 3, 3))
        local, parts = _propagate_parts(local, parts, float(inc[k - 1, 0]), float(inc[k - 1, 1]))
        parts_from_kf[k] = parts
    k_vec = np.array([noise.k_d, noise.k_dtheta, noise.k_theta])
    cov_from_kf = np.einsum("c,ncij->nij", k_vec, parts_from_kf)
    dist_cum = np.concatenate([[0.0], np.cumsum(inc[:, 0])])
    between_cov = cov_from_kf[kf_idx[1:]] + np.diag(ODOMETRY_FLOOR)
    between_parts = np.moveaxis(parts_from_kf[kf_idx[1:]], 1, 0).copy()
    between_dist = np.diff(dist_cum[kf_idx])
    betw = between(poses[kf_idx[:-1]], poses[kf_idx[1:]])
    betw[:, 2] = poses[kf_idx[1:], 2] - poses[kf_idx[:-1], 2]  # unwrapped heading change
    # reflections
    stamp = np.asarray(log.reflection_stamp, dtype=np.float64)
    bearing = np.asarray(log.bearing, dtype=np.float64)
    keep = (stamp > t[0]) & (stamp <= t[-1])
    if drop_repeats and stamp.size:
        # standing (the odometry step holding the stamp reads zero): the same pose, so a repeated count is the
        # same measurement; moving, a run of one count is the bearing passing through the pulse, and on a
        # coarse head (the differential AGV's) thinning the runs broke the tracks and lost reflectors
        in_step = np.clip(np.searchsorted(t, stamp, side="left") - 1, 0, n - 2)
        still = np.flatnonzero(keep & np.all(inc[in_step] == 0.0, axis=1))
        if still.size:
            keep[still[repeated_readings(stamp[still], bearing[still], float(settings.get("rate_hz") or 8.0))]] = False
    stamp, bearing = stamp[keep], bearing[keep]
    step = np.clip(np.searchsorted(t, stamp, side="left") - 1, 0, n - 2)  # t[step] < stamp <= t[step + 1]
    frac = (stamp - t[step]) / (t[step + 1] - t[step])
    partial = inc[step] * frac[:, None]
    part = _step_poses(partial)
    c, s = np.cos(poses[step, 2]), np.sin(poses[step, 2])
    at = np.column_stack([poses[step, 0] + c * part[:, 0] - s * part[:, 1],
                          poses[step, 1] + s * part[:, 0] + c * part[:, 1], poses[step, 2] + part[:, 2]])
    a = kf_of_step[step]
    off = between(poses[kf_idx[a]], at)
    off[:, 2] = at[:, 2] - poses[kf_idx[a], 2]
    # offset covariance: up to t[step] (zero when the step starts at the keyframe), plus the partial step
    base_parts = np.where(is_kf[step][:, None, None, None], 0.0, parts_from_kf[step])
    start = between(poses[kf_idx[a]], poses[step])
    dd_p, dth_p = inc[step, 0] * frac, inc[step, 1] * frac
    F = pose_jacobian(start, dd_p, dth_p, rule="midpoint")[:, None]  # (B, 1, 3, 3)
    G = increment_jacobian(start, dd_p, dth_p, rule="midpoint")[:, None]  # (B, 1, 3, 2)
    unit = unit_increment_cov(dd_p, dth_p)
    off_parts = F @ base_parts @ np.swapaxes(F, -1, -2) + G @ unit @ np.swapaxes(G, -1, -2)
    off_cov = np.einsum("c,ncij->nij", k_vec, off_parts)
    off_dist = dist_cum[step] + partial[:, 0] - dist_cum[kf_idx[a]]
    # interpolation between keyframes a and a+1 (interpolate_drive): the time fraction alpha, and the bridge's
    # covariance per unit coefficient. The reflection's step S lies after whole steps W from keyframe a and
    # before the rest R up to a+1; an odometry step's error is spread over it in proportion (the motion
    # between two odometry instants is interpolated, as the offset is), so the interpolated offset's
    # error is (1 - α) e_W + (f - α) e_S - α e_R: zero when every odometry instant is a keyframe.
    alpha = np.clip((stamp - t[kf_idx[a]]) / (t[kf_idx[a + 1]] - t[kf_idx[a]]), 0.0, 1.0)
    G_full = increment_jacobian(start, inc[step, 0], inc[step, 1], rule="midpoint")[:, None]
    unit_full = unit_increment_cov(inc[step, 0], inc[step, 1])
    c_s = G_full @ unit_full @ np.swapaxes(G_full, -1, -2)
    c_r = _clip_diagonal(parts_from_kf[kf_idx[a + 1]] - base_parts - c_s)
    w = lambda x: x[:, None, None, None]  # noqa: E731 - (B,) weights over (B, 3, 3, 3)
    bridge = w((1.0 - alpha) ** 2) * base_parts + w((frac - alpha) ** 2) * c_s + w(alpha ** 2) * c_r
    return Drive(t[kf_idx], poses[kf_idx], betw, between_cov, a.astype(np.int64), off, off_cov, stamp, bearing,
                 mount_arr, between_parts, np.moveaxis(off_parts, 1, 0).copy(), between_dist, off_dist, k_vec,
                 None, alpha, np.moveaxis(bridge, 1, 0).copy(), step.astype(np.int64), frac,
                 np.moveaxis(c_s, 1, 0).copy())
