"""The mapping factor graph: whitened residuals and their sparse Jacobian.

Variables (one state vector): keyframe poses ``X(k) = [x, y, ψ]`` (m, m, rad), reflector
centres ``L(j) = [x, y]`` (m) and the odometry's systematic errors: the scale factor ``s``
(dimensionless, every ``ΔD`` is multiplied by it), a heading rate ``κ`` (rad per metre rolled:
a steering offset, unequal wheel diameters) and a turn scale ``b`` (the measured turn is
``(1 + b)`` times short: a wheelbase or track error) — the three systematic errors of
odometry calibration (UMBmark's ``E_d``, ``E_b`` and the scale; [seed002 §3]). The odometry's
random noise is white; its systematic part is not, and treated as white noise it made the
reflector covariances optimistic (a heading drift of 3 mrad/m in the shipped tricycles).
Factors, named after what they measure (as GTSAM's ``BetweenFactorPose2`` / ``BearingFactor2D``):

- :class:`OdometryFactors` (between): ``e = [R(ψ_i)ᵀ (p_j − p_i) − s t_ij,
  wrap(ψ_j − ψ_i − (1 + b) θ_ij − κ D_ij)]`` (``D_ij`` the signed distance rolled), whitened by the
  odometry covariance of the relative pose ([seed002 eq17], propagated); the translation
  ignores the second-order effect of ``κ``, ``b`` inside one keyframe step (< 10 µm);
- :class:`BearingFactors`: the goniometer's leading-edge bearing of a cylinder of radius ``r``
  seen from the head (``X(k) ∘ u(s, κ, b) ∘ mount``; the offset's heading is
  ``(1 + b) u_ψ + κ u_D``), ``β = atan2(δ_y, δ_x) − ψ_head − dir·asin(r/d)``
  ([seed000 §2.1]; :func:`agvnav.sensors.goniometer.leading_edge_bearing`), ``e = wrap(β − z)/σ``;
- priors on poses, reflectors and the scale, and distance factors between two reflectors
  (a taped baseline): the anchors of :mod:`agvnav.mapping.anchors`.

Every residual is already whitened, so the least-squares cost is ``½ Σ e²`` and the
Gauss-Newton information matrix is ``JᵀJ``. Jacobians are analytic and tested against
numerical ones (tests/mapping/test_graph.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from agvnav.geometry import wrap_angle

__all__ = [
    "BearingFactors",
    "DistanceFactors",
    "FactorGraph",
    "OdometryFactors",
    "PosePriors",
    "ReflectorPriors",
    "bearing_prediction",
    "linearize",
    "whitener",
]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

#: State entries after the reflectors: the odometry scale, heading rate per metre and turn scale.
N_CALIBRATION = 3


def whitener(cov: F64) -> F64:
    """``W (..., n, n)`` with ``WᵀW = cov⁻¹`` (the inverse of the lower Cholesky factor), for whitening residuals."""
    chol = np.linalg.cholesky(np.asarray(cov, dtype=np.float64))
    eye = np.broadcast_to(np.eye(chol.shape[-1]), chol.shape)
    return np.asarray(np.linalg.solve(chol, eye))


@dataclass(frozen=True)
class OdometryFactors:
    """Between-factors ``X(i) → X(j)``: measured relative pose ``z (E, 3)`` at scale 1, whitener ``W (E, 3, 3)``,
    signed distance rolled ``dist (E,)`` (m; None: zero)."""

    i: I64
    j: I64
    z: F64
    W: F64
    dist: F64 | None = None


@dataclass(frozen=True)
class BearingFactors:
    """Bearings ``z (B,)`` (rad, head frame) from keyframe ``pose (B,)`` to reflector ``landmark (B,)``.

    ``offset (B, 3)``: base_link at the stamp relative to the keyframe (translation at scale 1);
    ``offset_dist (B,)``: the signed distance rolled over that offset (m; None: zero);
    ``sigma (B,)`` the bearing std (rad); ``mount (3,)`` the head on base_link; ``radius`` (m) and
    ``direction`` (+1 CCW head) of the leading-edge model.
    ``alpha (B,)``: interpolated between keyframes ``pose`` and ``pose + 1`` (None: hung on ``pose`` alone).
    The reflection's instant lies ``alpha`` of the way through the interval; ``offset`` and ``offset_dist``
    are then the odometry offset minus ``alpha`` times the interval's odometry (``v = u − α z``), and the
    base_link pose is ``p_k + α (p_{k+1} − p_k) + R(ψ_k) s v_t`` with heading
    ``ψ_k + α wrap(ψ_{k+1} − ψ_k) + (1 + b) v_ψ + κ v_D``: the odometry's error over the interval, which
    both keyframe poses know, is shared out in proportion, so the bearings no longer carry it as noise
    (it is common to every bearing of the interval, and as independent noise it made them over-weighted).
    ``whitener (B, B)``: correlated bearing noise, ``WᵀW = Σ⁻¹`` (block diagonal: the bearings of one odometry
    step share its in-step slip); the residuals are then ``W wrap(β − z)`` and ``sigma`` is not used.
    """

    pose: I64
    landmark: I64
    offset: F64
    z: F64
    sigma: F64
    mount: F64
    radius: float = 0.0
    direction: int = 1
    offset_dist: F64 | None = None
    alpha: F64 | None = None
    whitener: sp.csr_matrix | None = None


@dataclass(frozen=True)
class PosePriors:
    """Priors on keyframe poses: ``index (P,)``, ``mean (P, 3)``, whitener ``W (P, 3, 3)``."""

    index: I64
    mean: F64
    W: F64


@dataclass(frozen=True)
class ReflectorPriors:
    """Priors on reflector centres (surveyed reflectors, an existing map): ``index``, ``mean (P, 2)``,
    whitener ``W (P, 2, 2)``."""

    index: I64
    mean: F64
    W: F64


@dataclass(frozen=True)
class DistanceFactors:
    """Measured distances ``d (D,)`` (m, std ``sigma``) between reflectors ``a`` and ``b``: a taped baseline."""

    a: I64
    b: I64
    d: F64
    sigma: F64


def _empty_i() -> I64:
    return np.zeros(0, dtype=np.int64)


@dataclass(frozen=True)
class FactorGraph:
    """All factors over ``n_poses`` keyframes and ``n_landmarks`` reflectors (+ the scale).

    ``scale_prior``: ``(mean, sigma)`` of the odometry scale, or None (free: the map then needs another
    scale reference). ``calibration_prior``: ``(σ_κ, σ_b)`` of priors on the heading rate (rad/m) and
    the turn scale (a drive that never turns cannot tell ``b``), centred on ``calibration_mean``. State layout:
    ``[X(0..K-1) (3K), L(0..N-1) (2N), s, κ, b]``.
    """

    n_poses: int
    n_landmarks: int
    odometry: OdometryFactors
    bearings: BearingFactors
    pose_priors: PosePriors = field(
        default_factory=lambda: PosePriors(_empty_i(), np.zeros((0, 3)), np.zeros((0, 3, 3))))
    reflector_priors: ReflectorPriors = field(
        default_factory=lambda: ReflectorPriors(_empty_i(), np.zeros((0, 2)), np.zeros((0, 2, 2))))
    distances: DistanceFactors = field(
        default_factory=lambda: DistanceFactors(_empty_i(), _empty_i(), np.zeros(0), np.zeros(0)))
    scale_prior: tuple[float, float] | None = None
    calibration_prior: tuple[float, float] = (1e-6, 1e-6)
    calibration_mean: tuple[float, float] = (0.0, 0.0)

    @property
    def n_vars(self) -> int:
        """Length of the state vector."""
        return 3 * self.n_poses + 2 * self.n_landmarks + N_CALIBRATION

    def landmark_slice(self) -> slice:
        """Slice of the reflector centres in the state vector."""
        return slice(3 * self.n_poses, 3 * self.n_poses + 2 * self.n_landmarks)

    def pack(self, poses: F64, landmarks: F64, scale: float, calibration: tuple[float, float] = (0.0, 0.0)) -> F64:
        """State vector from poses ``(K, 3)``, landmarks ``(N, 2)``, the scale and ``(κ, b)``."""
        return np.concatenate([np.asarray(poses, dtype=np.float64).ravel(),
                               np.asarray(landmarks, dtype=np.float64).ravel(), [float(scale)],
                               np.asarray(calibration, dtype=np.float64)])

    def unpack(self, x: F64) -> tuple[F64, F64, float]:
        """``(poses (K, 3), landmarks (N, 2), scale)`` views of the state vector."""
        k3 = 3 * self.n_poses
        return x[:k3].reshape(-1, 3), x[k3:-N_CALIBRATION].reshape(-1, 2), float(x[-N_CALIBRATION])

    def calibration(self, x: F64) -> tuple[float, float]:
        """``(κ, b)``: the odometry's heading rate (rad/m) and turn scale in the state vector ``x``."""
        return float(x[-2]), float(x[-1])

    @property
    def scale_index(self) -> int:
        """Index of the scale ``s`` in the state vector (``κ``, ``b`` follow)."""
        return self.n_vars - N_CALIBRATION


