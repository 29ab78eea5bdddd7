"""A tiny closed-loop integrator for the guidance tests (seed 000 eq. 8, RK4, zero-order hold).

Local helper: the simulator package builds the full loop; these tests only
need the nonlinear tricycle driven by a controller at a fixed step.
"""

from __future__ import annotations

import math

import numpy as np


def tricycle_derivative(state: np.ndarray, v: float, gamma_dot: float, wheelbase: float) -> np.ndarray:
    """Seed 000 eq. 8 for state [x_O, y_O, psi, gamma] with v the speed of C."""
    _, _, psi, gamma = state
    return np.array(
        [
            v * math.cos(gamma) * math.cos(psi),
            v * math.cos(gamma) * math.sin(psi),
            v * math.sin(gamma) / wheelbase,
            gamma_dot,
        ]
    )


def rk4_step(state: np.ndarray, v: float, gamma_dot: float, wheelbase: float, dt: float) -> np.ndarray:
    f = tricycle_derivative
    k1 = f(state, v, gamma_dot, wheelbase)
    k2 = f(state + 0.5 * dt * k1, v, gamma_dot, wheelbase)
    k3 = f(state + 0.5 * dt * k2, v, gamma_dot, wheelbase)
    k4 = f(state + dt * k3, v, gamma_dot, wheelbase)
    return state + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


def run(controller, state0, v: float, wheelbase: float, distance: float, dt: float = 0.01, step=None):
    """Drive ``distance`` metres at speed v; returns (states (n+1, 4), errors dicts list, travelled (n,)).

    ``step(state, v, gamma_dot, dt)`` advances the plant (default: RK4 of eq. 8 here).
    """
    state = np.asarray(state0, dtype=float)
    states, errs = [state], []
    n = int(round(distance / (abs(v) * dt)))
    for _ in range(n):
        u = controller.command(state[:3], state[3], v)
        errs.append(controller.last_errors.as_dict())
        state = rk4_step(state, v, u, wheelbase, dt) if step is None else step(state, v, u, dt)
        states.append(state)
    travelled = abs(v) * dt * np.arange(n)
    return np.array(states), errs, travelled


def assert_same_roots(actual, desired, atol: float) -> None:
    """Two sets of complex roots agree (order-free matching by nearest neighbour)."""
    a = np.asarray(actual, dtype=complex).ravel()
    d = list(np.asarray(desired, dtype=complex).ravel())
    assert a.size == len(d), (a, d)
    for x in a:
        j = int(np.argmin([abs(x - y) for y in d]))
        assert abs(x - d[j]) <= atol, (a, d)
        d.pop(j)
