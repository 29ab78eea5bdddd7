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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.odometry.integrate import increment_jacobian, integrate_pose, pose_jacobian

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
        """``diag(K_D|ΔD|, K_Dθ|ΔD| + K_θ|Δθ|)`` ``(..., 2, 2)`` of the increments ``(ΔD, Δθ)``."""
        dd = np.abs(np.asarray(delta_d, dtype=np.float64))
        dth = np.abs(np.asarray(delta_theta, dtype=np.float64))
        shape = np.broadcast_shapes(dd.shape, dth.shape)
        cov = np.zeros(shape + (2, 2))
        cov[..., 0, 0] = self.k_d * dd
        cov[..., 1, 1] = self.k_dtheta * dd + self.k_theta * dth
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
    are left out: the reflector updates bound them.
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
