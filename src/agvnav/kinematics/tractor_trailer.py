"""Tractor-trailer of seed 003 §3.2.7, with an off-axle hitch.

A unicycle tractor (state ``[x, y, theta]`` of its rear-axle midpoint, input
``[v, omega]``, seed 003 writes ``ω = v ρ``) tows a one-axle trailer hitched at
a point ``d`` behind the tractor axle; the trailer axle is ``D`` behind the
hitch. The fourth state is the hitch angle ``φ = θ − θ_trailer``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_nonnegative, require_positive
from agvnav.kinematics.base import FloatArray, KinematicModel, check_angle_limit


class TractorTrailer(KinematicModel):
    """Tractor with one off-axle trailer [seed003 §3.2.7].

    ``φ' = −(sin φ / D) v + (1 + (d/D) cos φ) ω``, from the seed's constraint
    ``[cosθ sinφ, sinθ sinφ, −D − d cosφ, D]·q' = 0``.

    Parameters
    ----------
    trailer_length : D, hitch to trailer axle (m), > 0.
    hitch_offset : d, tractor axle to hitch, positive behind the axle (m), >= 0 (0 = on-axle).
    max_hitch_angle : |φ| at which the combination counts as jackknifed (rad), default 90°.
    """

    state_names = ("x", "y", "theta", "phi")
    input_names = ("v", "omega")
    substeps = 4

    def __init__(self, trailer_length: float, hitch_offset: float = 0.0, max_hitch_angle: float = np.pi / 2) -> None:
        self.trailer_length = require_positive("trailer_length", trailer_length)
        self.hitch_offset = require_nonnegative("hitch_offset", hitch_offset)
        self.max_hitch_angle = check_angle_limit("max_hitch_angle", max_hitch_angle, np.pi)

    def derivative_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``[v cosθ, v sinθ, ω, φ']`` with the hitch rate above: [seed003 §3.2.7]."""
        state = np.asarray(state, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        th, phi = state[..., 2], state[..., 3]
        v, w = u[..., 0], u[..., 1]
        D, d = self.trailer_length, self.hitch_offset
        phi_dot = -np.sin(phi) * v / D + (1.0 + d * np.cos(phi) / D) * w
        return np.stack([v * np.cos(th), v * np.sin(th), w + 0.0 * phi_dot, phi_dot], axis=-1)

    def jacobian_state_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂f/∂state`` ``(..., 4, 4)``."""
        state = np.asarray(state, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        th, phi = state[..., 2], state[..., 3]
        v, w = u[..., 0], u[..., 1]
        D, d = self.trailer_length, self.hitch_offset
        shape = np.broadcast_shapes(th.shape, v.shape)
        jac = np.zeros(shape + (4, 4))
        jac[..., 0, 2] = -v * np.sin(th)
        jac[..., 1, 2] = v * np.cos(th)
        jac[..., 3, 3] = -np.cos(phi) * v / D - d * np.sin(phi) * w / D
        return jac

    def jacobian_input_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂f/∂[v, ω]`` ``(..., 4, 2)``."""
        state = np.asarray(state, dtype=np.float64)
        th, phi = state[..., 2], state[..., 3]
        D, d = self.trailer_length, self.hitch_offset
        shape = np.broadcast_shapes(th.shape, np.asarray(u).shape[:-1])
        jac = np.zeros(shape + (4, 2))
        jac[..., 0, 0] = np.cos(th)
        jac[..., 1, 0] = np.sin(th)
        jac[..., 3, 0] = -np.sin(phi) / D
        jac[..., 2, 1] = 1.0
        jac[..., 3, 1] = 1.0 + d * np.cos(phi) / D
        return jac

    @property
    def n_constraints(self) -> int:
        """Tractor axle and trailer axle: 4 − 2 = 2 DOF [seed003 §3.2.7]."""
        return 2

    def constraint_matrix(self, state: ArrayLike) -> FloatArray:
        """``[[−sinθ, cosθ, 0, 0], [cosθ sinφ, sinθ sinφ, −D − d cosφ, D]]`` [seed003 §3.2.7]."""
        state = np.asarray(state, dtype=np.float64)
        th, phi = state[..., 2], state[..., 3]
        zero = np.zeros_like(th)
        D, d = self.trailer_length, self.hitch_offset
        r1 = np.stack([-np.sin(th), np.cos(th), zero, zero], axis=-1)
        r2 = np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), -D - d * np.cos(phi), D + zero], axis=-1)
        return np.stack([r1, r2], axis=-2)

    def trailer_pose(self, state: ArrayLike) -> FloatArray:
        """Trailer axle midpoint pose ``(..., 3)``: hitch ``d`` behind the tractor axle, axle ``D`` behind the hitch."""
        state = np.asarray(state, dtype=np.float64)
        th = state[..., 2]
        th_t = th - state[..., 3]
        hx = state[..., 0] - self.hitch_offset * np.cos(th)
        hy = state[..., 1] - self.hitch_offset * np.sin(th)
        return np.stack(
            [hx - self.trailer_length * np.cos(th_t), hy - self.trailer_length * np.sin(th_t), th_t], axis=-1
        )

    def trailer_velocity(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """Time derivative ``(..., 3)`` of ``trailer_pose`` (for checking the trailer wheels' constraint)."""
        state = np.asarray(state, dtype=np.float64)
        qd = self.derivative_unchecked(state, u)
        th, th_t = state[..., 2], state[..., 2] - state[..., 3]
        w, w_t = qd[..., 2], qd[..., 2] - qd[..., 3]
        d, D = self.hitch_offset, self.trailer_length
        vx = qd[..., 0] + d * np.sin(th) * w + D * np.sin(th_t) * w_t
        vy = qd[..., 1] - d * np.cos(th) * w - D * np.cos(th_t) * w_t
        return np.stack([vx, vy, w_t], axis=-1)

    def jackknifed(self, state: ArrayLike) -> NDArray[np.bool_]:
        """True ``(...)`` where |φ| reached ``max_hitch_angle``."""
        return np.abs(np.asarray(state, dtype=np.float64)[..., 3]) >= self.max_hitch_angle

    def equilibrium_hitch_angle(self, curvature: ArrayLike) -> FloatArray:
        """Steady hitch angle (rad) while the tractor drives forward on curvature κ (1/m), from ``φ' = 0``.

        Solves ``−sin φ + (D + d cos φ) κ = 0`` by Newton iterations started at
        ``atan(κ D)``, the exact answer for an on-axle hitch (d = 0).
        """
        k = np.asarray(curvature, dtype=np.float64)
        D, d = self.trailer_length, self.hitch_offset
        phi = np.arctan(k * D)
        for _ in range(30):
            g = -np.sin(phi) + (D + d * np.cos(phi)) * k
            dg = -np.cos(phi) - d * np.sin(phi) * k
            phi = phi - g / dg
        return phi

    def state_violations(self, state: FloatArray) -> list[tuple[str, NDArray[np.bool_]]]:
        """Jackknife: |φ| >= ``max_hitch_angle``."""
        return [("phi (hitch angle: jackknife)", self.jackknifed(state))]
