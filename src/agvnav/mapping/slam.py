"""Reflector mapping from a drive: associate, initialise, solve incrementally, then anchor and solve in batch.

1. **Front end** (incremental): the drive is processed in chunks of ``chunk_s`` seconds. New
   keyframes are dead-reckoned from the last solved one; each reflection is gated against the
   known reflectors (:func:`agvnav.mapping.association.associate`); the unassociated ones wait in
   a pool (the last ``pool_s`` seconds) from which new reflectors are triangulated
   (:func:`agvnav.mapping.initialise.initialise_reflectors`); a new track within ``merge_distance`` of a known
   reflector is merged into it only if its rays fit no other reflector better (:func:`_track_target`: rays along
   one line of sight through two reflectors triangulate anywhere on it). After each chunk that added
   sightings, the graph so far is re-solved from the previous solution (a warm-started
   Levenberg-Marquardt of a few iterations: the incremental update; GTSAM's iSAM2 is not used).
   The front end's frame is the start pose with the odometry scale held at 1: provisional.
2. **Anchoring**: the provisional map is moved into the anchors' frame (a similarity onto the
   surveyed reflectors, or the start pose), and the anchors become priors: reflector priors,
   distance factors, a start-pose prior, a prior on the odometry scale
   (:mod:`agvnav.mapping.anchors`). No anchor: :class:`~agvnav.mapping.anchors.ScaleUnobservable`.
3. **Batch**: each bearing factor interpolates the pose between the two keyframes around its reflection
   (a keyframe at every odometry instant: :func:`agvnav.mapping.drive.interpolate_drive`); every
   reflection is re-associated against the solved trajectory and the kept reflectors with a tight gate, a lone
   reflection (no other of its reflector within ``max_gap_s``: clutter, :func:`_isolated`) left out (after each
   solve that re-associates, the reflections no reflector claims are triangulated into new reflectors,
   :func:`_initialise_leftovers`, ``batch_initialise``),
   reflectors without ``min_sightings`` from ``min_baseline`` are dropped, the graph is solved to
   convergence with the odometry's systematic errors (scale, heading rate, turn scale), bearing
   outliers beyond ``outlier_sigma`` are removed and it is solved again. The noise is estimated
   from the drive by variance components (Förstner; per component redundancy): the bearing std
   and Crowley's three odometry coefficients, iterated to their fixed point in each pass before the
   outlier cut (a cut with an unconverged, too small bearing std censors the residuals and shrinks the
   std further: the cause of the optimistic covariances, issue 17). Bearings are corrected by half an encoder pulse (the
   head reports the last whole pulse, as the EKF corrects it). The reflector covariances are the
   blocks of ``(JᵀJ)⁻¹``, jointly (:func:`agvnav.mapping.solve.reflector_covariance`).

An existing map (``existing``) seeds the reflector list: its reflectors are associated from the
start (the start pose must then be in its frame), refined with their covariance as priors, and
keep their ids; the frame does not move, new reflectors are added.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from agvnav.geometry import compose, wrap_angle
from agvnav.mapping.anchors import (
    Anchor,
    BaselineAnchor,
    ScaleUnobservable,
    StartPoseAnchor,
    SurveyedAnchor,
    anchor_kind,
    apply_similarity,
    match_surveyed,
)
from agvnav.mapping.association import associate, head_poses, predicted_edge_bearings, ray_covariances
from agvnav.mapping.drive import ODOMETRY_FLOOR, Drive, interpolate_drive, prepare_drive
from agvnav.mapping.graph import (
    BearingFactors,
    DistanceFactors,
    FactorGraph,
    OdometryFactors,
    PosePriors,
    ReflectorPriors,
    linearize,
    whitener,
)
from agvnav.mapping.initialise import InitialiseOptions, initialise_from_tracks, ray_misfit
from agvnav.mapping.solve import factorize, reflector_covariance, solve
from agvnav.odometry import OdometryNoise
from agvnav.positioning import encoder_bearing_std

__all__ = ["FrontEnd", "MappingOptions", "MappingResult", "build_map", "front_end", "solve_anchored"]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

UNOBSERVABLE = ("scale unobservable: bearings carry no scale and the odometry's is not calibrated; anchor the map "
                "(--anchor) with two or more surveyed reflectors (surveyed:FILE), a taped baseline between two "
                "reflectors (baseline:X1,Y1,X2,Y2,D) or a known start pose with the calibrated odometry (start_pose)")


@dataclass(frozen=True)
class MappingOptions:
    """Settings of :func:`build_map` (SI units).

    radius : reflector radius (m) of the leading-edge model. direction : +1 for a CCW head.
    bearing_std : bearing std (rad); None: the encoder's quantisation (from the log's pulses_per_rev,
    else 65535) with a floor of ``bearing_std_floor``.
    keyframe_s, chunk_s, pool_s : keyframe spacing (0: every odometry instant, so that an interpolated bearing
    factor carries no odometry noise: a 0.1 s spacing left joint NEES 5-15 on the lab drive), front-end
    chunk, pool memory (s).
    gate_sigma, position_tol : front-end gate (σ, m); final_position_tol : batch gate (m).
    outlier_sigma : bearings with a whitened residual beyond this are dropped in the batch.
    existing_std : prior std (m) of an existing map's reflector that states no covariance or survey std.
    window_s : the front end re-solves the poses of the last ``window_s`` seconds (and every reflector).
    front_sigma : bearing std (rad) the front end assumes for a reflector's own uncertainty in its gate
    (dead-reckoned poses). merge_distance : front-end reflectors closer than this (m) are one.
    front_odometry_var : the front end multiplies the odometry covariance by this (it trusts dead
    reckoning over its window; the batch estimates the real coefficients). variance_passes : batch passes
    of association, solution and variance-component estimation. variance_iterations, variance_tolerance :
    per pass, the variance components are iterated (each step a solution) until no component changes by
    more than ``variance_tolerance`` in log (at most ``variance_iterations`` steps). variance_probes : random probes of
    the redundancy traces (Hutchinson, fixed seed). bearing_offset : added to every bearing (rad);
    None: half an encoder pulse (``π / pulses_per_rev``, the head reports the last whole pulse passed,
    as the EKF corrects it), unless the log's settings state ``bearing_offset``.
    gate_odometry_var : the front end's gate takes the odometry offset's heading variance inside the step times at
    least this (the stated odometry noise: the gate must not trust dead reckoning inside a step more than it); the
    heading dead-reckoned since the last window solution enters at the windows' estimated factor of the noise.
    front_calibration : the front end also solves the heading rate and turn scale per window.
    heading_rate_std, turn_scale_std : std of the zero-mean priors on the odometry's systematic heading
    rate (rad/m) and turn scale estimated in the batch (:mod:`agvnav.mapping.graph`).
    interpolate : the batch's bearing factors interpolate the pose between the two keyframes around the
    reflection (:func:`agvnav.mapping.drive.interpolate_drive`) instead of hanging it on the earlier one
    with the odometry offset's variance as bearing noise (shared by every bearing of the interval, it
    over-weighted them: joint NEES 5-15 on the lab drive).
    in_step_slip : the bearings of one odometry step share the slip inside it (a Brownian bridge between the
    two keyframes, :class:`StepNoise`), its own variance component ``λ_s`` (a vehicle whose wheels do not
    slip within a step drives it to zero).
    drop_repeats : one reading of each run of identical readings taken standing
    (:func:`agvnav.mapping.drive.repeated_readings`: a head standing repeats one quantisation error).
    batch_initialise : after each batch solve that re-associates, reflectors are initialised from the reflections no
    reflector claims (tracks against the solved trajectory: a reflector the front end missed beside others, or one
    it placed 10-20 cm off whose sightings the batch then drops: warehouse seed 0, rack_3_n5 and rack_3_n6). It was
    off while the re-association counted dropped reflectors as candidates (their ambiguity left true reflections
    over, and on the differential AGV they made a spurious reflector).
    head_yaw_std : std (rad) of the head's yaw on the vehicle: a frame given by the start pose is
    only as well oriented as the head is calibrated (added to the start pose's heading variance).
    """

    radius: float = 0.04
    direction: int = 1
    bearing_std: float | None = None
    bearing_std_floor: float = 2e-5
    keyframe_s: float = 0.0
    chunk_s: float = 1.0
    pool_s: float = 10.0
    window_s: float = 10.0
    front_sigma: float = 1e-3
    merge_distance: float = 0.15
    use_lcov: bool = True
    front_odometry_var: float = 0.01
    variance_passes: int = 5
    variance_iterations: int = 8
    variance_tolerance: float = 0.05
    variance_probes: int = 48
    bearing_offset: float | None = None
    heading_rate_std: float = 0.05
    turn_scale_std: float = 0.1
    front_calibration: bool = False
    gate_odometry_var: float = 1.0
    head_yaw_std: float = 2e-4
    gate_sigma: float = 5.0
    position_tol: float = 0.05
    final_position_tol: float = 0.005
    outlier_sigma: float = 5.0
    max_range: float | None = None
    existing_std: float = 0.001
    front_iterations: int = 3
    interpolate: bool = True
    batch_initialise: bool = True
    drop_repeats: bool = True
    in_step_slip: bool = True
    odometry_noise: OdometryNoise | None = None
    init: InitialiseOptions = field(default_factory=InitialiseOptions)

    def __post_init__(self) -> None:
        if not self.radius >= 0.0:
            raise ValueError(f"radius must be >= 0 m, got {self.radius!r}")
        if self.direction not in (1, -1):
            raise ValueError(f"direction must be +1 or -1, got {self.direction!r}")
        if not self.keyframe_s >= 0.0:
            raise ValueError(f"keyframe_s must be >= 0 s, got {self.keyframe_s!r}")
        for name in ("chunk_s", "pool_s", "gate_sigma", "position_tol", "final_position_tol",
                     "outlier_sigma"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)!r}")


@dataclass
class FrontEnd:
    """The provisional map: keyframe poses ``(K, 3)``, reflectors ``(N, 2)``, the association ``(B,)`` of
    every reflection (-1: none), ids of the reflectors (existing ones keep theirs, new ones are None),
    the drive, and the odometry's heading rate and turn scale ``calibration`` (rad/m, -)."""

    drive: Drive
    poses: F64
    landmarks: F64
    assoc: I64
    ids: list[str | None]
    sigma: F64
    max_range: float
    runtime_s: float
    calibration: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class MappingResult:
    """A solved map.

    ids (N,), xy (N, 2) m, covariance (N, 2, 2) m², sightings (N,) associated reflections each;
    poses (K, 3) keyframe trajectory in map and keyframe_t (K,) s; scale and scale_std of the odometry;
    anchor: which anchors fixed frame and scale; reflections / associated / unassociated counts;
    chi2_per_dof of the solution; runtime_s (front end and batch). heading_rate (rad/m) and turn_scale:
    the odometry's systematic errors estimated with the map; odometry_noise ``(k_d, k_dθ, k_θ)`` and
    bearing_std (rad): the noise estimated from the drive (variance components; the bearing's median
    std, encoder and the odometry offset inside a keyframe step). joint_covariance (2N, 2N) m²: all
    reflector centres ``[x_0, y_0, x_1, ...]`` together (their errors share the anchor's and the
    trajectory's; ``covariance`` holds its diagonal blocks).
    """

    ids: tuple[str, ...]
    xy: F64
    covariance: F64
    sightings: I64
    poses: F64
    keyframe_t: F64
    scale: float
    scale_std: float
    anchor: str
    reflections: int
    associated: int
    chi2_per_dof: float
    runtime_s: float
    existing_ids: tuple[str, ...] = ()
    heading_rate: float = 0.0
    turn_scale: float = 0.0
    odometry_noise: tuple[float, float, float] | None = None
    bearing_std: float | None = None
    joint_covariance: F64 | None = None


def _bearing_sigma(log: Any, options: MappingOptions) -> float:
    if options.bearing_std is not None:
        if not options.bearing_std > 0.0:
            raise ValueError(f"bearing_std must be positive, got {options.bearing_std!r}")
        return float(options.bearing_std)
    ppr = (getattr(log, "settings", {}) or {}).get("pulses_per_rev") or 65535
    return max(encoder_bearing_std(float(ppr)), options.bearing_std_floor)


def _bearing_var_parts(drive: Drive, sigma: float, heads: F64, landmarks: F64, assoc: I64,
                       odo_var: F64 | float = 1.0, lam_b: float = 1.0) -> F64:
    """Variance parts ``(B, 4)`` (rad²) of each bearing: the encoder's ``λ_b σ²`` and the odometry offset's
    (position over range, heading) for ``k_d``, ``k_dθ``, ``k_θ`` in turn.

    ``odo_var``: a scalar multiplies the drive's odometry covariance (all in the ``k_d`` column); a
    ``(3,)`` vector multiplies each of Crowley's coefficients.
    """
    B = drive.bearing.shape[0]
    if np.ndim(odo_var) == 0 or drive.refl_offset_cov_parts is None or drive.odometry_k is None:
        covs = (drive.refl_offset_cov * float(np.mean(odo_var)))[None]
    else:
        covs = drive.refl_offset_cov_parts * (np.asarray(odo_var) * drive.odometry_k)[:, None, None, None]
    out = np.zeros((B, 4))
    out[:, 0] = lam_b * sigma ** 2
    ok = assoc >= 0
    inv_d2 = np.zeros(B)
    if landmarks.shape[0] and np.any(ok):
        d = np.hypot(*(landmarks[assoc[ok]] - heads[ok, :2]).T)
        inv_d2[ok] = 1.0 / np.maximum(d, 0.3) ** 2
    for c in range(covs.shape[0]):
        out[:, 1 + c] = covs[c, :, 2, 2] + (covs[c, :, 0, 0] + covs[c, :, 1, 1]) * inv_d2
    return out


def _bearing_offset(log: Any, options: MappingOptions) -> float:
    """Added to every bearing (rad): the option, else the log's ``bearing_offset`` setting, else half a pulse."""
    if options.bearing_offset is not None:
        return float(options.bearing_offset)
    settings = getattr(log, "settings", {}) or {}
    if settings.get("bearing_offset") is not None:
        return float(settings["bearing_offset"])
    return math.pi / float(settings.get("pulses_per_rev") or 65535)


def _sigma_eff(drive: Drive, sigma: float, heads: F64, landmarks: F64, assoc: I64, odo_var: F64 | float = 1.0,
               lam_b: float = 1.0) -> F64:
    """Bearing std per reflection (rad): the square root of the sum of :func:`_bearing_var_parts`."""
    return np.sqrt(_bearing_var_parts(drive, sigma, heads, landmarks, assoc, odo_var, lam_b).sum(axis=1))


def _odometry_total(drive: Drive, odo_var: F64) -> F64:
    """``(2,)``: the summed position (m²) and heading (rad²) variance of all between-keyframe factors for the
    coefficient multipliers ``odo_var``: what the variance iteration must settle (a component the drive cannot
    tell from zero keeps halving without changing these)."""
    cov = _odometry_cov(drive, drive.between.shape[0], odo_var)
    return np.array([float(np.sum(cov[:, 0, 0] + cov[:, 1, 1])), float(np.sum(cov[:, 2, 2]))])


def _odometry_cov(drive: Drive, n: int, odo_var: F64 | float) -> F64:
    """Between-keyframe covariances ``(n, 3, 3)``: scalar ``odo_var`` times the drive's, or per coefficient."""
    if np.ndim(odo_var) == 0 or drive.between_cov_parts is None or drive.odometry_k is None:
        return drive.between_cov[:n] * float(np.mean(odo_var))
    k = np.asarray(odo_var) * drive.odometry_k
    return np.einsum("c,cnij->nij", k, drive.between_cov_parts[:, :n]) + np.diag(ODOMETRY_FLOOR)


def _graph(drive: Drive, n_poses: int, landmarks: F64, assoc: I64, sig: F64, options: MappingOptions,
           pose_priors: PosePriors, reflector_priors: ReflectorPriors | None = None,
           distances: DistanceFactors | None = None, scale_prior: tuple[float, float] | None = None,
           odo_var: F64 | float = 1.0, calibration: bool = False,
           bearing_whitener: sp.csr_matrix | None = None) -> FactorGraph:
    use = _used(drive, assoc, n_poses)
    e = np.arange(n_poses - 1)
    dist = None if drive.between_dist is None else drive.between_dist[:n_poses - 1]
    odo = OdometryFactors(e, e + 1, drive.between[:n_poses - 1], whitener(_odometry_cov(drive, n_poses - 1, odo_var)),
                          dist)
    bear = BearingFactors(drive.refl_keyframe[use], assoc[use], drive.refl_offset[use], drive.bearing[use], sig[use],
                          drive.mount, options.radius, options.direction,
                          None if drive.refl_offset_dist is None else drive.refl_offset_dist[use],
                          None if drive.refl_alpha is None else drive.refl_alpha[use], bearing_whitener)
    kw: dict[str, Any] = {"pose_priors": pose_priors, "scale_prior": scale_prior}
    if calibration:
        kw["calibration_prior"] = (options.heading_rate_std, options.turn_scale_std)
    if reflector_priors is not None:
        kw["reflector_priors"] = reflector_priors
    if distances is not None:
        kw["distances"] = distances
    return FactorGraph(n_poses, landmarks.shape[0], odo, bear, **kw)


def _window_graph(drive: Drive, k0: int, n: int, poses: F64, landmarks: F64, assoc: I64, sig: F64, heads: F64,
                  options: MappingOptions, prior_cov: F64 | None,
                  odo_var: float, calibration: tuple[float, float]) -> tuple[FactorGraph, NDArray[np.bool_]]:
    """The front end's sliding window: poses ``k0 .. n-1`` (the first held), every reflector, and
    ``free`` (the variables to solve). The bearings from poses before ``k0`` (held for good) enter
    as a prior on each reflector, their information ``Σ g gᵀ / σ²`` at the current estimate (plus
    an existing map's prior and 1 m⁻² so a reflector seen only in the past stays regular): the
    cost of a chunk no longer grows with the drive (the whole history was relinearised each second).
    The odometry's heading rate and turn scale are solved in each window, their prior centred on the
    previous window's (a random walk): dead reckoning with a 1 % turn error (the differential AGV's
    track) put reflectors 0.2 m off after a half turn, and they were created twice.
    """
    N = landmarks.shape[0]
    past = (assoc >= 0) & (drive.refl_keyframe < k0)
    info = np.zeros((N, 2, 2))
    if np.any(past):
        a = assoc[past]
        dx = landmarks[a, 0] - heads[past, 0]
        dy = landmarks[a, 1] - heads[past, 1]
        d2 = np.maximum(dx * dx + dy * dy, 1e-12)
        gv = np.column_stack([-dy / d2, dx / d2]) / sig[past, None]
        np.add.at(info, a, gv[:, :, None] * gv[:, None, :])
    if prior_cov is not None:
        info[: prior_cov.shape[0]] += np.linalg.inv(prior_cov)
    info += np.eye(2)
    W = np.asarray(np.linalg.cholesky(info).transpose(0, 2, 1), dtype=np.float64)  # WᵀW = info
    rpri = ReflectorPriors(np.arange(N, dtype=np.int64), landmarks.copy(), W)
    m = n - k0
    e = np.arange(m - 1)
    odo = OdometryFactors(e, e + 1, drive.between[k0:n - 1],
                          whitener(_odometry_cov(drive, n - 1, odo_var)[k0:]),
                          None if drive.between_dist is None else drive.between_dist[k0:n - 1])
    use = (assoc >= 0) & (drive.refl_keyframe >= k0) & (drive.refl_keyframe < n)
    bear = BearingFactors(drive.refl_keyframe[use] - k0, assoc[use], drive.refl_offset[use], drive.bearing[use],
                          sig[use], drive.mount, options.radius, options.direction,
                          None if drive.refl_offset_dist is None else drive.refl_offset_dist[use])
    pp = PosePriors(np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3, 3)))
    g = FactorGraph(m, N, odo, bear, pose_priors=pp, reflector_priors=rpri, scale_prior=(1.0, 1e-6),
                    calibration_prior=(options.heading_rate_std, options.turn_scale_std),
                    calibration_mean=calibration)
    free = np.ones(g.n_vars, dtype=bool)
    free[:3] = False  # the window's first pose is held (it is tied to the poses before it)
    free[g.scale_index] = False  # the scale: the batch estimates it with the anchors
    if not options.front_calibration:
        free[g.scale_index:] = False
    return g, free


