"""Wheel constraints of seed 003 §3.2.1-3.2.3 as residual functions.

Each function returns the residual of one constraint: zero when the wheel rolls
without slipping. They are used to verify vehicle models (a simulated
trajectory must keep every wheel's residual at zero) and by a simulator to
measure slip. Velocities are in the world frame (m/s), headings in rad.

Sign conventions follow the seed: the lateral (no-slip) constraint of a wheel
whose plane has heading ``θ`` is ``ẋ sinθ − ẏ cosθ = 0`` and the rolling
constraint is ``ẋ cosθ + ẏ sinθ − r α̇ = 0`` (seed 003 §3.2.1).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def point_velocity(pose: ArrayLike, pose_dot: ArrayLike, offset: ArrayLike) -> FloatArray:
    """World velocity ``(..., 2)`` of a body point ``offset (..., 2)`` (m) of a rigid body.

    ``V_P = V_O + ω ∧ l`` ([seed003 §3.2.2] [seed003 §3.2.4]), with ``pose (..., 3)`` and
    ``pose_dot (..., 3)`` = ``[ẋ, ẏ, θ']`` of the body reference point O.
    """
    pose = np.asarray(pose, dtype=np.float64)
    qd = np.asarray(pose_dot, dtype=np.float64)
    off = np.asarray(offset, dtype=np.float64)
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    lx = c * off[..., 0] - s * off[..., 1]
    ly = s * off[..., 0] + c * off[..., 1]
    return np.stack([qd[..., 0] - qd[..., 2] * ly, qd[..., 1] + qd[..., 2] * lx], axis=-1)


def lateral_residual(velocity: ArrayLike, wheel_heading: ArrayLike) -> FloatArray:
    """No-slip residual ``ẋ sinθ − ẏ cosθ`` (m/s) of a wheel contact [seed003 §3.2.1]."""
    v = np.asarray(velocity, dtype=np.float64)
    th = np.asarray(wheel_heading, dtype=np.float64)
    return v[..., 0] * np.sin(th) - v[..., 1] * np.cos(th)


def rolling_residual(velocity: ArrayLike, wheel_heading: ArrayLike, spin_rate: ArrayLike, radius: float) -> FloatArray:
    """Pure-rolling residual ``ẋ cosθ + ẏ sinθ − r α̇`` (m/s) [seed003 §3.2.1]."""
    v = np.asarray(velocity, dtype=np.float64)
    th = np.asarray(wheel_heading, dtype=np.float64)
    return v[..., 0] * np.cos(th) + v[..., 1] * np.sin(th) - radius * np.asarray(spin_rate, dtype=np.float64)


def fixed_wheel_residual(pose: ArrayLike, pose_dot: ArrayLike, mount: ArrayLike) -> FloatArray:
    """No-slip residual (m/s) of a fixed standard wheel mounted on a rigid body.

    Parameters
    ----------
    pose, pose_dot : (..., 3) body pose and its time derivative.
    mount : (..., 3) wheel contact ``[x_b, y_b, β]`` in the body frame (m, m, rad);
        ``β`` is the wheel-plane heading relative to the body x-axis.

    [seed003 §3.2.1] with the contact velocity from ``V_P = V_O + ω ∧ l``.
    """
    mount = np.asarray(mount, dtype=np.float64)
    vel = point_velocity(pose, pose_dot, mount[..., :2])
    return lateral_residual(vel, np.asarray(pose, dtype=np.float64)[..., 2] + mount[..., 2])


def steered_wheel_residual(
    pose: ArrayLike, pose_dot: ArrayLike, position: ArrayLike, steer: ArrayLike
) -> FloatArray:
    """No-slip residual (m/s) of a steered standard wheel at body ``position (..., 2)``, steer angle ``steer (...)``.

    The steering axis passes through the contact point, so only the plane
    heading ``θ + steer`` changes ([seed003 §3.2.5], second constraint).
    """
    vel = point_velocity(pose, pose_dot, position)
    return lateral_residual(vel, np.asarray(pose, dtype=np.float64)[..., 2] + np.asarray(steer, dtype=np.float64))


def castor_wheel_residual(
    axis_velocity: ArrayLike, castor_heading: ArrayLike, castor_heading_rate: ArrayLike, offset: float
) -> FloatArray:
    """No-slip residual (m/s) of a castor wheel [seed003 §3.2.2].

    ``ẋ sinθ − ẏ cosθ + l θ̇ = 0`` where ``(ẋ, ẏ)`` is the world velocity of the
    steering-axis point, ``θ`` the wheel-plane heading (world) and ``l`` the
    trailing offset (m) from the steering axis back to the contact point.
    """
    th_dot = np.asarray(castor_heading_rate, dtype=np.float64)
    return lateral_residual(axis_velocity, castor_heading) + offset * th_dot


def castor_heading_rate(axis_velocity: ArrayLike, castor_heading: ArrayLike, offset: float) -> FloatArray:
    """Heading rate (rad/s) a free castor takes so its residual is zero: ``θ̇ = −(ẋ sinθ − ẏ cosθ)/l``."""
    if offset <= 0.0:
        raise ValueError(f"castor offset must be > 0, got {offset!r}")
    return -lateral_residual(axis_velocity, castor_heading) / offset


def swedish_wheel_residual(
    velocity: ArrayLike, wheel_heading: ArrayLike, spin_rate: ArrayLike, radius: float, roller_angle: float
) -> FloatArray:
    """Residual (m/s) of the one constraint of a Swedish (mecanum/omni) wheel [seed003 §3.2.3].

    The contact velocity minus the part produced by the wheel spin,
    ``v − r α̇ e``, must lie along the free-rolling direction of the rollers
    (at ``roller_angle`` from the wheel plane, π/2 for the seed's 90° wheel,
    ±π/4 for mecanum). The residual is its component across that direction.
    For ``roller_angle = π/2`` this is the seed's rolling equation
    ``ẋ cosθ + ẏ sinθ − α̇ r = 0``; the seed's other equation only fixes the
    roller rate ``β̇`` and constrains nothing, so a Swedish wheel removes one
    degree of freedom, not two.
    """
    v = np.asarray(velocity, dtype=np.float64)
    th = np.asarray(wheel_heading, dtype=np.float64)
    spin = radius * np.asarray(spin_rate, dtype=np.float64)
    rel_x = v[..., 0] - spin * np.cos(th)
    rel_y = v[..., 1] - spin * np.sin(th)
    free = th + roller_angle
    # Component across the free direction f = (cos, sin): f⊥ = (sin, −cos) scaled so that π/2 gives the seed's form.
    return rel_x * np.sin(free) - rel_y * np.cos(free)
