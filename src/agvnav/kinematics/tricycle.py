"""Tricycle vehicles: the seed-000 pallet stacker and seed 003's models A and B.

All share one geometry: a fixed rear axle (reference point O at its midpoint,
the fork wheels of the stacker) and one steered wheel with centre C at distance
``L`` (wheelbase) ahead of O on the body x-axis. They differ in which wheel
drives and in whether the steering angle is a state (input: steering rate) or
an input (the "simplified" models):

==============================  ========  ==========================  ==================
class                           traction  state                       input
==============================  ========  ==========================  ==================
``TricycleStacker``             front     ``[x_O, y_O, psi, gamma]``  ``[v, gamma_dot]``
``TricycleStackerSimple``       front     ``[x_O, y_O, psi]``         ``[v, gamma]``
``TricycleRearDrive``           rear      ``[x, y, theta, phi]``      ``[V, phi_dot]``
``TricycleRearDriveSimple``     rear      ``[x, y, theta]``           ``[V, phi]``
==============================  ========  ==========================  ==================

Front traction ([seed000 eq8]; seed 003 model B with ``v = V_d``): O moves at
``v cos γ`` along the heading and ``ψ' = v sin γ / L``. Rear traction (seed
003 model A): O moves at ``V`` and ``θ' = V tan φ / L``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_positive
from agvnav.kinematics.base import (
    FloatArray,
    KinematicModel,
    check_angle_limit,
    check_rate_limit,
    rk4_step,
    twist_step,
)


def front_drive_twist(v: ArrayLike, gamma: ArrayLike, wheelbase: float) -> tuple[FloatArray, FloatArray]:
    """Speed of O and yaw rate ``(v cos γ, v sin γ / L)`` for a front drive wheel.

    [seed000 eq8]; seed 003 model B [seed003 §3.2.5] with ``v = V_d``.
    """
    v = np.asarray(v, dtype=np.float64)
    g = np.asarray(gamma, dtype=np.float64)
    return v * np.cos(g), v * np.sin(g) / wheelbase


def rear_drive_twist(v: ArrayLike, phi: ArrayLike, wheelbase: float) -> tuple[FloatArray, FloatArray]:
    """Speed of O and yaw rate ``(V, V tan φ / L)`` for rear traction (seed 003 model A) [seed003 §3.2.5]."""
    v = np.asarray(v, dtype=np.float64)
    return v, v * np.tan(np.asarray(phi, dtype=np.float64)) / wheelbase


class _Tricycle(KinematicModel):
    """Shared implementation; see the module docstring for the four public variants."""

    front_traction: bool = True
    steer_is_state: bool = True

    def __init__(self, wheelbase: float, max_steer: float = np.pi / 2, max_steer_rate: float = np.inf) -> None:
        self.wheelbase = require_positive("wheelbase", wheelbase)
        upper = np.pi / 2
        self.max_steer = check_angle_limit("max_steer", max_steer, upper)
        if not self.front_traction and self.max_steer >= upper:
            # tan φ is unbounded at 90°: rear traction needs a limit strictly below it.
            self.max_steer = np.nextafter(upper, 0.0)
        self.max_steer_rate = check_rate_limit("max_steer_rate", max_steer_rate)

    # ------------------------------------------------------------ the model
    def _twist(self, v: FloatArray, steer: FloatArray) -> tuple[FloatArray, FloatArray]:
        if self.front_traction:
            return front_drive_twist(v, steer, self.wheelbase)
        return rear_drive_twist(v, steer, self.wheelbase)

    def _twist_partials(self, v: FloatArray, steer: FloatArray) -> tuple[FloatArray, ...]:
        """``(∂u_O/∂v, ∂u_O/∂γ, ∂ω/∂v, ∂ω/∂γ)`` of the speed of O and the yaw rate."""
        L = self.wheelbase
        if self.front_traction:
            c, s = np.cos(steer), np.sin(steer)
            return c, -v * s, s / L, v * c / L
        t = np.tan(steer)
        return np.ones_like(t), np.zeros_like(t), t / L, v * (1.0 + t * t) / L

    def _split(self, state: ArrayLike, u: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        state = np.asarray(state, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        steer = state[..., 3] if self.steer_is_state else u[..., 1]
        return state, u, steer

    def derivative_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``[x', y', ψ'(, γ')]`` [seed000 eq8] [seed003 §3.2.5]."""
        state, u, steer = self._split(state, u)
        speed, omega = self._twist(u[..., 0], steer)
        psi = state[..., 2]
        cols = [speed * np.cos(psi), speed * np.sin(psi), omega]
        if self.steer_is_state:
            cols.append(np.broadcast_to(u[..., 1], omega.shape))
        return np.stack(cols, axis=-1)

    def jacobian_state_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂f/∂state`` ``(..., n, n)``."""
        state, u, steer = self._split(state, u)
        speed, _ = self._twist(u[..., 0], steer)
        psi = state[..., 2]
        c, s = np.cos(psi), np.sin(psi)
        jac = np.zeros(np.broadcast_shapes(speed.shape, psi.shape) + (self.n_state, self.n_state))
        jac[..., 0, 2] = -speed * s
        jac[..., 1, 2] = speed * c
        if self.steer_is_state:
            _, du_dg, _, dw_dg = self._twist_partials(u[..., 0], steer)
            jac[..., 0, 3] = du_dg * c
            jac[..., 1, 3] = du_dg * s
            jac[..., 2, 3] = dw_dg
        return jac

    def jacobian_input_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂f/∂u`` ``(..., n, 2)``."""
        state, u, steer = self._split(state, u)
        du_dv, du_dg, dw_dv, dw_dg = self._twist_partials(u[..., 0], steer)
        psi = state[..., 2]
        c, s = np.cos(psi), np.sin(psi)
        shape = np.broadcast_shapes(np.shape(du_dv), np.shape(du_dg), psi.shape)
        jac = np.zeros(shape + (self.n_state, 2))
        jac[..., 0, 0] = du_dv * c
        jac[..., 1, 0] = du_dv * s
        jac[..., 2, 0] = dw_dv
        if self.steer_is_state:
            jac[..., 3, 1] = 1.0
        else:
            jac[..., 0, 1] = du_dg * c
            jac[..., 1, 1] = du_dg * s
            jac[..., 2, 1] = dw_dg
        return jac

    def step_unchecked(self, state: ArrayLike, u: ArrayLike, dt: float) -> FloatArray:
        """Exact arc while the steering angle is constant, sub-stepped RK4 where it changes.

        The kernel does not clamp γ at ``max_steer``: limits belong to the steering actuator;
        ``state_valid``/``check_state`` flag a state that went beyond them.
        """
        state, u, steer = self._split(state, u)
        speed, omega = self._twist(u[..., 0], steer)
        arc = twist_step(state[..., :3], speed, 0.0, omega, dt)
        if not self.steer_is_state:
            return arc
        arc = np.concatenate([arc, np.broadcast_to(steer, arc.shape[:-1])[..., None]], axis=-1)
        turning = u[..., 1] != 0.0
        if not np.any(turning):
            return arc
        rk = rk4_step(self.derivative_unchecked, state, u, dt, self.substeps)
        return np.where(turning[..., None], rk, arc)

    # ----------------------------------------------------------- geometry
    def point_c(self, state: ArrayLike) -> FloatArray:
        """Centre C of the steered wheel ``(..., 2)``, L ahead of O on the body x-axis (seed 000 Fig. 4b)."""
        state = np.asarray(state, dtype=np.float64)
        psi = state[..., 2]
        return np.stack(
            [state[..., 0] + self.wheelbase * np.cos(psi), state[..., 1] + self.wheelbase * np.sin(psi)], axis=-1
        )

    def steer_for_curvature(self, curvature: ArrayLike) -> FloatArray:
        """Steering angle ``atan(κ L)`` (rad) that makes O follow a path of curvature κ (1/m).

        The turn radius of O is ``R = l / tan φ`` [seed003 §3.2.5].
        """
        return np.arctan(np.asarray(curvature, dtype=np.float64) * self.wheelbase)

    def inverse(self, speed_o: ArrayLike, omega: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Inverse kinematics: ``(drive speed, steering angle)`` giving O speed ``speed_o`` and yaw rate ``omega``.

        Front traction: ``γ = atan(ωL/u_O)``, ``v = u_O / cos γ``; rear: ``φ = atan(ωL/V)``, ``V = u_O``.
        ``u_O = 0`` with ``ω ≠ 0`` needs γ = ±90° (turning on the spot): NaN, the limit is exclusive.
        """
        u_o = np.asarray(speed_o, dtype=np.float64)
        w = np.asarray(omega, dtype=np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            steer = np.where(u_o == 0.0, np.where(w == 0.0, 0.0, np.nan), np.arctan(w * self.wheelbase / u_o))
        drive = u_o / np.cos(steer) if self.front_traction else u_o + 0.0 * steer
        return drive, steer

    # ------------------------------------------------------- constraints
    @property
    def n_constraints(self) -> int:
        """Rear axle and steered wheel when γ is a state (4 − 2 = 2 DOF, [seed003 §3.2.5]); rear axle only otherwise."""
        return 2 if self.steer_is_state else 1

    def constraint_matrix(self, state: ArrayLike) -> FloatArray:
        """[seed003 §3.2.5]: ``ẋ sinθ − ẏ cosθ = 0``, ``ẋ sin(φ+θ) − ẏ cos(φ+θ) − θ' l cos φ = 0``."""
        state = np.asarray(state, dtype=np.float64)
        th = state[..., 2]
        zero = np.zeros_like(th)
        rows = [[np.sin(th), -np.cos(th), zero]]
        if self.steer_is_state:
            rows[0].append(zero)
            g = state[..., 3]
            rows.append([np.sin(g + th), -np.cos(g + th), -self.wheelbase * np.cos(g), zero])
        return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)

    # ------------------------------------------------------------ limits
    def state_violations(self, state: FloatArray) -> list[tuple[str, NDArray[np.bool_]]]:
        """Steering angle beyond ``max_steer`` (exclusive at 90°: −90° < γ < 90°, seed 000 §3.1)."""
        if not self.steer_is_state:
            return []
        return [(f"{self.state_names[3]} (steering angle)", self._steer_bad(state[..., 3]))]

    def input_violations(self, u: FloatArray) -> list[tuple[str, NDArray[np.bool_]]]:
        """Steering rate beyond ``max_steer_rate`` or commanded angle beyond ``max_steer``."""
        if self.steer_is_state:
            return [(f"{self.input_names[1]} (steering rate)", np.abs(u[..., 1]) > self.max_steer_rate)]
        return [(f"{self.input_names[1]} (steering angle)", self._steer_bad(u[..., 1]))]

    def _steer_bad(self, steer: FloatArray) -> NDArray[np.bool_]:
        if self.max_steer >= np.pi / 2:
            return np.abs(steer) >= np.pi / 2
        return np.abs(steer) > self.max_steer