def _instep_heading_var(drive: Drive, odo_var: F64 | float, options: MappingOptions) -> F64:
    """``(B,)`` the in-step slip's heading variance at each reflection, ``f (1 − f) C_S,ψψ`` at unit ``λ_s``
    (rad²; zeros when ``options.in_step_slip`` is off or the drive has no steps)."""
    B = drive.bearing.shape[0]
    if not options.in_step_slip or drive.step_frac is None or drive.step_parts is None or drive.odometry_k is None:
        return np.zeros(B)
    k = np.broadcast_to(np.asarray(odo_var, dtype=np.float64), (3,)) * drive.odometry_k
    f = drive.step_frac
    return f * (1.0 - f) * np.einsum("c,cn->n", k, drive.step_parts[:, :, 2, 2])


def _used(drive: Drive, assoc: I64, n_poses: int) -> NDArray[np.bool_]:
    """The reflections that enter the graph as bearing factors (associated, their keyframes in the graph)."""
    use = (assoc >= 0) & (drive.refl_keyframe < n_poses)
    if drive.refl_alpha is not None:
        use &= drive.refl_keyframe + 1 < n_poses
    return use


@dataclass(frozen=True)
class StepNoise:
    """The bearing noise of the graph's bearings, in blocks of one odometry step each.

    ``blocks (G, m)``: indices into the graph's bearings (-1: padding); ``indep (G, m, m)``: the
    independent part (encoder, diagonal) at unit ``λ_b``; ``step (G, m, m)``: the in-step slip's Brownian
    bridge at unit ``λ_s``, ``(f_i − f_i f_j) g_iᵀ C_S g_j`` (``g`` the bearing's gradient with respect to
    the base_link offset, ``C_S`` the step's odometry covariance). Bearings of one step share it: as
    independent noise (or none, as before) the differential AGV's bearings, whose true in-step heading
    wanders by ~2 mrad (its wheels slip in every 5 ms substep), were over-weighted.
    """

    blocks: I64
    indep: F64
    step: F64

    def covariance(self, lam_b: float, lam_s: float) -> F64:
        """``(G, m, m)`` block covariances (rad²); padding on the diagonal is 1."""
        pad = self.blocks < 0
        cov = np.where(pad[:, :, None] | pad[:, None, :], 0.0, lam_b * self.indep + lam_s * self.step)
        g, a = np.nonzero(pad)
        cov[g, a, a] = 1.0
        return cov

    def whitener(self, lam_b: float, lam_s: float, n: int) -> tuple[sp.csr_matrix, F64]:
        """``(W (n, n), Wb (G, m, m))``: ``WᵀW = Σ⁻¹`` of the ``n`` bearings, and its blocks."""
        L = np.linalg.cholesky(self.covariance(lam_b, lam_s))
        Wb = np.linalg.solve(L, np.broadcast_to(np.eye(L.shape[-1]), L.shape))
        return _block_matrix(self.blocks, Wb, n), Wb

    def total(self, lam_b: float, lam_s: float) -> float:
        """The summed variance of all bearings (rad²)."""
        ok = self.blocks >= 0
        diag = np.diagonal(lam_b * self.indep + lam_s * self.step, axis1=1, axis2=2)
        return float(np.sum(diag[ok]))

    def marginal_var(self, lam_b: float, lam_s: float, n: int) -> F64:
        """``(n,)`` each bearing's own variance (rad²)."""
        out = np.zeros(n)
        ok = self.blocks >= 0
        diag = np.diagonal(lam_b * self.indep + lam_s * self.step, axis1=1, axis2=2)
        out[self.blocks[ok]] = diag[ok]
        return out


