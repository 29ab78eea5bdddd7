"""A tiny closed loop for the guidance tests: the truth stacker plant driven by a controller at a fixed step.

Local helper: the simulator package wires the full loop; these tests only need the
nonlinear tricycle (seed 000 eq. 8) with an ideal steering servo (no lag, no rate
limit) and no odometry errors, which is :class:`agvnav.vehicles.TricyclePlant` so
configured. ``rk4_step``/``tricycle_derivative`` are the kinematic model's own
kernels (:class:`agvnav.kinematics.TricycleStacker`) for tests that step by hand.
"""

from __future__ import annotations

import math

import numpy as np

from agvnav.actuators import SteeringActuator
from agvnav.kinematics import TricycleStacker
from agvnav.odometry import TricycleErrors
from agvnav.vehicles import TricyclePlant


def tricycle_derivative(state: np.ndarray, v: float, gamma_dot: float, wheelbase: float) -> np.ndarray:
    """Seed 000 eq. 8 for state [x_O, y_O, psi, gamma] with v the speed of C."""
    return TricycleStacker(wheelbase).derivative_unchecked(state, [v, gamma_dot])


def rk4_step(state: np.ndarray, v: float, gamma_dot: float, wheelbase: float, dt: float) -> np.ndarray:
    """One step of the stacker model (RK4 while steering, the exact arc otherwise)."""
    return TricycleStacker(wheelbase).step_unchecked(np.asarray(state, dtype=float), [v, gamma_dot], dt)


def ideal_plant(state0, wheelbase: float) -> TricyclePlant:
    """The truth stacker with an ideal servo (no lag, 1e6 rad/s) and no systematic or random errors."""
    steering = SteeringActuator(max_angle=math.pi / 2, max_rate=1e6, tau=0.0)
    return TricyclePlant(wheelbase, 0.125, 1 << 20, 1 << 20, steering, TricycleErrors(), None, state0)


def run(controller, state0, v: float, wheelbase: float, distance: float, dt: float = 0.01, step=None):
    """Drive ``distance`` metres at speed v; returns (states (n+1, 4), errors dicts list, travelled (n,)).

    ``step(state, v, gamma_dot, dt)`` advances the vehicle (default: :func:`ideal_plant`).
    """
    state = np.asarray(state0, dtype=float)
    plant = ideal_plant(state, wheelbase) if step is None else None
    rng = np.random.default_rng(0)
    states, errs = [state], []
    n = round(distance / (abs(v) * dt))
    for k in range(n):
        u = controller.command(state[:3], state[3], v)
        errs.append(controller.last_errors.as_dict())
        if plant is None:
            state = step(state, v, u, dt)
        else:
            plant.advance((v, u), k * dt, dt, rng)
            state = plant.state
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
