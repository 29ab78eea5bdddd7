"""Scalar fast paths of the kinematic kernels for one vehicle stepped in a hot loop.

A closed-loop simulator steps one vehicle at a time on 3- and 4-vectors, where
NumPy's per-call overhead (~1 us per ufunc) dominates. The functions below redo
*the same equations* as the vectorised kernels with the ``math`` module; each names
the kernel it mirrors and ``tests/kinematics/test_kinematics_fast.py`` checks it against that
kernel to 1e-12. The kernels stay the reference and serve every batch use.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

Rate4 = tuple[float, float, float, float]


def stacker_rate(psi: float, gamma: float, v: float, gamma_dot: float, wheelbase: float) -> Rate4:
    """``d/dt [x_O, y_O, psi, gamma]`` of the stacker [seed000 eq8]: speed ``v`` of C (m/s), L (m)."""
    cg = v * math.cos(gamma)
    return cg * math.cos(psi), cg * math.sin(psi), v * math.sin(gamma) / wheelbase, gamma_dot


def stacker_rk4(
    state: Sequence[float], v: float, gamma_dot: float, wheelbase: float, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One classical RK4 step of the stacker [seed000 eq8] in scalar ``math``.

    Mirrors :meth:`agvnav.kinematics.TricycleStacker.step` with one RK4 sub-step
    (``substeps = 1``). ``state`` is ``[x_O, y_O, psi, gamma]`` (m, rad), ``v`` the
    speed of C (m/s), ``gamma_dot`` the steering rate (rad/s), held for ``dt`` s.
    Returns the new state ``(4,)`` and the state derivatives at the start and at the
    end of the step ``(2, 4)`` (for a Hermite interpolation inside the step).
    """
    new, k1, end = stacker_rk4_values(state, v, gamma_dot, wheelbase, dt)
    return np.array(new), np.array([k1, end])


def stacker_rk4_values(
    state: Sequence[float], v: float, gamma_dot: float, wheelbase: float, dt: float
) -> tuple[Rate4, Rate4, Rate4]:
    """:func:`stacker_rk4` as plain floats: ``(new state, derivative at the start, derivative at the end)``.

    The same arithmetic (it is :func:`stacker_rk4`'s body); for the truth plant, which steps
    one vehicle per control step and builds its own arrays (issue 11).
    """
    x, y, psi, g = (float(c) for c in state)
    h = dt
    k1 = stacker_rate(psi, g, v, gamma_dot, wheelbase)
    k2 = stacker_rate(psi + 0.5 * h * k1[2], g + 0.5 * h * k1[3], v, gamma_dot, wheelbase)
    k3 = stacker_rate(psi + 0.5 * h * k2[2], g + 0.5 * h * k2[3], v, gamma_dot, wheelbase)
    k4 = stacker_rate(psi + h * k3[2], g + h * k3[3], v, gamma_dot, wheelbase)
    h6 = h / 6.0
    new = (
        x + h6 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
        y + h6 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
        psi + h6 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]),
        g + h6 * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3]),
    )
    return new, k1, stacker_rate(new[2], new[3], v, gamma_dot, wheelbase)


def track_twist(
    v_right: float, v_left: float, twist_matrix: Sequence[Sequence[float]]
) -> tuple[float, float, float]:
    """Body twist ``(v_x, v_y, omega)`` (m/s, rad/s) of a tracked base for track speeds (m/s).

    Mirrors :meth:`agvnav.kinematics.TrackedVehicle.body_twist`: the ICR model's
    ``twist_matrix`` ``T (3, 2)`` (as nested floats) applied to ``[v_R, v_L]``.
    """
    t0, t1, t2 = twist_matrix[0], twist_matrix[1], twist_matrix[2]
    return (
        t0[0] * v_right + t0[1] * v_left,
        t1[0] * v_right + t1[1] * v_left,
        t2[0] * v_right + t2[1] * v_left,
    )