def _block_matrix(blocks: I64, vals: F64, n: int) -> sp.csr_matrix:
    """The ``(n, n)`` sparse matrix with ``vals[g, a, b]`` at ``(blocks[g, a], blocks[g, b])`` (padding dropped)."""
    m = blocks.shape[1]
    r = np.broadcast_to(blocks[:, :, None], (blocks.shape[0], m, m))
    c = np.broadcast_to(blocks[:, None, :], (blocks.shape[0], m, m))
    ok = (r >= 0) & (c >= 0) & (vals != 0.0)
    return sp.csr_matrix((vals[ok], (r[ok], c[ok])), shape=(n, n))


def _step_noise(drive: Drive, use: NDArray[np.bool_], heads: F64, landmarks: F64, assoc: I64, poses: F64,
                sig_indep: F64, odo_var: F64, options: MappingOptions) -> StepNoise | None:
    """The :class:`StepNoise` of the used bearings at the current estimate (None: the drive has no steps)."""
    if drive.step_id is None or drive.step_frac is None or drive.step_parts is None or drive.odometry_k is None:
        return None
    idx = np.flatnonzero(use)
    n = idx.size
    h, L = heads[idx], landmarks[assoc[idx]]
    dx, dy = L[:, 0] - h[:, 0], L[:, 1] - h[:, 1]
    d2 = np.maximum(dx * dx + dy * dy, 1e-12)
    d = np.sqrt(d2)
    ratio = np.clip(options.radius / d, 0.0, 0.999999)
    k = options.direction * options.radius / (d2 * d * np.sqrt(1.0 - ratio * ratio))
    gx, gy = -dy / d2 + k * dx, dx / d2 + k * dy
    psi_k = poses[drive.refl_keyframe[idx], 2]
    c, s = np.cos(psi_k), np.sin(psi_k)
    base = h[:, 2] - drive.mount[2]
    cb, sb = np.cos(base), np.sin(base)
    arm_x, arm_y = cb * drive.mount[0] - sb * drive.mount[1], sb * drive.mount[0] + cb * drive.mount[1]
    grad = np.column_stack([-(gx * c + gy * s), -(-gx * s + gy * c), -(gx * -arm_y + gy * arm_x) - 1.0])
    C = np.einsum("c,cnij->nij", odo_var * drive.odometry_k, drive.step_parts[:, idx])
    step, frac = drive.step_id[idx], drive.step_frac[idx]
    order = np.lexsort((frac, step))
    bounds = np.flatnonzero(np.diff(step[order])) + 1
    starts = np.r_[0, bounds]
    sizes = np.diff(np.r_[starts, n])
    G, m = starts.size, int(sizes.max(initial=1))
    blocks = np.full((G, m), -1, dtype=np.int64)
    pos = np.arange(n) - np.repeat(starts, sizes)
    grp = np.repeat(np.arange(G), sizes)
    blocks[grp, pos] = order
    ok = blocks >= 0
    safe = np.where(ok, blocks, 0)
    f = np.where(ok, frac[safe], 0.0)
    gb = np.where(ok[:, :, None], grad[safe], 0.0)
    Cb = C[safe[:, 0]]  # one step, one covariance
    gCg = np.einsum("gai,gij,gbj->gab", gb, Cb, gb)
    fi, fj = f[:, :, None], f[:, None, :]
    step_cov = (np.minimum(fi, fj) - fi * fj) * gCg
    indep = np.zeros((G, m, m))
    ga, pa = np.nonzero(ok)
    indep[ga, pa, pa] = sig_indep[idx][blocks[ga, pa]] ** 2
    return StepNoise(blocks, indep, step_cov)


