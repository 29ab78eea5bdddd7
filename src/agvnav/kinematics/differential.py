"""Differential drive / unicycle (seed 002 §2, seed 003 §3.2.4, seed 004 §II.A).

State ``[x, y, theta]`` of the axle midpoint, input ``[v, omega]``; the wheels'
speeds convert to and from ``(v, ω)`` with the track ``L`` (distance between
the wheel contact points).

This module holds agvnav's one formulation of the differential-drive equations
``v = (v_R + v_L)/2``, ``ω = (v_R − v_L)/L`` and their inverse:
:func:`body_speeds_unchecked` and :func:`wheel_speeds_unchecked` work on plain
floats (a simulator's hot loop) and on arrays alike; :func:`body_speeds` and
:func:`wheel_speeds` add the checks. Odometry increments (distances instead of
speeds), the actuators' wheel angular rates and the tracked vehicle's ideal-track
speeds all call these two.
"""

from __future__ import annotations

from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_positive
from agvnav.kinematics.base import FloatArray, KinematicModel, scalar_inputs_or_flag, twist_step

Speed = TypeVar("Speed", float, NDArray[np.float64])


def unicycle_derivative(state: ArrayLike, u: ArrayLike) -> FloatArray:
    """``[ẋ, ẏ, θ'] = [v cosθ, v sinθ, ω]`` [seed002 eq9] [seed002 eq11], state ``(..., 3)``, u ``(..., 2)``."""
    state = np.asarray(state, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)
    th = state[..., 2]
    return np.stack([u[..., 0] * np.cos(th), u[..., 0] * np.sin(th), u[..., 1]], axis=-1)


def wheel_speeds_unchecked(v: Speed, omega: Speed, track: float) -> tuple[Speed, Speed]:
    """Wheel ground speeds ``(v_R, v_L)`` for body speed ``v`` and yaw rate ``ω``, no checks.

    ``v_R = v + ωL/2``, ``v_L = v − ωL/2``: the inverse of [seed002 eq4] and [seed002 eq6]
    ([seed004 eq1] and [seed004 eq2] times the wheel radius). Floats in, floats out (the
    hot-loop form); arrays broadcast. The same expression maps the odometry increments
    ``(ΔD, Δθ)`` to the wheel distances ``(ΔD_R, ΔD_L)`` ([seed002 eq18], [seed002 eq21]).

    Parameters
    ----------
    v : speed of the axle midpoint (m/s), or distance ΔD (m).
    omega : yaw rate (rad/s), or heading increment Δθ (rad).
    track : L, distance between the wheel contact points (m); not checked.

    Returns
    -------
    (v_R, v_L) : right and left wheel ground speeds (m/s), or distances (m).
    """
    half = 0.5 * track * omega
    return v + half, v - half


def body_speeds_unchecked(v_right: Speed, v_left: Speed, track: float) -> tuple[Speed, Speed]:
    """``(v, ω)`` from wheel ground speeds, no checks: ``v = (v_R + v_L)/2``, ``ω = (v_R − v_L)/L``.

    [seed002 eq4], [seed002 eq6], [seed003 §3.2.4] (with ``L = 2l``). Floats in, floats out
    (the hot-loop form); arrays broadcast. With wheel distances instead of speeds it is the
    odometry increment ``(ΔD, Δθ)`` of [seed002 eq16].

    Parameters
    ----------
    v_right, v_left : right and left wheel ground speeds (m/s), or distances (m).
    track : L, distance between the wheel contact points (m); not checked.

    Returns
    -------
    (v, omega) : speed of the axle midpoint (m/s) and yaw rate (rad/s), or (ΔD (m), Δθ (rad)).
    """
    return 0.5 * (v_right + v_left), (v_right - v_left) / track


TwistMatrix = tuple[tuple[float, float], tuple[float, float], tuple[float, float]]


def body_twist_matrix(track: float) -> TwistMatrix:
    """Body twist ``[v_x, v_y, ω]`` per wheel ground speed ``[v_R, v_L]``: ``(3, 2)`` nested floats.

    ``[[1/2, 1/2], [0, 0], [1/L, −1/L]]``, [seed002 eq8] per unit wheel radius: the columns
    are :func:`body_speeds_unchecked` of a unit speed of each wheel, so it is the same
    formulation in matrix form, for hot loops that apply a (possibly perturbed) matrix, such
    as :func:`agvnav.kinematics.scalar.track_twist`. Applied to the wheel distances of a
    step it gives ``(ΔD, 0, Δθ)`` of [seed002 eq16].

    Parameters
    ----------
    track : L, distance between the wheel contact points (m), > 0 (ValueError otherwise).
    """
    track = require_positive("track", track)
    v_r, w_r = body_speeds_unchecked(1.0, 0.0, track)
    v_l, w_l = body_speeds_unchecked(0.0, 1.0, track)
    return (v_r, v_l), (0.0, 0.0), (w_r, w_l)


