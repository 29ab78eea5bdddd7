"""Odometry noise model [seed002 eq17] (after Crowley 1992), made positive semi-definite.

Seed 002 prints ``Q11 = K_D ΔD cos θ``, ``Q22 = K_D ΔD sin θ`` — which is
negative for half the headings, so it cannot be a covariance. The intended
model is noise on the increments, ``var(ΔD) = K_D |ΔD|`` and
``var(Δθ) = K_Dθ |ΔD| + K_θ |Δθ|``, mapped to the pose through the full Jacobian ``G = ∂pose'/∂(ΔD, Δθ)`` of the
integration rule's pose update (:func:`~agvnav.odometry.integrate.increment_jacobian`):
``Q = G · diag(...) · Gᵀ``.

The earlier ``J = [[cos θ_m, 0], [sin θ_m, 0], [0, 1]]`` (midpoint heading
``θ_m = θ + Δθ/2``) dropped the displacement a heading error makes *within* the step
(``∂x'/∂Δθ = −ΔD/2 · sin θ_m`` for the midpoint and arc rules): over 4 steps of
0.625 m and 0.25 rad along an arc its lateral variance was about 26 % below a Monte
Carlo of the same noise model (issue 12; ``tests/odometry/test_covariance_montecarlo.py``).

For a steered vehicle the three coefficients can only bound the errors of its two
readings (drive-wheel distance and steering angle): :class:`SteeredOdometryNoise` maps
them exactly (rank-one terms along the directions each reading moves the increment) and
names the systematic ones (radius scale, steering offset) for the EKF's consider filter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.odometry.integrate import increment_jacobian, integrate_pose, pose_jacobian
from agvnav.odometry.noise_kernels import increment_variances_array

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class OdometryNoise:
    """Crowley's odometry error coefficients (seed 002 §3.2, typical values as defaults).

    k_d : translation variance per metre travelled (m²/m).
    k_dtheta : heading variance per metre travelled (rad²/m).
    k_theta : heading variance per radian turned (rad²/rad).
    """

    k_d: float = 0.001
    k_dtheta: float = 0.003
    k_theta: float = 0.001

    def __post_init__(self) -> None:
        for name in ("k_d", "k_dtheta", "k_theta"):
            k = getattr(self, name)
            if not np.isfinite(k) or k < 0.0:
                raise ValueError(f"{name} must be a non-negative finite number, got {k!r}")

    def increment_covariance(self, delta_d: ArrayLike, delta_theta: ArrayLike) -> FloatArray:
        """``diag(K_D|ΔD|, K_Dθ|ΔD| + K_θ|Δθ|)`` ``(..., 2, 2)`` of the increments ``(ΔD, Δθ)``.

        The variances are :func:`agvnav.odometry.noise_kernels.increment_variances` [seed002 eq17] on arrays.
        """
        var_d, var_th = increment_variances_array(delta_d, delta_theta, self.k_d, self.k_dtheta, self.k_theta)
        cov = np.zeros(var_d.shape + (2, 2))
        cov[..., 0, 0] = var_d
        cov[..., 1, 1] = var_th
        return cov


#: Vehicle models :func:`noise_from_truth` derives coefficients for.
TRUTH_MODELS = ("tricycle", "tricycle_rear", "differential")


def noise_from_truth(model: str, slip_k: float, base_m: float, steering_std: float = 0.0,
                     step_m: float = 0.0) -> OdometryNoise:
    """Crowley's coefficients [seed002 eq17] of a vehicle's random odometry errors, mapped through its kinematics.

    In a simulation the truth's random errors are known: a filter whose ``Q`` is those
    errors carried through the same increment rule is consistent by design (issue 12:
    seed 002's typical values, made for a small differential platform, left the
    tricycle EKF's heading variance ~7x its error). Seed 002 §3.2 says to adjust the
    three constants to the platform's error sources; this is that adjustment.

    Parameters
    ----------
    model:
        ``"tricycle"`` (front drive wheel C steered, base_link O on the fixed axle,
        [seed000 eq8]), ``"tricycle_rear"`` (driven rear axle at O, steered front
        wheel) or ``"differential"`` (two driven wheels, [seed002 eq16]).
    slip_k:
        Variance of a driven wheel's ground distance per metre rolled (m²/m): the
        truth's ``slip_std**2`` (steered) or ``slip_k`` (differential).
    base_m:
        Wheelbase L (steered) or track b (differential), m.
    steering_std:
        Std (rad) of the steered wheel's random angle error, drawn afresh per step.
    step_m:
        Distance (m) travelled per control step (speed x step), over which one
        steering error acts.

    Returns
    -------
    OdometryNoise with, for a wheel rolling ``s`` (variance ``slip_k |s|``):

    * tricycle: ``dD = s cos g``, ``dtheta = s sin g / L``: ``var(dD) = slip_k |dD| cos g``
      gives ``k_d = slip_k``; ``var(dtheta) = slip_k |dtheta| sin g / L`` gives
      ``k_theta = slip_k / L``; the steering error turns the heading by
      ``dD dg / L`` per step: ``k_dtheta = steering_std² step_m / L²``. Each is exact
      at its extreme (straight, or ``g = 90°``) and an upper bound elsewhere;
    * tricycle_rear: ``dD = s``, ``dtheta = s tan g / L``: ``k_d = slip_k``,
      ``k_theta = slip_k / L`` (exact at ``R = L``, an upper bound on wider turns),
      ``k_dtheta = steering_std² step_m / L²`` (straight);
    * differential: ``dD = (s_R + s_L) / 2``, ``dtheta = (s_R - s_L) / b``:
      ``k_d = slip_k / 2`` and ``k_dtheta = 2 slip_k / b²`` (exact straight),
      ``k_theta = slip_k / b`` (exact turning on the spot).

    Systematic errors (wheel radius, steering offset, track) are no random walk and
    are left out. Taken alone, these bounds leave the tricycles' heading pessimistic
    (everywhere but at 90 deg of steering) while the systematic errors they omit make it
    optimistic on straights: :class:`SteeredOdometryNoise` is the exact model of a steered
    vehicle, with the systematic errors as the EKF's consider parameters (issue 12).
    """
    if model not in TRUTH_MODELS:
        raise ValueError(f"noise_from_truth: unknown model {model!r}; choose one of {', '.join(TRUTH_MODELS)}")
    for name, value in (("slip_k", slip_k), ("steering_std", steering_std), ("step_m", step_m)):
        if not (np.isfinite(value) and value >= 0.0):
            raise ValueError(f"{name} must be a non-negative finite number, got {value!r}")
    if not (np.isfinite(base_m) and base_m > 0.0):
        raise ValueError(f"base_m must be a positive finite length (m), got {base_m!r}")
    if model == "differential":
        return OdometryNoise(k_d=0.5 * slip_k, k_dtheta=2.0 * slip_k / base_m**2, k_theta=slip_k / base_m)
    return OdometryNoise(k_d=slip_k, k_dtheta=steering_std**2 * step_m / base_m**2, k_theta=slip_k / base_m)


@dataclass(frozen=True)
class WheelPairOdometryNoise(OdometryNoise):
    """The exact random odometry error of two driven wheels on one axle (a differential drive; issue 32).

    The increments come from the wheels' rolled distances ``s_R = dD + b dtheta / 2`` and
    ``s_L = dD - b dtheta / 2`` ([seed002 eq16], ``b`` the nominal track), each slipping with
    ``var(s) = slip_k |s|`` independently, so ``Sigma = J diag(slip_k |s_R|, slip_k |s_L|) J^T``
    with ``J = d(dD, dtheta)/d(s_R, s_L) = [[1/2, 1/2], [1/b, -1/b]]``:

    * ``var(dD) = slip_k (|s_R| + |s_L|) / 4``, ``var(dtheta) = slip_k (|s_R| + |s_L|) / b^2``,
      ``cov(dD, dtheta) = slip_k (|s_R| - |s_L|) / (2 b)``.

    Crowley's three terms [seed002 eq17] are this model driving straight (``k_d = slip_k / 2``,
    ``k_dtheta = 2 slip_k / b^2``) and for the heading of a turn on the spot (``k_theta = slip_k / b``),
    but they miss the translation a turn on the spot makes: the wheels roll ``b |dtheta| / 2`` each in
    opposite directions and their slips do not cancel, ``var(dD) = slip_k b |dtheta| / 4``, where
    ``K_D |dD|`` says 0. A filter on that form is overconfident along the heading after every spot
    turn (0.6 mm of random shift for a 1.5 deg turn at ``slip_k = 1e-4``, ``b = 0.5`` m, against a
    covariance that did not grow): the station estimator's false alarm of issue 32.

    ``track_m`` (m) the nominal track ``b``; ``slip_k`` (m^2/m) a wheel's slip variance per metre rolled.
    The inherited ``k_d, k_dtheta, k_theta`` are not inputs: they hold Crowley's form of the same slip
    (:func:`noise_from_truth`) for the consumers that take three coefficients.
    """

    k_d: float = field(default=0.0, init=False)
    k_dtheta: float = field(default=0.0, init=False)
    k_theta: float = field(default=0.0, init=False)
    track_m: float = 0.5
    slip_k: float = 0.0

    def __post_init__(self) -> None:
        bound = noise_from_truth("differential", self.slip_k, self.track_m)
        for name in ("k_d", "k_dtheta", "k_theta"):
            object.__setattr__(self, name, getattr(bound, name))
        super().__post_init__()

    def increment_covariance(self, delta_d: ArrayLike, delta_theta: ArrayLike) -> FloatArray:
        """``Sigma (..., 2, 2)`` of the increments ``(dD, dtheta)`` (m, rad) from the two wheels' slip (class doc)."""
        dd, dth = np.broadcast_arrays(np.asarray(delta_d, dtype=np.float64), np.asarray(delta_theta, dtype=np.float64))
        b = self.track_m
        roll_r, roll_l = np.abs(dd + 0.5 * b * dth), np.abs(dd - 0.5 * b * dth)
        cov = np.zeros(dd.shape + (2, 2))
        cov[..., 0, 0] = 0.25 * self.slip_k * (roll_r + roll_l)
        cov[..., 1, 1] = self.slip_k * (roll_r + roll_l) / (b * b)
        cov[..., 0, 1] = cov[..., 1, 0] = 0.5 * self.slip_k * (roll_r - roll_l) / b
        return cov