def _variance_components(g: FactorGraph, x: F64, drive: Drive, odo_var: F64, lam_b: float,
                         probes: int, noise: StepNoise | None = None,
                         lam_s: float = 1.0) -> tuple[F64, float, float]:
    """One step of Förstner's variance-component estimation for the bearing std and Crowley's three
    odometry coefficients: each component ``c`` is scaled by ``q_c / r_c``, its share of the weighted
    square sum over its share of the redundancy.

    In whitened terms (``S_c``: the component's part of a factor's covariance, whitened; ``Σ_c S_c = I``)
    ``q_c = Σ eᵀ S_c e`` and ``r_c = Σ tr(S_c) − tr(S_c^½ J N⁻¹ Jᵀ S_c^½)`` with ``N = JᵀJ``. The trace
    is estimated with ``probes`` Rademacher vectors in the residual space (Hutchinson; fixed seed) and
    one sparse factorisation (probing ``N⁻¹ Jᵀ S J`` in the state space instead had a variance set
    by the badly scaled ``N⁻¹`` and failed on the warehouse drive).
    The earlier single factor for all odometry with the global redundancy ``1 − n/m`` let the bearings
    (which absorb the pose degrees of freedom) take too little redundancy: bearing std too small,
    reflector covariances 1.2-1.4x optimistic.
    The bearings are one component ``λ_b``: it scales their whole variance, the encoder's and the
    odometry offset's inside a keyframe step (both are white per bearing only approximately; the
    drive's offsets are what the estimate is fitted to).
    """
    e, J = linearize(g, x)
    assert J is not None
    J = J.tocsr()
    N = (J.T @ J).tocsc()
    # reflectors dropped in this pass have no factor: a unit diagonal keeps N regular (they touch no row)
    empty = N.diagonal() == 0.0
    if np.any(empty):
        N = (N + sp.diags(empty.astype(np.float64))).tocsc()
    try:
        lu = factorize(N)
    except RuntimeError:
        return odo_var, lam_b, lam_s
    rng = np.random.default_rng(17)
    E = g.odometry.i.size
    n_b = g.bearings.pose.size
    q = np.zeros(4)
    tr_s = np.zeros(4)
    t = np.zeros(4)

    def hat_trace(rows: Any) -> float:
        """``tr(A N⁻¹ Aᵀ)`` for the (whitened, weighted) rows ``A``: a block of the hat matrix, symmetric
        with eigenvalues in [0, 1], so Hutchinson's estimate has a variance below ``2 tr / probes``."""
        w = rng.choice(np.array([-1.0, 1.0]), size=(rows.shape[0], probes))
        v = np.asarray(rows.T @ w)
        return float(np.einsum("np,np->", v, lu.solve(v))) / probes

    # odometry factors: S_c = W (k_c part_c) Wᵀ, rows S_c^½ J
    if E and drive.between_cov_parts is not None and drive.odometry_k is not None:
        W = g.odometry.W
        eo = e[:3 * E].reshape(E, 3)
        Jo = J[:3 * E]
        k = odo_var * drive.odometry_k
        for c in range(3):
            S = W @ (k[c] * drive.between_cov_parts[c, :E]) @ np.swapaxes(W, 1, 2)
            S = 0.5 * (S + np.swapaxes(S, 1, 2))
            val, vec = np.linalg.eigh(S)
            half = (vec * np.sqrt(np.maximum(val, 0.0))[:, None, :]) @ np.swapaxes(vec, 1, 2)
            q[1 + c] += float(np.einsum("ea,eab,eb->", eo, S, eo))
            tr_s[1 + c] += float(np.trace(S, axis1=1, axis2=2).sum())
            t[1 + c] += hat_trace(sp.block_diag(list(half), format="csr") @ Jo)
    # bearings: one component scaling the independent bearing variance (encoder and the offset's odometry),
    # and with the in-step slip (StepNoise) a second, its blocks S_c = W Σ_c Wᵀ
    q_s = tr_ss = t_s = 0.0
    if n_b and noise is None:
        eb = e[3 * E:3 * E + n_b]
        q[0] = float(eb @ eb)
        tr_s[0] = float(n_b)
        t[0] = hat_trace(J[3 * E:3 * E + n_b])
    elif n_b and noise is not None:
        eb = e[3 * E:3 * E + n_b]
        Jb = J[3 * E:3 * E + n_b]
        _, Wb = noise.whitener(lam_b, lam_s, n_b)
        ok_b = noise.blocks >= 0
        e_blk = np.where(ok_b, eb[np.where(ok_b, noise.blocks, 0)], 0.0)
        res = []
        for part, lam in ((noise.indep, lam_b), (noise.step, lam_s)):
            S = Wb @ (lam * part) @ np.swapaxes(Wb, 1, 2)
            S = np.where(ok_b[:, :, None] & ok_b[:, None, :], 0.5 * (S + np.swapaxes(S, 1, 2)), 0.0)
            val, vec = np.linalg.eigh(S)
            half = (vec * np.sqrt(np.maximum(val, 0.0))[:, None, :]) @ np.swapaxes(vec, 1, 2)
            res.append((float(np.einsum("ga,gab,gb->", e_blk, S, e_blk)), float(np.trace(S, axis1=1, axis2=2).sum()),
                        hat_trace(_block_matrix(noise.blocks, half, n_b) @ Jb)))
        q[0], tr_s[0], t[0] = res[0]
        q_s, tr_ss, t_s = res[1]
    r = tr_s - t
    ratio = np.ones(4)
    ok = r > 1e-3 * np.maximum(tr_s, 1e-300)
    ratio[ok] = np.clip(q[ok] / r[ok], 1e-2, 1e2)
    ratio_s = float(np.clip(q_s / (tr_ss - t_s), 1e-2, 1e2)) if tr_ss - t_s > 1e-3 * max(tr_ss, 1e-300) else 1.0
    # floors on the accumulated factors (std 1/1000 of the stated noise, odometry variance 1e-8 of it): a noise-free
    # drive has no residual to estimate from, and iterated to convergence the factors ran to 0 (a singular graph)
    return np.maximum(odo_var * ratio[1:], 1e-8), max(lam_b * float(ratio[0]), 1e-6), max(lam_s * ratio_s, 1e-6)