def bearing_prediction(poses: F64, landmarks: F64, scale: float, f: BearingFactors,
                       jacobians: bool = False, calibration: tuple[float, float] = (0.0, 0.0),
                       ) -> tuple[F64, F64 | None, F64 | None, F64 | None]:
    """Predicted leading-edge bearings ``(B,)`` and, with ``jacobians``, ``∂β/∂X (B, 3)`` (``(B, 6)`` for
    ``X(k), X(k+1)`` when ``f.alpha`` interpolates), ``∂β/∂L (B, 2)``, ``∂β/∂(s, κ, b) (B, 3)``.

    Offset heading ``w_ψ = (1 + b) u_ψ + κ u_D``; head position ``h = p + R(ψ)(s u_t + R(w_ψ) m_t)``,
    heading ``ψ + w_ψ + m_ψ``; ``δ = L − h``, ``d = |δ|``; ``β = atan2(δ) − ψ_head − dir·asin(r/d)``
    [seed000 §2.1].
    """
    X = poses[f.pose]
    L = landmarks[f.landmark]
    u, m = f.offset, f.mount
    kappa, b = calibration
    u_dist = np.zeros(u.shape[0]) if f.offset_dist is None else f.offset_dist
    w = (1.0 + b) * u[:, 2] + kappa * u_dist
    px, py = X[:, 0], X[:, 1]
    if f.alpha is not None:
        Xn = poses[f.pose + 1]
        w = w + f.alpha * wrap_angle(Xn[:, 2] - X[:, 2])
        px = px + f.alpha * (Xn[:, 0] - X[:, 0])
        py = py + f.alpha * (Xn[:, 1] - X[:, 1])
    cu, su = np.cos(w), np.sin(w)
    wx = scale * u[:, 0] + cu * m[0] - su * m[1]
    wy = scale * u[:, 1] + su * m[0] + cu * m[1]
    c, s = np.cos(X[:, 2]), np.sin(X[:, 2])
    rx, ry = c * wx - s * wy, s * wx + c * wy
    dx, dy = L[:, 0] - px - rx, L[:, 1] - py - ry
    d2 = dx * dx + dy * dy
    d = np.sqrt(d2)
    ratio = np.clip(f.radius / np.maximum(d, 1e-12), 0.0, 0.999999)
    beta = np.arctan2(dy, dx) - (X[:, 2] + w + m[2]) - f.direction * np.arcsin(ratio)
    if not jacobians:
        return beta, None, None, None
    k = f.direction * f.radius / (d2 * d * np.sqrt(1.0 - ratio * ratio))
    gx = -dy / d2 + k * dx
    gy = dx / d2 + k * dy
    jl = np.column_stack([gx, gy])
    jx = np.column_stack([-gx, -gy, -(gx * -ry + gy * rx) - 1.0])
    tx = c * u[:, 0] - s * u[:, 1]
    ty = s * u[:, 0] + c * u[:, 1]
    js = -(gx * tx + gy * ty)
    # ∂β/∂w: the heading term and the mount arm turning with it
    ax, ay = -su * m[0] - cu * m[1], cu * m[0] - su * m[1]
    jw = -(gx * (c * ax - s * ay) + gy * (s * ax + c * ay)) - 1.0
    jc = np.column_stack([js, jw * u_dist, jw * u[:, 2]])
    if f.alpha is not None:  # (B, 6): X(k) then X(k+1)
        a = f.alpha
        jx = np.column_stack([-(1.0 - a) * gx, -(1.0 - a) * gy, jx[:, 2] - a * jw, -a * gx, -a * gy, a * jw])
    return beta, jx, jl, jc