def wheel_speeds(v: ArrayLike, omega: ArrayLike, track: float) -> tuple[FloatArray, FloatArray]:
    """Wheel ground speeds ``(v_R, v_L)`` (m/s) for body speed ``v`` (m/s) and yaw rate ``ω`` (rad/s).

    Inverse of [seed002 eq6] (``v = (v_R + v_L)/2``) and [seed002 eq4] (``ω = (v_R − v_L)/L``):
    ``v_R = v + ωL/2``, ``v_L = v − ωL/2`` (:func:`wheel_speeds_unchecked` after the checks).
    ``track`` L (m) must be positive; scalar NaN/inf inputs raise a ValueError naming them,
    batch elements come out NaN (the flag).
    """
    track = require_positive("track", track)
    (v, omega), _ = scalar_inputs_or_flag(v=v, omega=omega)
    return wheel_speeds_unchecked(v, omega, track)


def body_speeds(v_right: ArrayLike, v_left: ArrayLike, track: float) -> tuple[FloatArray, FloatArray]:
    """``(v, ω)`` from wheel ground speeds: ``v = (v_R+v_L)/2`` [seed002 eq6], ``ω = (v_R−v_L)/L`` [seed002 eq4].

    :func:`body_speeds_unchecked` after the checks: ``track`` L (m) must be positive; scalar
    NaN/inf speeds raise a ValueError naming them, batch elements come out NaN (the flag).
    """
    track = require_positive("track", track)
    (vr, vl), _ = scalar_inputs_or_flag(v_right=v_right, v_left=v_left)
    return body_speeds_unchecked(vr, vl, track)


def turning_radius(v_right: ArrayLike, v_left: ArrayLike, track: float) -> FloatArray:
    """Signed radius ``R = L(v_R+v_L) / (2(v_R−v_L))`` (m) of the axle midpoint [seed002 eq3] [seed002 eq4].

    ``+inf``/``-inf`` for straight motion (``v_R = v_L ≠ 0``); NaN when both are zero
    (no motion, radius undefined). Positive R: the centre is on the left.
    """
    vr = np.asarray(v_right, dtype=np.float64)
    vl = np.asarray(v_left, dtype=np.float64)
    num = track * (vr + vl)
    den = 2.0 * (vr - vl)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = num / den
    return np.where(den == 0.0, np.where(num == 0.0, np.nan, np.copysign(np.inf, num)), r)


def instantaneous_centre(state: ArrayLike, radius: ArrayLike) -> FloatArray:
    """ICR ``(x − R sinθ, y + R cosθ)`` ``(..., 2)`` (m) for signed radius ``R`` [seed002 eq2]."""
    state = np.asarray(state, dtype=np.float64)
    r = np.asarray(radius, dtype=np.float64)
    th = state[..., 2]
    return np.stack([state[..., 0] - r * np.sin(th), state[..., 1] + r * np.cos(th)], axis=-1)