def _dead_reckon(drive: Drive, start: F64, poses: F64, k_from: int, k_to: int,
                 calibration: tuple[float, float] = (0.0, 0.0)) -> None:
    """Poses ``k_from+1 .. k_to`` (inclusive) composed from pose ``k_from`` with the odometry (scale 1),
    its turns corrected by ``calibration = (κ, b)``: ``(1 + b) θ + κ D``."""
    kappa, b = calibration
    for k in range(k_from, k_to):
        z = drive.between[k].copy()
        if drive.between_dist is not None:
            z[2] = (1.0 + b) * z[2] + kappa * drive.between_dist[k]
        poses[k + 1] = compose(poses[k], z)
        poses[k + 1, 2] = poses[k, 2] + z[2]


def _existing_priors(existing: Any, options: MappingOptions) -> ReflectorPriors:
    n = len(existing.reflectors)
    cov = np.zeros((n, 2, 2))
    for j, r in enumerate(existing.reflectors):
        if r.covariance_m2 is not None:
            cov[j] = np.array(r.covariance_m2)
        std = r.survey_std_m if r.survey_std_m > 0.0 else options.existing_std
        if not np.all(np.linalg.eigvalsh(cov[j]) > 1e-14):
            cov[j] = np.eye(2) * std ** 2
    return ReflectorPriors(np.arange(n, dtype=np.int64), existing.reflector_xy.copy(), whitener(cov))


def front_end(log: Any, start: F64 | None = None, options: MappingOptions | None = None,
              existing: Any = None) -> FrontEnd:
    """The provisional map of ``log`` (module docstring, step 1), in the frame of ``start`` (default the origin).

    ``existing``: a :class:`agvnav.world.WorldMap` whose reflectors are known from the start
    (``start`` must then be in its frame).
    """
    opt = options or MappingOptions()
    t0 = time.perf_counter()
    settings = getattr(log, "settings", {}) or {}
    drive = prepare_drive(log, opt.keyframe_s, opt.odometry_noise, drop_repeats=opt.drop_repeats)
    drive = replace(drive, bearing=drive.bearing + _bearing_offset(log, opt))
    max_range = float(opt.max_range or settings.get("max_range_m") or 30.0)
    init = InitialiseOptions(**{**opt.init.__dict__, "max_range": max_range})
    sigma = _bearing_sigma(log, opt)
    K = drive.keyframe_t.shape[0]
    B = drive.bearing.shape[0]
    poses = np.zeros((K, 3))
    poses[0] = np.zeros(3) if start is None else np.asarray(start, dtype=np.float64)
    landmarks = np.zeros((0, 2)) if existing is None else existing.reflector_xy.copy()
    ids: list[str | None] = [] if existing is None else list(existing.reflector_ids)
    rpriors = None if existing is None else _existing_priors(existing, opt)
    prior_cov = None if rpriors is None else np.linalg.inv(np.einsum("nji,njk->nik", rpriors.W, rpriors.W))
    assoc = np.full(B, -1, dtype=np.int64)
    solved_to = 0
    # the last keyframe a window solution placed (the start pose: given); later ones are dead-reckoned
    fixed_to = 0
    # heading variance of the odometry from keyframe 0 to each keyframe (rad², stated noise): heading
    # composes additively, so the dead-reckoned heading's variance since keyframe a is a difference
    head_var_cum = np.concatenate([[0.0], np.cumsum(drive.between_cov[:, 2, 2] - ODOMETRY_FLOOR[2])])
    lam_o = opt.front_odometry_var
    calib = (0.0, 0.0)
    offd = drive.refl_offset_dist if drive.refl_offset_dist is not None else np.zeros(B)
    pool = np.zeros(0, dtype=np.int64)
    t_start, t_end = float(drive.keyframe_t[0]), float(drive.keyframe_t[-1])
    n_chunks = max(1, math.ceil((t_end - t_start) / opt.chunk_s))
    for c in range(n_chunks):
        lo, hi = t_start + c * opt.chunk_s, (t_end + 1.0 if c == n_chunks - 1 else t_start + (c + 1) * opt.chunk_s)
        k_hi = int(np.searchsorted(drive.keyframe_t, hi, side="right")) - 1
        _dead_reckon(drive, poses[0], poses, solved_to, k_hi, calib)
        idx = np.flatnonzero((drive.refl_t > lo) & (drive.refl_t <= hi))
        if idx.size:
            lcov = None
            if landmarks.shape[0]:
                done = np.flatnonzero(assoc >= 0)
                h_done = head_poses(poses, drive.refl_keyframe[done], drive.refl_offset[done], drive.mount, 1.0,
                                    offd[done], calib)
                lcov = ray_covariances(h_done, assoc[done], landmarks, opt.front_sigma, prior_cov)
            heads = head_poses(poses, drive.refl_keyframe[idx], drive.refl_offset[idx], drive.mount, 1.0, offd[idx],
                               calib)
            # gate on the bearing's own std: the encoder's, the heading dead-reckoned since the last keyframe a window
            # solution placed (up to a chunk of odometry; the stated random noise [seed002 eq17] times the factor
            # lam_o the windows estimate for it) and the offset inside the keyframe step (at least the stated noise).
            # With a keyframe at every odometry instant the offset alone covers one partial step: the differential
            # AGV's stated heading noise (8e-4 rad²/m) gives ~20 mrad over the chunk's 0.5 m, and its reflections fell
            # outside a gate of the partial step's ~3 mrad and became false reflectors (issue 17). At the stated
            # noise instead of lam_o, the lab's loose default noise widened its gate into wrong associations.
            dr_var = head_var_cum[drive.refl_keyframe[idx]] - head_var_cum[min(fixed_to, K - 1)]
            sig_idx = np.sqrt(sigma ** 2 + np.maximum(dr_var, 0.0) * lam_o
                              + drive.refl_offset_cov[idx, 2, 2] * max(lam_o, opt.gate_odometry_var))
            a = associate(drive.bearing[idx], heads, landmarks, opt.radius, sig_idx, opt.gate_sigma,
                          opt.position_tol, max_range, opt.direction, lcov if opt.use_lcov else None)
            assoc[idx] = a
            pool = np.concatenate([pool, idx[a < 0]])
        pool = pool[drive.refl_t[pool] > hi - opt.pool_s]
        added = idx.size > 0 and bool(np.any(assoc[idx] >= 0))
        if pool.size >= init.min_sightings:
            heads = head_poses(poses, drive.refl_keyframe[pool], drive.refl_offset[pool], drive.mount, 1.0,
                               offd[pool], calib)
            taken = np.zeros(pool.size, dtype=bool)
            for new in initialise_from_tracks(heads, drive.bearing[pool], drive.refl_t[pool], opt.radius, init,
                                              opt.direction):
                target = _track_target(heads[new.support], drive.bearing[pool[new.support]], new.xy, landmarks, opt)
                if target != NEW_REFLECTOR:
                    if target >= 0:
                        assoc[pool[new.support]] = target
                    taken[new.support] = True
                    continue
                assoc[pool[new.support]] = landmarks.shape[0]
                landmarks = np.vstack([landmarks, new.xy])
                ids.append(None)
                taken[new.support] = True
                added = True
            pool = pool[~taken]
        if added and landmarks.shape[0]:
            n = k_hi + 1
            k0 = min(int(np.searchsorted(drive.keyframe_t, hi - opt.window_s)), n - 1)
            heads = head_poses(poses, drive.refl_keyframe, drive.refl_offset, drive.mount, 1.0, offd, calib)
            sig = _sigma_eff(drive, sigma, heads, landmarks, assoc, lam_o)
            g, free = _window_graph(drive, k0, n, poses, landmarks, assoc, sig, heads, opt, prior_cov, lam_o, calib)
            sol = solve(g, g.pack(poses[k0:n], landmarks, 1.0, calib), max_iterations=opt.front_iterations,
                        free=free, huber=3.0)
            calib = g.calibration(sol.x)
            e, _ = linearize(g, sol.x, jacobian=False)
            n_o, n_b = 3 * (n - k0 - 1), int(g.bearings.pose.size)
            if n_b >= 100 and landmarks.shape[0] >= 3:  # variance components, as in the batch
                red = max(0.05, 1.0 - int(free.sum()) / max(n_o + n_b, 1))
                lam_o = float(np.clip(lam_o * float(e[:n_o] @ e[:n_o]) / max(n_o * red, 1.0), 1e-4, 10.0))
            p, landmarks, _ = g.unpack(sol.x)
            poses[k0:n] = p
            fixed_to = n - 1
            landmarks, assoc, ids = _merge(landmarks.copy(), assoc, ids, opt.merge_distance)
        solved_to = k_hi
    return FrontEnd(drive, poses, landmarks, assoc, ids, np.full(B, sigma), max_range, time.perf_counter() - t0,
                    calib)