class _Builder:
    """COO triplets and residual blocks, concatenated once."""

    def __init__(self) -> None:
        self.rows: list[I64] = []
        self.cols: list[I64] = []
        self.vals: list[F64] = []
        self.res: list[F64] = []
        self.n = 0

    def block(self, r: F64) -> int:
        start = self.n
        self.res.append(r)
        self.n += r.shape[0]
        return start

    def add(self, rows: I64, cols: I64, vals: F64) -> None:
        self.rows.append(rows.ravel())
        self.cols.append(cols.ravel())
        self.vals.append(vals.ravel())


def linearize(graph: FactorGraph, x: F64, jacobian: bool = True) -> tuple[F64, sp.csr_matrix | None]:
    """Whitened residuals ``e (m,)`` and, with ``jacobian``, their sparse Jacobian ``(m, n_vars)`` at ``x``."""
    poses, landmarks, scale = graph.unpack(x)
    kappa, tscale = graph.calibration(x)
    b = _Builder()
    k3 = 3 * graph.n_poses
    svar = graph.scale_index
    cal_cols = svar + np.arange(N_CALIBRATION)
    # odometry between-factors
    o = graph.odometry
    if o.i.size:
        Xi, Xj = poses[o.i], poses[o.j]
        c, s = np.cos(Xi[:, 2]), np.sin(Xi[:, 2])
        dpx, dpy = Xj[:, 0] - Xi[:, 0], Xj[:, 1] - Xi[:, 1]
        dist = np.zeros(o.i.size) if o.dist is None else o.dist
        e = np.column_stack([c * dpx + s * dpy - scale * o.z[:, 0], -s * dpx + c * dpy - scale * o.z[:, 1],
                             wrap_angle(Xj[:, 2] - Xi[:, 2] - (1.0 + tscale) * o.z[:, 2] - kappa * dist)])
        ew = np.einsum("eab,eb->ea", o.W, e)
        start = b.block(ew.ravel())
        if jacobian:
            E = o.i.size
            J = np.zeros((E, 3, 9))  # columns: Xi (3), Xj (3), s, κ, b
            J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1] = -c, -s, s, -c
            J[:, 0, 2] = -s * dpx + c * dpy
            J[:, 1, 2] = -c * dpx - s * dpy
            J[:, 2, 2] = -1.0
            J[:, 0, 3], J[:, 0, 4], J[:, 1, 3], J[:, 1, 4] = c, s, -s, c
            J[:, 2, 5] = 1.0
            J[:, 0, 6], J[:, 1, 6] = -o.z[:, 0], -o.z[:, 1]
            J[:, 2, 7], J[:, 2, 8] = -dist, -o.z[:, 2]
            Jw = np.einsum("eab,ebc->eac", o.W, J)
            rows = start + np.arange(3 * E).reshape(E, 3, 1) + np.zeros((1, 1, 9), dtype=np.int64)
            cols = np.concatenate([3 * o.i[:, None] + np.arange(3), 3 * o.j[:, None] + np.arange(3),
                                   np.broadcast_to(cal_cols, (E, N_CALIBRATION))], axis=1)
            b.add(rows, np.broadcast_to(cols[:, None, :], (E, 3, 9)), Jw)
    # bearings
    f = graph.bearings
    if f.pose.size:
        beta, jx, jl, jc = bearing_prediction(poses, landmarks, scale, f, jacobian, (kappa, tscale))
        r = wrap_angle(beta - f.z)
        start = b.block(r / f.sigma if f.whitener is None else f.whitener @ r)
        if jacobian:
            assert jx is not None and jl is not None and jc is not None
            B = f.pose.size
            n_pose = jx.shape[1]
            vals = np.concatenate([jx, jl, jc], axis=1)
            rows = np.repeat(np.arange(B)[:, None], n_pose + 2 + N_CALIBRATION, axis=1)
            cols = np.concatenate([3 * f.pose[:, None] + np.arange(n_pose), k3 + 2 * f.landmark[:, None] + np.arange(2),
                                   np.broadcast_to(cal_cols, (B, N_CALIBRATION))], axis=1)
            if f.whitener is None:
                b.add(start + rows, cols, vals / f.sigma[:, None])
            else:
                Jw = (f.whitener @ sp.csr_matrix((vals.ravel(), (rows.ravel(), cols.ravel())),
                                                 shape=(B, graph.n_vars))).tocoo()
                b.add(start + Jw.row.astype(np.int64), Jw.col.astype(np.int64), Jw.data)
    # pose priors
    pp = graph.pose_priors
    if pp.index.size:
        X = poses[pp.index]
        e = X - pp.mean
        e[:, 2] = wrap_angle(e[:, 2])
        start = b.block(np.einsum("pab,pb->pa", pp.W, e).ravel())
        if jacobian:
            P = pp.index.size
            rows = start + np.arange(3 * P).reshape(P, 3, 1) + np.zeros((1, 1, 3), dtype=np.int64)
            cols = np.broadcast_to((3 * pp.index[:, None] + np.arange(3))[:, None, :], (P, 3, 3))
            b.add(rows, cols, pp.W)
    # reflector priors
    rp = graph.reflector_priors
    if rp.index.size:
        e = landmarks[rp.index] - rp.mean
        start = b.block(np.einsum("pab,pb->pa", rp.W, e).ravel())
        if jacobian:
            P = rp.index.size
            rows = start + np.arange(2 * P).reshape(P, 2, 1) + np.zeros((1, 1, 2), dtype=np.int64)
            cols = np.broadcast_to((k3 + 2 * rp.index[:, None] + np.arange(2))[:, None, :], (P, 2, 2))
            b.add(rows, cols, rp.W)
    # distances (taped baselines)
    df = graph.distances
    if df.a.size:
        delta = landmarks[df.a] - landmarks[df.b]
        dist = np.hypot(delta[:, 0], delta[:, 1])
        start = b.block((dist - df.d) / df.sigma)
        if jacobian:
            D = df.a.size
            unit = delta / dist[:, None] / df.sigma[:, None]
            rows = start + np.repeat(np.arange(D)[:, None], 4, axis=1)
            cols = np.concatenate([k3 + 2 * df.a[:, None] + np.arange(2), k3 + 2 * df.b[:, None] + np.arange(2)],
                                  axis=1)
            b.add(rows, cols, np.concatenate([unit, -unit], axis=1))
    # scale prior
    if graph.scale_prior is not None:
        mean, sigma = graph.scale_prior
        start = b.block(np.array([(scale - mean) / sigma]))
        if jacobian:
            b.add(np.array([start]), np.array([svar]), np.array([1.0 / sigma]))
    # priors on the heading rate and the turn scale
    sk, sb = graph.calibration_prior
    mk, mb = graph.calibration_mean
    start = b.block(np.array([(kappa - mk) / sk, (tscale - mb) / sb]))
    if jacobian:
        b.add(start + np.arange(2), cal_cols[1:], np.array([1.0 / sk, 1.0 / sb]))
    res = np.concatenate(b.res) if b.res else np.zeros(0)
    if not jacobian:
        return res, None
    jac = sp.csr_matrix((np.concatenate(b.vals), (np.concatenate(b.rows), np.concatenate(b.cols))),
                        shape=(res.shape[0], graph.n_vars))
    return res, jac