class DifferentialDrive(KinematicModel):
    """Differential-drive vehicle, equivalently a unicycle with ``[v, ω]`` input.

    State ``[x, y, θ]`` of the axle midpoint [seed002 eq5], model [seed003 §3.2.4].

    Parameters
    ----------
    track : distance L between the two wheel contact points (m), > 0.
    wheel_radius : r (m), > 0; used by the wheel angular-speed conversions.
    max_wheel_speed : limit on |v_R|, |v_L| (m/s); ``inf`` for none.

    ``step`` is exact (constant ``(v, ω)`` gives an arc, [seed002 eq25]).
    """

    state_names = ("x", "y", "theta")
    input_names = ("v", "omega")

    def __init__(self, track: float, wheel_radius: float = 0.1, max_wheel_speed: float = np.inf) -> None:
        self.track = require_positive("track", track)
        self.wheel_radius = require_positive("wheel_radius", wheel_radius)
        if np.isnan(max_wheel_speed) or max_wheel_speed <= 0.0:
            raise ValueError(f"max_wheel_speed must be > 0, got {max_wheel_speed!r}")
        self.max_wheel_speed = float(max_wheel_speed)

    @property
    def n_constraints(self) -> int:
        """One non-holonomic constraint: ``ẋ sinθ − ẏ cosθ = 0`` ([seed003 §3.2.4], 3 − 1 = 2 DOF)."""
        return 1

    def constraint_matrix(self, state: ArrayLike) -> FloatArray:
        """``[[sinθ, −cosθ, 0]]`` ``(..., 1, 3)`` [seed003 §3.2.4] (also seed 002's non-holonomy condition)."""
        th = np.asarray(state, dtype=np.float64)[..., 2]
        return np.stack([np.sin(th), -np.cos(th), np.zeros_like(th)], axis=-1)[..., None, :]

    def derivative_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``[v cosθ, v sinθ, ω]`` [seed002 eq11] [seed003 §3.2.4]."""
        return unicycle_derivative(state, u)

    def jacobian_state_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂f/∂[x, y, θ]`` ``(..., 3, 3)``: only the θ column is non-zero."""
        th = np.asarray(state, dtype=np.float64)[..., 2]
        v = np.asarray(u, dtype=np.float64)[..., 0]
        jac = np.zeros(np.broadcast_shapes(th.shape, v.shape) + (3, 3))
        jac[..., 0, 2] = -v * np.sin(th)
        jac[..., 1, 2] = v * np.cos(th)
        return jac

    def jacobian_input_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂f/∂[v, ω]`` ``(..., 3, 2)`` = ``[[cosθ, 0], [sinθ, 0], [0, 1]]`` [seed002 eq11]."""
        th = np.asarray(state, dtype=np.float64)[..., 2]
        shape = np.broadcast_shapes(th.shape, np.asarray(u).shape[:-1])
        jac = np.zeros(shape + (3, 2))
        jac[..., 0, 0] = np.cos(th)
        jac[..., 1, 0] = np.sin(th)
        jac[..., 2, 1] = 1.0
        return jac

    def step_unchecked(self, state: ArrayLike, u: ArrayLike, dt: float) -> FloatArray:
        """Exact arc for constant ``(v, ω)`` [seed002 eq12] [seed002 eq13] [seed002 eq25]."""
        u = np.asarray(u, dtype=np.float64)
        return twist_step(state, u[..., 0], 0.0, u[..., 1], dt)

    def input_violations(self, u: FloatArray) -> list[tuple[str, NDArray[np.bool_]]]:
        """Wheel ground speeds beyond ``max_wheel_speed``."""
        vr, vl = wheel_speeds_unchecked(u[..., 0], u[..., 1], self.track)  # flags must not raise on NaN
        too_fast = (np.abs(vr) > self.max_wheel_speed) | (np.abs(vl) > self.max_wheel_speed)
        return [("wheel speed (v ± omega*track/2)", too_fast)]

    # ---------------------------------------------------------------- wheels
    def wheel_speeds(self, u: ArrayLike) -> FloatArray:
        """Wheel ground speeds ``(..., 2)`` = ``[v_R, v_L]`` (m/s) for input ``[v, ω]``."""
        u = np.asarray(u, dtype=np.float64)
        return np.stack(wheel_speeds(u[..., 0], u[..., 1], self.track), axis=-1)

    def input_from_wheel_speeds(self, wheel: ArrayLike) -> FloatArray:
        """``[v, ω]`` ``(..., 2)`` from ``[v_R, v_L]`` [seed002 eq6] [seed002 eq4]."""
        wheel = np.asarray(wheel, dtype=np.float64)
        return np.stack(body_speeds(wheel[..., 0], wheel[..., 1], self.track), axis=-1)

    def wheel_rates(self, u: ArrayLike) -> FloatArray:
        """Wheel angular speeds ``[ω_R, ω_L]`` (rad/s) [seed004 eq1] [seed004 eq2]: ``ω_R = (2v + ωL)/(2r)``."""
        return self.wheel_speeds(u) / self.wheel_radius

    def input_from_wheel_rates(self, rates: ArrayLike) -> FloatArray:
        """``[v, ω]`` from wheel angular speeds ``[ω_R, ω_L]`` [seed002 eq6] [seed002 eq7] [seed002 eq8]."""
        return self.input_from_wheel_speeds(np.asarray(rates, dtype=np.float64) * self.wheel_radius)

    def icr(self, state: ArrayLike, u: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Instantaneous centre of rotation ``(..., 2)`` and signed radius ``R = v/ω`` ``(...)``.

        [seed002 eq2] [seed002 eq3] [seed002 eq4].

        For ``ω = 0`` the radius is ±inf and the centre is at infinity (inf/nan entries).
        """
        u = np.asarray(u, dtype=np.float64)
        vr, vl = wheel_speeds(u[..., 0], u[..., 1], self.track)
        radius = turning_radius(vr, vl, self.track)
        with np.errstate(invalid="ignore"):
            return instantaneous_centre(state, radius), radius