class TricycleStacker(_Tricycle):
    """Seed-000 pallet stacker (also seed 003 model B, complete): front wheel drives and steers.

    State ``[x_O, y_O, psi, gamma]``, input ``[v, gamma_dot]`` with ``v`` the
    speed of the drive-wheel centre C:
    ``x_O' = v cosγ cosψ``, ``y_O' = v cosγ sinψ``, ``ψ' = v sinγ / L`` [seed000 eq8], ``γ' = γ̇``.

    Parameters
    ----------
    wheelbase : L, distance O-C (m), > 0.
    max_steer : |γ| limit (rad); the default π/2 is exclusive (−90° < γ < 90°, seed 000 §3.1).
    max_steer_rate : |γ̇| limit (rad/s), ``inf`` for none.
    """

    state_names = ("x_O", "y_O", "psi", "gamma")
    input_names = ("v", "gamma_dot")


class TricycleStackerSimple(_Tricycle):
    """Stacker with the steering angle commanded directly (seed 003 model B, simplified): input ``[v, gamma]``."""

    state_names = ("x_O", "y_O", "psi")
    input_names = ("v", "gamma")
    steer_is_state = False


class TricycleRearDrive(_Tricycle):
    """Seed 003 model A, complete: rear traction ``V``, steered front wheel ``φ``, ``θ' = V tan φ / l``.

    State ``[x, y, theta, phi]``, input ``[V, phi_dot]``; requires |φ| < max_steer < 90°.
    """

    state_names = ("x", "y", "theta", "phi")
    input_names = ("V", "phi_dot")
    front_traction = False


class TricycleRearDriveSimple(_Tricycle):
    """Seed 003 model A, simplified: state ``[x, y, theta]``, input ``[V, phi]``."""

    state_names = ("x", "y", "theta")
    input_names = ("V", "phi")
    front_traction = False
    steer_is_state = False


TricycleModelA = TricycleRearDrive
TricycleModelB = TricycleStacker