#: :func:`_track_target`'s answer for a track that is no known reflector.
NEW_REFLECTOR = -2


def _track_target(heads: F64, bearings: F64, xy: F64, landmarks: F64, opt: MappingOptions) -> int:
    """What a new track (centre ``xy (2,)`` m, its reflections' head poses ``(P, 3)`` and bearings ``(P,)`` rad) is:
    the known reflector it merges into, :data:`NEW_REFLECTOR`, or -1: ambiguous, its reflections are left out.

    A track within ``merge_distance`` of a known reflector is that reflector only if its rays fit no other
    reflector better (:func:`~agvnav.mapping.initialise.ray_misfit`): rays along one line of sight through two
    reflectors triangulate anywhere along it. hall_differential seed 8: 16 reflections of P2 seen from the north
    lane, where P1 hides 0.5 m behind it, triangulated 0.16 m from P1 and were merged into P1; their along-track
    pull held the front end's trajectory 7 cm off, the batch's re-association kept them (and dropped the bearings
    of S2, S3 that contradicted: a 0.15 m trajectory error), and the batch's ``k_d`` rose 9x to absorb it.
    """
    if landmarks.shape[0] == 0:
        return NEW_REFLECTOR
    dist = np.hypot(*(landmarks - xy).T)
    if float(dist.min()) >= opt.merge_distance:
        return NEW_REFLECTOR
    j = int(np.argmin(dist))
    fit = ray_misfit(heads, bearings, opt.radius, landmarks, opt.direction)
    return j if int(np.argmin(fit)) == j else -1


def _merge(landmarks: F64, assoc: I64, ids: list[str | None], distance: float) -> tuple[F64, I64, list[str | None]]:
    """Merge reflectors closer than ``distance`` (m): the later one's sightings go to the earlier (an
    existing reflector, with an id, is never removed)."""
    n = landmarks.shape[0]
    alive = np.ones(n, dtype=bool)
    target = np.arange(n)
    for j in range(n):
        if not alive[j]:
            continue
        for k in range(j + 1, n):
            if alive[k] and ids[k] is None and float(np.hypot(*(landmarks[k] - landmarks[j]))) < distance:
                alive[k] = False
                target[k] = j
    if alive.all():
        return landmarks, assoc, ids
    renum = np.cumsum(alive) - 1
    new_assoc = np.where(assoc >= 0, renum[target[np.maximum(assoc, 0)]], -1)
    return landmarks[alive], new_assoc.astype(np.int64), [i for i, a in zip(ids, alive, strict=True) if a]


def _similarity_poses(T: F64, poses: F64) -> F64:
    a, b = T[0], T[1]
    out = poses.copy()
    out[:, :2] = apply_similarity(T, poses[:, :2])
    out[:, 2] = poses[:, 2] + math.atan2(b, a)
    return out


def _batch_drive(fe: FrontEnd, opt: MappingOptions) -> Drive:
    """The batch's drive: each reflection interpolated between its two keyframes when ``opt.interpolate``."""
    return interpolate_drive(fe.drive) if opt.interpolate else fe.drive


def _reassociate(fe: FrontEnd, poses: F64, landmarks: F64, scale: float, opt: MappingOptions,
                 keep: NDArray[np.bool_], odo_var: F64 | float = 1.0, lam_b: float = 1.0,
                 calibration: tuple[float, float] = (0.0, 0.0), lam_s: float = 1.0) -> tuple[I64, F64]:
    d = _batch_drive(fe, opt)
    heads = head_poses(poses, d.refl_keyframe, d.refl_offset, d.mount, scale, d.refl_offset_dist, calibration,
                       d.refl_alpha)
    sig0 = np.sqrt(_sigma_eff(d, fe.sigma[0], heads, landmarks, np.full(heads.shape[0], -1, dtype=np.int64),
                              odo_var) ** 2 * max(lam_b, 1.0) + max(lam_s, 1.0) * _instep_heading_var(d, odo_var, opt))
    # only the kept reflectors are candidates: a dropped one (a front-end duplicate 0.4-0.8 m off a true
    # reflector) inside the gate made the true one's reflections ambiguous, and they stayed unassociated
    kept = np.flatnonzero(keep)
    a = associate(d.bearing, heads, landmarks[kept], opt.radius, sig0, opt.gate_sigma, opt.final_position_tol,
                  fe.max_range, opt.direction)
    assoc = np.where(a >= 0, kept[np.maximum(a, 0)], -1).astype(np.int64)
    assoc[_isolated(assoc, d.refl_t, opt.init.max_gap_s)] = -1
    return assoc, heads


def _isolated(assoc: I64, times: F64, max_gap: float) -> NDArray[np.bool_]:
    """``(B,)`` True for an associated reflection with no other reflection of its reflector within ``max_gap`` (s).

    A reflector passes the head's beam once per revolution and is seen revolution after revolution (the track
    test that creates and keeps reflectors, :func:`_track_ok`); a lone reflection inside a reflector's gate is
    clutter (a spurious reflection, ``goniometer.spurious_rate_hz``) more likely than the one revolution a
    reflector showed. hall_differential seed 9: a clutter reflection in N1's gate from the west arc, the only
    one from its direction (the others see N1 from the south, where its range is weakly determined), put N1 30 mm
    off with a stated std of 9 mm; dropping the drive's lone reflections took the map RMS from 9.5 to 6.4 mm.
    """
    out = np.zeros(assoc.shape[0], dtype=bool)
    ok = np.flatnonzero(assoc >= 0)
    if ok.size == 0:
        return out
    order = ok[np.lexsort((times[ok], assoc[ok]))]
    a, t = assoc[order], times[order]
    same_prev = np.r_[False, a[1:] == a[:-1]]
    same_next = np.r_[a[1:] == a[:-1], False]
    near_prev = same_prev & (np.r_[np.inf, np.diff(t)] <= max_gap)
    near_next = same_next & (np.r_[np.diff(t), np.inf] <= max_gap)
    out[order] = ~(near_prev | near_next)
    return out


