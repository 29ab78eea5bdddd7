"""Baseline guidance laws on the seed-000 tricycle: pure pursuit and Stanley.

Both are geometric laws that give a *steering-angle target*; the tricycle's
guidance output is a steering *rate* (seed 000 §3.2), so the target goes
through a first-order steering servo ``gamma' = (gamma_target - gamma) / tau``
(:func:`servo_rate`). With ``tau`` small against the time to travel the
convergence distance the servo barely changes the geometric law's behaviour.

Pure functions over NumPy arrays; the stateful controllers live in
:mod:`agvnav.guidance.controller`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry.angles import wrap_angle, wrap_angle_scalar

__all__ = [
    "MAX_STEERING_RAD",
    "lookahead_for_distance",
    "pure_pursuit_steering",
    "servo_rate",
    "stanley_gain_for_distance",
    "stanley_steering",
]

MAX_STEERING_RAD = math.radians(89.0)
"""Steering targets are clipped to +/- 89 deg: the seed's wheel turns within (-90, 90) deg."""

_LN50 = math.log(50.0)


def servo_rate(gamma_target: ArrayLike, gamma: ArrayLike, tau: float) -> NDArray[np.float64] | float:
    """First-order steering servo: ``gamma' = (gamma_target - gamma) / tau`` (rad/s), ``tau`` in s."""
    if not (math.isfinite(tau) and tau > 0.0):
        raise ValueError(f"servo time constant tau must be a positive finite number (s), got {tau!r}")
    if isinstance(gamma_target, float) and isinstance(gamma, float):
        return (gamma_target - gamma) / tau
    return (np.asarray(gamma_target, dtype=np.float64) - np.asarray(gamma, dtype=np.float64)) / tau


def pure_pursuit_steering(
    beta: ArrayLike, lookahead: float, wheelbase: float, point: str = "O", direction: ArrayLike = 1
) -> NDArray[np.float64] | float:
    """Pure-pursuit steering target (rad) (Coulter 1992) on the seed-000 tricycle.

    ``beta`` (rad): bearing of the look-ahead point G, at arclength ``lookahead``
    (m) ahead of the tracked point P along the path, measured from the body's
    direction of motion (psi, or psi + pi in reverse). The arc through P,
    tangent to P's velocity and through G, has curvature
    ``kappa = 2 sin(alpha) / lookahead`` with alpha the bearing from P's
    velocity. From [seed000 eq8] (see :mod:`agvnav.guidance.errors`):

    * P = O (velocity along the body): ``alpha = beta``,
      ``tan(gamma) = d L kappa`` -> ``gamma = atan(2 d L sin(beta) / l)``;
    * P = C (velocity along the wheel): ``alpha = beta - gamma``,
      ``sin(gamma) = d L kappa``; solving for gamma gives
      ``gamma = atan2(2 d L sin(beta), l + 2 d L cos(beta))``.

    ``d`` = direction of travel (+1/-1). Clipped to +/- :data:`MAX_STEERING_RAD`.
    """
    if not (math.isfinite(lookahead) and lookahead > 0.0):
        raise ValueError(f"lookahead must be a positive finite distance (m), got {lookahead!r}")
    if point not in ("O", "C"):
        raise ValueError(f"point must be 'O' or 'C', got {point!r}")
    if isinstance(beta, float) and isinstance(direction, int):  # controllers' fast path
        k2 = 2.0 * direction * wheelbase
        if point == "O":
            g = math.atan(k2 * math.sin(beta) / lookahead)
        else:
            g = math.atan2(k2 * math.sin(beta), lookahead + k2 * math.cos(beta))
        return min(max(g, -MAX_STEERING_RAD), MAX_STEERING_RAD)
    beta = np.asarray(beta, dtype=np.float64)
    k = 2.0 * np.asarray(direction, dtype=np.float64) * wheelbase
    if point == "O":
        gamma = np.arctan(k * np.sin(beta) / lookahead)
    else:
        gamma = np.arctan2(k * np.sin(beta), lookahead + k * np.cos(beta))
    return np.clip(wrap_angle(gamma), -MAX_STEERING_RAD, MAX_STEERING_RAD)


def stanley_steering(
    heading_error: ArrayLike, eps_c: ArrayLike, gain_per_m: float
) -> NDArray[np.float64] | float:
    """Stanley steering target (rad) (Thrun et al. 2006), front wheel = point C, v > 0.

    ``gamma = -heading_error - atan(k eps_c)`` where ``heading_error = psi -
    theta`` (rad) is the body heading minus the path tangent at C's projection
    and ``eps_c`` (m) the lateral error of C (left positive). The first term
    aligns the wheel with the path, the second steers towards it. Stanley's
    ``atan(k_t e / v)`` is written with ``k_t = k v`` so that the gain ``k``
    (1/m) fixes a convergence distance independent of speed: with the wheel
    on target, ``eps_c' = v sin(xi_r) = -v k eps_c / sqrt(1 + (k eps_c)^2)``.
    Clipped to +/- :data:`MAX_STEERING_RAD`.
    """
    if not (math.isfinite(gain_per_m) and gain_per_m > 0.0):
        raise ValueError(f"Stanley gain must be a positive finite number (1/m), got {gain_per_m!r}")
    if isinstance(heading_error, float) and isinstance(eps_c, float):  # controllers' fast path
        g = wrap_angle_scalar(-heading_error - math.atan(gain_per_m * eps_c))
        return min(max(g, -MAX_STEERING_RAD), MAX_STEERING_RAD)
    g = -np.asarray(heading_error, dtype=np.float64) - np.arctan(gain_per_m * np.asarray(eps_c, dtype=np.float64))
    return np.clip(wrap_angle(g), -MAX_STEERING_RAD, MAX_STEERING_RAD)


def lookahead_for_distance(distance: float) -> float:
    """Look-ahead (m) giving convergence within ``distance`` (m) for pure pursuit on O (ideal servo).

    Linearised on a line, ``eps'' + (2/l) eps' + (2/l^2) eps = 0`` per metre:
    poles ``(-1 +/- j) / l``, so the 2 % distance is ``l ln 50``.
    Refined with the servo by :func:`agvnav.guidance.controller.tune_for_convergence`.
    """
    if not (math.isfinite(distance) and distance > 0.0):
        raise ValueError(f"distance must be a positive finite number (m), got {distance!r}")
    return distance / _LN50


def stanley_gain_for_distance(distance: float) -> float:
    """Stanley gain (1/m) giving convergence within ``distance`` (m) (ideal servo).

    Linearised: ``eps' = -k eps`` per metre, pole ``-k``; 2 % at ``ln 50 / k``.
    """
    if not (math.isfinite(distance) and distance > 0.0):
        raise ValueError(f"distance must be a positive finite number (m), got {distance!r}")
    return _LN50 / distance