def wheel_pair_noise(noise: OdometryNoise, track_m: float) -> WheelPairOdometryNoise:
    """The wheel-pair model (:class:`WheelPairOdometryNoise`) of a differential drive given Crowley's coefficients.

    Each coefficient [seed002 eq17] implies a wheel slip (``2 k_d``, ``k_dtheta b^2 / 2``, ``k_theta b``,
    :func:`noise_from_truth` inverted); the largest is taken, so the model bounds every one of them
    and equals them when they come from one slip. ``track_m`` (m) the nominal track ``b``.
    """
    if not (np.isfinite(track_m) and track_m > 0.0):
        raise ValueError(f"track_m must be a positive finite length (m), got {track_m!r}")
    slip_k = max(2.0 * noise.k_d, 0.5 * noise.k_dtheta * track_m**2, noise.k_theta * track_m)
    return WheelPairOdometryNoise(track_m=float(track_m), slip_k=slip_k)


#: Steered vehicles :class:`SteeredOdometryNoise` models exactly.
STEERED_MODELS = ("tricycle", "tricycle_rear")


@dataclass(frozen=True)
class SteeredOdometryNoise(OdometryNoise):
    """The exact odometry error model of a steered vehicle's one driven wheel (issue 12).

    A tricycle's increments come from two readings, the driven wheel's rolled distance
    ``s`` and the steering angle ``g``: front drive ``(dD, dtheta) = (s cos g, s sin g / L)``
    ([seed000 eq8]), rear drive (driven axle at base_link) ``(s, s tan g / L)``. Their errors
    are not the three independent terms of Crowley's form [seed002 eq17], which can only bound
    them (:func:`noise_from_truth`), but move the increment along fixed directions:

    * random slip, ``var(s) = slip_k |s|``: the increment moves along
      ``d(dD, dtheta)/ds = (dD, dtheta) / s`` (both drives), so
      ``Sigma_slip = slip_k / |s| * u u^T`` with ``u = (dD, dtheta)``: rank one;
    * random steering error of std ``steering_std``, drawn afresh per control step of
      ``step_m`` metres: the increment moves along ``w = d(dD, dtheta)/dg``, front
      ``(-L dtheta, dD / L)``, rear ``(0, s (1 + tan^2 g) / L) = (0, dD / L + L dtheta^2 / dD)``:
      ``Sigma_steer = steering_std^2 step_m / |s| * w w^T`` (exact for one full step,
      white in the distance otherwise);
    * systematic errors, the same in every step: a drive-wheel radius scale error ``eps``
      (``s_true = (1 + eps) s``) moves the increment by ``eps u``, a steering offset
      ``beta`` (``g_true = g + beta``) by ``beta w``. They are no random walk: the EKF keeps
      them as consider parameters of prior std ``radius_scale_std`` and
      ``steering_offset_std`` (:mod:`agvnav.positioning.ekf`); :meth:`systematic_jacobian`
      is ``B = d(dD, dtheta)/d(eps, beta) = [u, w]``.

    ``|s|`` is ``hypot(dD, L dtheta)`` (front) or ``|dD|`` (rear). A rear-drive increment
    whose implied steering angle ``|atan(L dtheta / dD)|`` exceeds the vehicle's largest
    ``max_steering_rad`` is one the kinematics cannot produce -- the estimator makes them
    when it extrapolates to a reflection and the next message's heading change differs from
    the last rate (a near-zero ``dD`` with a finite ``dtheta``), where ``1 / |dD|`` would blow
    the slip and steering terms up. Turning by ``dtheta`` takes the rear wheel at least
    ``s_min = L |dtheta| / tan(max_steering_rad)``, so ``|s| = max(|dD|, s_min)`` (signed as
    ``dD``, forward at ``dD = 0``) and ``w = (0, s / L + L dtheta^2 / s)``: the model at the
    steering limit. Increments within the limit are unchanged. With no limit
    (``max_steering_rad = pi/2``) and ``dD = 0``, ``dtheta != 0``, nothing in the wheel model
    explains the turn: its ``Q`` is Crowley's bound ``k_theta |dtheta|`` on the heading
    (:func:`noise_from_truth`) and ``W = 0``. The inherited
    ``k_d, k_dtheta, k_theta`` are not inputs: they hold Crowley's upper bound of the same
    random errors (:func:`noise_from_truth`) for the consumers that take three coefficients
    (the integrity monitor's dead-reckoning growth).

    Parameters
    ----------
    model : ``"tricycle"`` (front drive) or ``"tricycle_rear"``.
    wheelbase_m : nominal wheelbase L (m).
    slip_k : the driven wheel's slip variance per metre rolled (m²/m).
    steering_std : std (rad) of the random steering error per control step.
    step_m : distance (m) per control step over which one steering error acts.
    radius_scale_std : prior std of the drive-wheel radius scale error (fraction, e.g. 0.003).
    steering_offset_std : prior std of the steering offset (rad).
    max_steering_rad : the steering angle limit (rad, either side; in (0, pi/2], default pi/2: no limit).
    """

    k_d: float = field(default=0.0, init=False)
    k_dtheta: float = field(default=0.0, init=False)
    k_theta: float = field(default=0.0, init=False)
    model: str = "tricycle"
    wheelbase_m: float = 1.0
    slip_k: float = 0.0
    steering_std: float = 0.0
    step_m: float = 0.0
    radius_scale_std: float = 0.0
    steering_offset_std: float = 0.0
    max_steering_rad: float = math.pi / 2

    def __post_init__(self) -> None:
        if self.model not in STEERED_MODELS:
            raise ValueError(f"SteeredOdometryNoise: unknown model {self.model!r}; choose one of "
                             f"{', '.join(STEERED_MODELS)}")
        for name in ("radius_scale_std", "steering_offset_std"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a non-negative finite number, got {value!r}")
        if not (np.isfinite(self.max_steering_rad) and 0.0 < self.max_steering_rad <= math.pi / 2):
            raise ValueError(f"max_steering_rad must lie in (0, pi/2] rad, got {self.max_steering_rad!r}")
        bound = noise_from_truth(self.model, self.slip_k, self.wheelbase_m, self.steering_std, self.step_m)
        for name in ("k_d", "k_dtheta", "k_theta"):
            object.__setattr__(self, name, getattr(bound, name))
        super().__post_init__()

    @property
    def front(self) -> bool:
        """Whether the steered wheel is the driven one (front drive)."""
        return self.model == "tricycle"

    @property
    def min_roll_per_rad(self) -> float:
        """``L / tan(max_steering_rad)`` (m/rad): the least a rear drive wheel rolls per rad of turn (0: no limit)."""
        if self.max_steering_rad >= math.pi / 2:
            return 0.0
        return self.wheelbase_m / math.tan(self.max_steering_rad)

    def driven_distance(self, delta_d: ArrayLike, delta_theta: ArrayLike) -> FloatArray:
        """``|s|`` (m), the driven wheel's rolled distance behind the increments (rear: at least ``s_min``)."""
        dd = np.asarray(delta_d, dtype=np.float64)
        dth = np.asarray(delta_theta, dtype=np.float64)
        if self.front:
            return np.hypot(dd, self.wheelbase_m * dth)
        return np.maximum(np.abs(dd), self.min_roll_per_rad * np.abs(dth))

    def systematic_jacobian(self, delta_d: ArrayLike, delta_theta: ArrayLike) -> FloatArray:
        """``B = d(dD, dtheta)/d(eps, beta) = [u, w]`` ``(..., 2, 2)`` (m, rad per unit scale and per rad)."""
        dd = np.asarray(delta_d, dtype=np.float64)
        dth = np.asarray(delta_theta, dtype=np.float64)
        dd, dth = np.broadcast_arrays(dd, dth)
        L = self.wheelbase_m
        B = np.zeros(dd.shape + (2, 2))
        B[..., 0, 0], B[..., 1, 0] = dd, dth
        if self.front:
            B[..., 0, 1], B[..., 1, 1] = -L * dth, dd / L
        else:
            s = np.where(dd < 0.0, -1.0, 1.0) * self.driven_distance(dd, dth)  # signed as dD, at least s_min
            with np.errstate(divide="ignore", invalid="ignore"):
                wt = np.where(s != 0.0, s / L + L * dth * dth / np.where(s != 0.0, s, 1.0), 0.0)
            B[..., 1, 1] = wt
        return B

    def increment_covariance(self, delta_d: ArrayLike, delta_theta: ArrayLike) -> FloatArray:
        """``slip_k/|s| u u^T + steering_std² step_m/|s| w w^T`` ``(..., 2, 2)`` (class docstring; 0 at ``s = 0``).

        At ``s = 0`` with ``dtheta != 0`` (rear drive, no steering limit) the heading variance is
        Crowley's ``k_theta |dtheta|``.
        """
        dd, dth = np.broadcast_arrays(np.asarray(delta_d, dtype=np.float64), np.asarray(delta_theta, dtype=np.float64))
        B = self.systematic_jacobian(dd, dth)
        s = self.driven_distance(dd, dth)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.where(s > 0.0, 1.0 / np.where(s > 0.0, s, 1.0), 0.0)
        u, w = B[..., :, 0], B[..., :, 1]
        q_slip = (self.slip_k * inv)[..., None, None]
        q_steer = (self.steering_std**2 * self.step_m * inv)[..., None, None]
        sigma = q_slip * u[..., :, None] * u[..., None, :] + q_steer * w[..., :, None] * w[..., None, :]
        sigma[..., 1, 1] += np.where(s > 0.0, 0.0, self.k_theta * np.abs(dth))
        return sigma

    def calibration_covariance(self) -> FloatArray:
        """``P_cc = diag(radius_scale_std², steering_offset_std²)`` of the consider parameters ``(eps, beta)``."""
        return np.diag([self.radius_scale_std**2, self.steering_offset_std**2])


#: The constructor fields of :class:`SteeredOdometryNoise` (a run log's ``wheel_odometry`` settings).
WHEEL_ODOMETRY_KEYS = ("model", "wheelbase_m", "slip_k", "steering_std", "step_m", "radius_scale_std",
                       "steering_offset_std", "max_steering_rad")


def steered_noise(model: str, slip_k: float, wheelbase_m: float, steering_std: float = 0.0, step_m: float = 0.0,
                  radius_scale_std: float = 0.0, steering_offset_std: float = 0.0,
                  max_steering_rad: float = math.pi / 2) -> SteeredOdometryNoise:
    """:class:`SteeredOdometryNoise` of a steered vehicle (same arguments as :func:`noise_from_truth`, plus the
    calibration tolerance: ``radius_scale_std`` (fraction) and ``steering_offset_std`` (rad), and the steering
    angle limit ``max_steering_rad`` (rad))."""
    return SteeredOdometryNoise(model=model, wheelbase_m=wheelbase_m, slip_k=slip_k, steering_std=steering_std,
                                step_m=step_m, radius_scale_std=radius_scale_std,
                                steering_offset_std=steering_offset_std, max_steering_rad=max_steering_rad)


def calibration_jacobian(pose: ArrayLike, delta_d: ArrayLike, delta_theta: ArrayLike,
                         noise: SteeredOdometryNoise, rule: str = "arc") -> FloatArray:
    """``W = G B`` ``(..., 3, 2)``: how the pose after one increment moves per unit radius scale error and per rad
    of steering offset (:meth:`SteeredOdometryNoise.systematic_jacobian` through the rule's Jacobian ``G``)."""
    G = increment_jacobian(pose, delta_d, delta_theta, rule)
    return G @ noise.systematic_jacobian(delta_d, delta_theta)


def motion_covariance(pose: ArrayLike, delta_d: ArrayLike, delta_theta: ArrayLike,
                      noise: OdometryNoise | None = None, rule: str = "arc") -> FloatArray:
    """Process noise ``Q (..., 3, 3)`` of one odometry increment ([seed002 eq17], corrected; see module doc).

    Parameters
    ----------
    pose:
        ``(..., 3)`` pose ``[x, y, θ]`` before the increment (m, m, rad).
    delta_d, delta_theta:
        Increments ``ΔD`` (m) and ``Δθ`` (rad).
    noise:
        The coefficients (default :class:`OdometryNoise`).
    rule:
        Integration rule of the pose update, ``"arc"`` [seed002 eq25], ``"midpoint"``
        [seed002 eq26] or ``"euler"`` [seed002 eq20]: ``Q = G Σ Gᵀ`` with ``G`` its exact
        Jacobian with respect to ``(ΔD, Δθ)``.
    """
    noise = noise or OdometryNoise()
    G = increment_jacobian(pose, delta_d, delta_theta, rule)
    sigma = noise.increment_covariance(delta_d, delta_theta)
    return G @ sigma @ np.swapaxes(G, -1, -2)


def propagate(pose: ArrayLike, covariance: ArrayLike, delta_d: ArrayLike, delta_theta: ArrayLike,
              noise: OdometryNoise | None = None, rule: str = "arc") -> tuple[FloatArray, FloatArray]:
    """One dead-reckoning prediction: ``(pose', P' = F P Fᵀ + Q)`` ([seed002 eq14] with the Q of [seed002 eq17]).

    ``F`` and ``Q`` are the Jacobians of the same ``rule`` (see :func:`motion_covariance`).
    """
    pose = np.asarray(pose, dtype=np.float64)
    F = pose_jacobian(pose, delta_d, delta_theta, rule)
    P = F @ np.asarray(covariance, dtype=np.float64) @ np.swapaxes(F, -1, -2)
    Q = motion_covariance(pose, delta_d, delta_theta, noise, rule)
    return integrate_pose(pose, delta_d, delta_theta, rule), P + Q
