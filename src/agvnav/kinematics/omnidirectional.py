"""Omnidirectional base on four Swedish (mecanum) wheels (seed 003 §3.2.3).

State ``[x, y, theta]``, input the body twist ``[v_x, v_y, omega]`` (m/s, m/s,
rad/s). Each wheel i at body position ``(x_i, y_i)`` drives along the body
x-axis; its 45° rollers leave one direction free, so its one constraint
(``swedish_wheel_residual``) fixes its spin: ``r ω_i = v_ix + s_i v_iy`` with
``(v_ix, v_iy)`` the body velocity of the contact and ``s_i = ±1`` the roller
hand. Wheel order: front-left, front-right, rear-left, rear-right.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_positive
from agvnav.kinematics.base import FloatArray, KinematicModel, twist_step

#: Roller hands s_i per layout (FL, FR, RL, RR).
ROLLER_HANDS = {"X": np.array([-1.0, 1.0, 1.0, -1.0]), "O": np.array([1.0, -1.0, -1.0, 1.0])}


class MecanumBase(KinematicModel):
    """Four-wheel mecanum base, forward and inverse kinematics [seed003 §3.2.3].

    Parameters
    ----------
    wheel_radius : r (m), > 0.
    half_length : a, body x of the front axle (rear at −a) (m), > 0.
    half_width : b, body y of the left wheels (right at −b) (m), > 0.
    layout : ``"X"`` or ``"O"``. Defined here by the free-rolling directions of
        the contact rollers (perpendicular to the roller axes) seen from above:
        in ``"X"`` the four lines through the contacts along those directions
        cross near the centre, and a yaw rate needs wheel speeds ``±(a + b)ω/r``;
        in ``"O"`` they form a diamond and the lever arm is ``|a − b|``, so a
        square ``"O"`` base cannot rotate (rank 2). Vendors name these layouts
        inconsistently; check the roller hands ``ROLLER_HANDS`` against the hardware.
    max_wheel_rate : |ω_i| limit (rad/s), ``inf`` for none.
    """

    state_names = ("x", "y", "theta")
    input_names = ("v_x", "v_y", "omega")

    def __init__(self, wheel_radius: float, half_length: float, half_width: float, layout: str = "X",
                 max_wheel_rate: float = np.inf) -> None:
        self.wheel_radius = require_positive("wheel_radius", wheel_radius)
        self.half_length = require_positive("half_length", half_length)
        self.half_width = require_positive("half_width", half_width)
        if layout not in ROLLER_HANDS:
            raise ValueError(f"layout must be 'X' or 'O', got {layout!r}")
        self.layout = layout
        if np.isnan(max_wheel_rate) or max_wheel_rate <= 0.0:
            raise ValueError(f"max_wheel_rate must be > 0, got {max_wheel_rate!r}")
        self.max_wheel_rate = float(max_wheel_rate)
        a, b = self.half_length, self.half_width
        self.wheel_positions = np.array([[a, b], [a, -b], [-a, b], [-a, -b]])
        self.roller_hands = ROLLER_HANDS[layout]
        # Free-rolling direction at η from the wheel plane gives r ω = v_x − v_y cot η, so η = −s·45°.
        self.roller_angles = -self.roller_hands * np.pi / 4.0
        # r ω_i = (v_x − ω y_i) + s_i (v_y + ω x_i)
        x_i, y_i = self.wheel_positions[:, 0], self.wheel_positions[:, 1]
        self.inverse_matrix = np.stack([np.ones(4), self.roller_hands, -y_i + self.roller_hands * x_i], axis=-1)
        self.inverse_matrix /= self.wheel_radius
        self.rank = int(np.linalg.matrix_rank(self.inverse_matrix))

    def wheel_rates(self, u: ArrayLike) -> FloatArray:
        """Inverse kinematics: wheel angular speeds ``(..., 4)`` (rad/s) for body twist ``(..., 3)``."""
        return np.asarray(u, dtype=np.float64) @ self.inverse_matrix.T

    def twist_from_wheel_rates(self, rates: ArrayLike) -> FloatArray:
        """Forward kinematics: body twist ``(..., 3)`` from wheel rates ``(..., 4)`` (least squares).

        Exact when the rates are consistent (no roller slip); otherwise the
        twist that best explains them. Raises ValueError for a rank-deficient
        layout (a square ``"O"`` base), whose yaw rate is unobservable.
        """
        if self.rank < 3:
            raise ValueError(f"layout {self.layout!r} with a == b cannot resolve the yaw rate (rank {self.rank})")
        return np.asarray(rates, dtype=np.float64) @ np.linalg.pinv(self.inverse_matrix).T

    def derivative_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """World velocity: body twist rotated by θ."""
        state = np.asarray(state, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        c, s = np.cos(state[..., 2]), np.sin(state[..., 2])
        vx, vy, w = u[..., 0], u[..., 1], u[..., 2]
        return np.stack([c * vx - s * vy, s * vx + c * vy, w + 0.0 * c], axis=-1)

    def jacobian_state_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂f/∂state`` ``(..., 3, 3)``."""
        state = np.asarray(state, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        c, s = np.cos(state[..., 2]), np.sin(state[..., 2])
        vx, vy = u[..., 0], u[..., 1]
        jac = np.zeros(np.broadcast_shapes(c.shape, vx.shape) + (3, 3))
        jac[..., 0, 2] = -s * vx - c * vy
        jac[..., 1, 2] = c * vx - s * vy
        return jac

    def jacobian_input_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂f/∂u`` ``(..., 3, 3)``: the rotation by θ, with 1 for ω."""
        th = np.asarray(state, dtype=np.float64)[..., 2]
        c, s = np.cos(th), np.sin(th)
        jac = np.zeros(np.broadcast_shapes(th.shape, np.asarray(u).shape[:-1]) + (3, 3))
        jac[..., 0, 0], jac[..., 0, 1] = c, -s
        jac[..., 1, 0], jac[..., 1, 1] = s, c
        jac[..., 2, 2] = 1.0
        return jac

    def step_unchecked(self, state: ArrayLike, u: ArrayLike, dt: float) -> FloatArray:
        """Exact for a constant body twist (SE(2) exponential)."""
        u = np.asarray(u, dtype=np.float64)
        return twist_step(state, u[..., 0], u[..., 1], u[..., 2], dt)

    @property
    def n_constraints(self) -> int:
        """No constraint on the body motion: 3 DOF (each Swedish wheel's constraint only fixes its own spin)."""
        return 0

    def input_violations(self, u: FloatArray) -> list[tuple[str, NDArray[np.bool_]]]:
        """Wheel rates beyond ``max_wheel_rate``."""
        return [("wheel rate", np.any(np.abs(self.wheel_rates(u)) > self.max_wheel_rate, axis=-1))]
