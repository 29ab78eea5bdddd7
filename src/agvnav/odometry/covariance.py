"""Odometry noise model [seed002 eq17] (after Crowley 1992), made positive semi-definite.

Seed 002 prints ``Q11 = K_D ΔD cos θ``, ``Q22 = K_D ΔD sin θ`` — which is
negative for half the headings, so it cannot be a covariance. The intended
model is noise on the increments, ``var(ΔD) = K_D |ΔD|`` and
``var(Δθ) = K_Dθ |ΔD| + K_θ |Δθ|``, mapped to the pose by
``J = [[cos θ_m, 0], [sin θ_m, 0], [0, 1]]`` at the midpoint heading
``θ_m = θ + Δθ/2``: ``Q = J · diag(...) · Jᵀ``. That is what is implemented.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.odometry.integrate import integrate_pose, pose_jacobian

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
                      noise: OdometryNoise | None = None) -> FloatArray:
    """Process noise ``Q (..., 3, 3)`` of one odometry increment ([seed002 eq17], corrected; see module doc)."""
    noise = noise or OdometryNoise()
    pose = np.asarray(pose, dtype=np.float64)
    dth = np.asarray(delta_theta, dtype=np.float64)
    heading = pose[..., 2] + 0.5 * dth
    sigma = noise.increment_covariance(delta_d, dth)
    c, s = np.cos(heading), np.sin(heading)
    J = np.zeros(np.broadcast_shapes(heading.shape, sigma.shape[:-2]) + (3, 2))
    J[..., 0, 0], J[..., 1, 0], J[..., 2, 1] = c, s, 1.0
    return J @ sigma @ np.swapaxes(J, -1, -2)


def propagate(pose: ArrayLike, covariance: ArrayLike, delta_d: ArrayLike, delta_theta: ArrayLike,
              noise: OdometryNoise | None = None, rule: str = "arc") -> tuple[FloatArray, FloatArray]:
    """One dead-reckoning prediction: ``(pose', P' = F P Fᵀ + Q)`` ([seed002 eq14] with the Q of [seed002 eq17])."""
    pose = np.asarray(pose, dtype=np.float64)
    F = pose_jacobian(pose, delta_d, delta_theta, rule)
    P = F @ np.asarray(covariance, dtype=np.float64) @ np.swapaxes(F, -1, -2)
    return integrate_pose(pose, delta_d, delta_theta, rule), P + motion_covariance(pose, delta_d, delta_theta, noise)
