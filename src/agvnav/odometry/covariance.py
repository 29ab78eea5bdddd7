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