def solve_anchored(fe: FrontEnd, anchors: list[Anchor] | tuple[Anchor, ...], existing: Any = None,
                   options: MappingOptions | None = None, start: F64 | None = None) -> MappingResult:
    """Anchor the provisional map ``fe`` and solve it in batch (module docstring, steps 2-3).

    ``start``: the start pose the front end used (its frame). Raises
    :class:`~agvnav.mapping.anchors.ScaleUnobservable` without an anchor (an existing map with two or
    more reflectors counts as one).
    """
    opt = options or MappingOptions()
    t0 = time.perf_counter()
    anchors = list(anchors)
    surveyed = [a for a in anchors if isinstance(a, SurveyedAnchor)]
    baselines = [a for a in anchors if isinstance(a, BaselineAnchor)]
    starts = [a for a in anchors if isinstance(a, StartPoseAnchor)]
    n_existing = 0 if existing is None else len(existing.reflectors)
    if not surveyed and not baselines and not starts and n_existing < 2:
        raise ScaleUnobservable(UNOBSERVABLE)
    d = _batch_drive(fe, opt)
    poses, landmarks, scale = fe.poses.copy(), fe.landmarks.copy(), 1.0
    ids = list(fe.ids)
    kind = anchor_kind(anchors) if anchors else f"existing_map{n_existing}"
    if existing is not None and anchors:
        kind = f"existing_map{n_existing}+{kind}"
    # drop weak reflectors of the front end (keep the existing ones)
    keep = np.array([i is not None for i in ids] + [False] * 0, dtype=bool)
    counts = np.bincount(fe.assoc[fe.assoc >= 0], minlength=landmarks.shape[0])
    keep = keep | (counts >= opt.init.min_sightings)
    # frame: similarity onto surveyed reflectors, else the start pose (front-end frame)
    rpri_idx: list[int] = []
    rpri_mean: list[F64] = []
    rpri_cov: list[F64] = []
    if existing is not None:
        pri = _existing_priors(existing, opt)
        for j in range(n_existing):
            rpri_idx.append(j)
            rpri_mean.append(pri.mean[j])
            rpri_cov.append(np.linalg.inv(pri.W[j].T @ pri.W[j]))
    for sa in surveyed:
        cand = np.flatnonzero(keep)
        idx, T = match_surveyed(landmarks[cand], sa.xy)
        if existing is None and not rpri_idx:
            poses = _similarity_poses(T, poses)
            landmarks = apply_similarity(T, landmarks)
            scale = float(math.hypot(T[0], T[1]))
        for s_row, m_row in enumerate(idx.tolist()):
            if m_row < 0:
                continue
            j = int(cand[m_row])
            ids[j] = sa.ids[s_row]
            rpri_idx.append(j)
            rpri_mean.append(sa.xy[s_row])
            rpri_cov.append(np.eye(2) * sa.std[s_row] ** 2)
    pose_prior = PosePriors(np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3, 3)))
    scale_prior: tuple[float, float] | None = None
    if starts:
        sp_anchor = starts[0]
        pose0 = np.asarray(sp_anchor.pose if sp_anchor.pose is not None else
                           (start if start is not None else poses[0]), dtype=np.float64)
        var0 = np.square(sp_anchor.pose_std) + np.array([0.0, 0.0, opt.head_yaw_std ** 2])
        pose_prior = PosePriors(np.array([0]), pose0[None].copy(), whitener(np.diag(var0)[None]))
        scale_prior = (sp_anchor.scale, sp_anchor.scale_std)
    elif not surveyed and existing is None:
        # baseline only: the frame is the start pose (a gauge choice, tight prior)
        pose0 = np.asarray(start if start is not None else poses[0], dtype=np.float64)
        var0 = np.array([1e-8, 1e-8, opt.head_yaw_std ** 2])
        pose_prior = PosePriors(np.array([0]), pose0[None].copy(), whitener(np.diag(var0)[None]))
    dist_a: list[int] = []
    dist_b: list[int] = []
    dist_d: list[float] = []
    dist_s: list[float] = []
    for ba in baselines:
        cand = np.flatnonzero(keep)
        pair = []
        for p in (ba.first, ba.second):
            dd = np.hypot(*(landmarks[cand] - np.asarray(p)).T)
            if dd.size == 0 or float(dd.min()) > ba.match_radius:
                raise ValueError(f"baseline anchor: no mapped reflector within {ba.match_radius} m of {list(p)}")
            pair.append(int(cand[int(np.argmin(dd))]))
        if pair[0] == pair[1]:
            raise ValueError("baseline anchor: both ends match the same mapped reflector")
        dist_a.append(pair[0])
        dist_b.append(pair[1])
        dist_d.append(ba.distance)
        dist_s.append(ba.std)
    rpri = ReflectorPriors(np.array(rpri_idx, dtype=np.int64), np.array(rpri_mean).reshape(-1, 2),
                           whitener(np.array(rpri_cov).reshape(-1, 2, 2)) if rpri_cov else np.zeros((0, 2, 2)))
    dist = DistanceFactors(np.array(dist_a, dtype=np.int64), np.array(dist_b, dtype=np.int64), np.array(dist_d),
                           np.array(dist_s))
    anchored = set(rpri_idx) | set(dist_a) | set(dist_b)
    K = poses.shape[0]
    odo_var, lam_b, lam_s = np.ones(3), 1.0, 1.0
    calib = fe.calibration
    is_anchored = np.isin(np.arange(keep.size), list(anchored))
    reassociate = True
    for pas in range(opt.variance_passes):
        if pas < 2 or reassociate:
            assoc, heads = _reassociate(fe, poses, landmarks, scale, opt, keep | is_anchored, odo_var, lam_b, calib,
                                        lam_s)
            if pas >= 1 and opt.batch_initialise:
                landmarks, keep, assoc, ids = _initialise_leftovers(d, heads, landmarks, keep, assoc, ids, opt,
                                                                    fe.max_range)
                is_anchored = np.isin(np.arange(keep.size), list(anchored))
        # variance components [Förstner]: bearing std and Crowley's coefficients against their redundancy,
        # iterated to their fixed point before any outlier is judged: one step per pass left the bearing std
        # 3-10x too small after five passes (the first step is clipped at 1/100), and a 5-sigma cut with that
        # std censored the bearings (40 % dropped on the lab drive), which shrank it further: reflector
        # covariances 5-40x optimistic in the joint NEES
        for _ in range(opt.variance_iterations):
            sig_ind = _sigma_eff(d, fe.sigma[0], heads, landmarks, assoc, odo_var)
            use = _used(d, assoc, K)
            noise = _step_noise(d, use, heads, landmarks, assoc, poses, sig_ind, odo_var, opt) \
                if opt.in_step_slip else None
            wb = None if noise is None else noise.whitener(lam_b, lam_s, int(use.sum()))[0]
            g = _graph(d, K, landmarks, assoc, sig_ind * math.sqrt(lam_b), opt, pose_prior, rpri, dist, scale_prior,
                       odo_var, calibration=True, bearing_whitener=wb)
            sol = solve(g, g.pack(poses, landmarks, scale, calib), max_iterations=50)
            poses, landmarks, scale = g.unpack(sol.x)
            poses, landmarks = poses.copy(), landmarks.copy()
            calib = g.calibration(sol.x)
            new_odo, new_lam, new_s = _variance_components(g, sol.x, d, odo_var, lam_b, opt.variance_probes, noise,
                                                           lam_s)
            # settled when the bearings' and the odometry's total variances are (a component the drive cannot
            # tell from zero keeps shrinking without changing them)
            bearing_change = new_lam / lam_b if noise is None else \
                noise.total(new_lam, new_s) / noise.total(lam_b, lam_s)
            change = float(np.max(np.abs(np.log(np.r_[bearing_change,
                                                      _odometry_total(d, new_odo) / _odometry_total(d, odo_var)]))))
            odo_var, lam_b, lam_s = new_odo, new_lam, new_s
            if change < opt.variance_tolerance:
                break
        # outliers
        e_use = (assoc >= 0)
        heads = head_poses(poses, d.refl_keyframe, d.refl_offset, d.mount, scale, d.refl_offset_dist, calib,
                           d.refl_alpha)
        sig = np.sqrt(_sigma_eff(d, fe.sigma[0], heads, landmarks, assoc, odo_var) ** 2 * lam_b
                      + lam_s * _instep_heading_var(d, odo_var, opt))
        if np.any(e_use):
            pred, _ = predicted_edge_bearings(heads[e_use], landmarks, opt.radius, opt.direction)
            r = wrap_angle(d.bearing[e_use] - pred[np.arange(pred.shape[0]), assoc[e_use]]) / sig[e_use]
            bad = np.flatnonzero(e_use)[np.abs(r) > opt.outlier_sigma]
            assoc[bad] = -1
        counts = np.bincount(assoc[assoc >= 0], minlength=landmarks.shape[0])
        track_ok = np.array([_track_ok(heads[assoc == j, :2], d.refl_t[assoc == j], opt.init)
                             for j in range(landmarks.shape[0])])
        protected = np.array([i is not None and j < n_existing for j, i in enumerate(ids)], dtype=bool) | \
            np.isin(np.arange(landmarks.shape[0]), list(anchored))
        new_keep = protected | ((counts >= opt.init.min_sightings) & track_ok)
        new_keep &= ~_duplicates(landmarks, counts, new_keep, protected, opt.merge_distance)
        reassociate = bool(np.any(new_keep != keep)) and pas < opt.variance_passes - 2
        keep = new_keep
    assoc = np.where((assoc >= 0) & keep[np.maximum(assoc, 0)], assoc, -1)
    sig_ind = _sigma_eff(d, fe.sigma[0], heads, landmarks, assoc, odo_var)
    # drop unkept reflectors from the state: renumber
    old = np.flatnonzero(keep)
    new_of_old = np.full(landmarks.shape[0], -1, dtype=np.int64)
    new_of_old[old] = np.arange(old.size)
    assoc = np.where(assoc >= 0, new_of_old[np.maximum(assoc, 0)], -1)
    rpri = ReflectorPriors(new_of_old[rpri.index], rpri.mean, rpri.W)
    dist = DistanceFactors(new_of_old[dist.a], new_of_old[dist.b], dist.d, dist.sigma)
    landmarks = landmarks[old]
    ids = [ids[j] for j in old.tolist()]
    use = _used(d, assoc, K)
    noise = _step_noise(d, use, heads, landmarks, assoc, poses, sig_ind, odo_var, opt) if opt.in_step_slip else None
    wb = None if noise is None else noise.whitener(lam_b, lam_s, int(use.sum()))[0]
    sig = sig_ind * math.sqrt(lam_b)
    g = _graph(d, K, landmarks, assoc, sig, opt, pose_prior, rpri, dist, scale_prior, odo_var, calibration=True,
               bearing_whitener=wb)
    sol = solve(g, g.pack(poses, landmarks, scale, calib), max_iterations=50)
    if noise is not None:
        sig = np.sqrt(sig ** 2 + lam_s * _instep_heading_var(d, odo_var, opt))
    poses, landmarks, scale = g.unpack(sol.x)
    calib = g.calibration(sol.x)
    joint, scale_var = reflector_covariance(g, sol.x)
    cov = np.array([joint[2 * j:2 * j + 2, 2 * j:2 * j + 2] for j in range(landmarks.shape[0])]).reshape(-1, 2, 2)
    n_res = 3 * (K - 1) + int(np.sum(assoc >= 0))
    dof = max(1, n_res - (g.n_vars - 0))
    k = 0
    final_ids: list[str] = []
    for i in ids:
        if i is None:
            k += 1
            name = f"M{k}"
            while name in ids:
                k += 1
                name = f"M{k}"
            final_ids.append(name)
        else:
            final_ids.append(i)
    existing_ids = tuple(existing.reflector_ids) if existing is not None else ()
    return MappingResult(
        tuple(final_ids), landmarks.copy(), cov, np.bincount(assoc[assoc >= 0], minlength=landmarks.shape[0]),
        poses.copy(), d.keyframe_t.copy(), scale, math.sqrt(max(scale_var, 0.0)), kind, int(d.bearing.shape[0]),
        int(np.sum(assoc >= 0)), 2.0 * sol.cost / dof, fe.runtime_s + time.perf_counter() - t0, existing_ids,
        calib[0], calib[1],
        tuple(float(v) for v in odo_var * (d.odometry_k if d.odometry_k is not None else np.ones(3))),  # type: ignore[arg-type]
        float(np.median(sig[assoc >= 0])) if np.any(assoc >= 0) else None, joint,
    )


def _initialise_leftovers(d: Drive, heads: F64, landmarks: F64, keep: NDArray[np.bool_], assoc: I64,
                          ids: list[str | None], opt: MappingOptions,
                          max_range: float) -> tuple[F64, NDArray[np.bool_], I64, list[str | None]]:
    """New reflectors from the reflections no reflector claims once the map is solved (batch passes from the second).

    The front end initialises from dead-reckoned poses and a pool of recent reflections; a reflector seen
    briefly beside others can lose its sightings to them there and is never initialised (warehouse,
    seed 0: rack_3_n6, 42 sightings taken by rack_3_s5 and s6, 13 cm off in the front end). The same
    track test runs on the leftovers against the solved trajectory (:func:`initialise_from_tracks`:
    spurious reflections form no track); a new reflector within ``merge_distance`` of a kept one is not added.
    """
    free = np.flatnonzero(assoc < 0)
    init = InitialiseOptions(**{**opt.init.__dict__, "max_range": max_range})
    if free.size < init.min_sightings:
        return landmarks, keep, assoc, ids
    kept = landmarks[keep]
    for new in initialise_from_tracks(heads[free], d.bearing[free], d.refl_t[free], opt.radius, init, opt.direction):
        if kept.shape[0] and float(np.min(np.hypot(*(kept - new.xy).T))) < opt.merge_distance:
            continue
        assoc[free[new.support]] = landmarks.shape[0]
        landmarks = np.vstack([landmarks, new.xy])
        keep = np.append(keep, True)
        ids = [*ids, None]
        kept = np.vstack([kept, new.xy])
    return landmarks, keep, assoc, ids


def _track_ok(points: F64, times: F64, init: InitialiseOptions) -> bool:
    """A reflector is kept when one continuous track of its sightings (no gap over ``max_gap_s``) has
    ``min_sightings`` from head positions spanning ``min_baseline``: a real reflector is seen revolution
    after revolution; sightings gathered by chance (clutter, reflections of another reflector while the
    front end's poses were off) are scattered in time and made a false reflector on the differential AGV."""
    if points.shape[0] < init.min_sightings:
        return False
    order = np.argsort(times, kind="stable")
    cuts = np.flatnonzero(np.diff(times[order]) > init.max_gap_s) + 1
    for part in np.split(points[order], cuts):
        if part.shape[0] >= init.min_sightings and _spread_ok(part, init.min_baseline):
            return True
    return False


def _duplicates(landmarks: F64, counts: I64, keep: NDArray[np.bool_], protected: NDArray[np.bool_],
                distance: float) -> NDArray[np.bool_]:
    """Kept reflectors closer than ``distance`` (m) to a kept one with more sightings (or a protected one):
    one reflector initialised twice; dropping the weaker lets the next association give its sightings back."""
    out = np.zeros(landmarks.shape[0], dtype=bool)
    idx = np.flatnonzero(keep)
    for a in idx:
        if protected[a]:
            continue
        for b in idx:
            if b == a or out[b]:
                continue
            if float(np.hypot(*(landmarks[a] - landmarks[b]))) < distance and \
                    (protected[b] or counts[b] > counts[a] or (counts[b] == counts[a] and b < a)):
                out[a] = True
                break
    return out


def _spread_ok(points: F64, min_baseline: float) -> bool:
    if points.shape[0] < 2:
        return False
    lo, hi = points.min(axis=0), points.max(axis=0)
    return bool(np.hypot(*(hi - lo)) >= min_baseline)


def build_map(log: Any, anchors: list[Anchor] | tuple[Anchor, ...], options: MappingOptions | None = None,
              existing: Any = None, start: Any = None) -> MappingResult:
    """Map the reflectors of ``log`` (a :class:`agvnav.logs.RecordedLog`) with ``anchors`` (module docstring).

    ``start`` (m, m, rad): the start pose; default a start-pose anchor's, else the log's ``initial_pose``
    setting when the map must be in a known frame (an existing map, a baseline), else the origin.
    Raises :class:`~agvnav.mapping.anchors.ScaleUnobservable` before any work when nothing anchors the map.
    """
    anchors = list(anchors)
    if not anchors and (existing is None or len(existing.reflectors) < 2):
        raise ScaleUnobservable(UNOBSERVABLE)
    if start is None:
        sp = [a for a in anchors if isinstance(a, StartPoseAnchor) and a.pose is not None]
        settings = getattr(log, "settings", {}) or {}
        if sp:
            start = sp[0].pose
        elif settings.get("initial_pose") is not None:
            start = settings["initial_pose"]
        elif existing is not None:
            raise ValueError("adding to an existing map needs the start pose in its frame (start_pose:X,Y,HEADING_DEG)")
    start_arr = None if start is None else np.asarray(start, dtype=np.float64)
    if start_arr is not None and start_arr.shape != (3,):
        raise ValueError(f"start pose must be [x, y, heading], got shape {start_arr.shape}")
    fe = front_end(log, start_arr, options, existing)
    return solve_anchored(fe, anchors, existing, options, start_arr)
