"""The interface every vehicle model shares, and the integration kernels they reuse.

A model maps a state ``(..., n)`` and an input ``(..., m)`` to the state
derivative ``(..., n)``; everything is vectorised over leading batch dimensions.
Two layers (see ``agvnav.kinematics``):

* the public methods ``derivative``, ``jacobian_state``, ``jacobian_input`` and
  ``step`` validate: a wrong trailing length, NaN/inf, ``dt <= 0`` or a limit
  violated (before *or after* the step) raises a ``ValueError`` naming the
  state/input variable, never a silent NaN;
* the ``*_unchecked`` kernels (``derivative_unchecked``, ``step_unchecked``, ...)
  do no checking at all, so a batch of 10,000 vehicles steps in one NumPy call;
  pair them with ``input_valid``/``state_valid`` to flag bad batch elements.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import as_float_array, require_last_dim
from agvnav.kinematics.twist import twist_steps

FloatArray = NDArray[np.float64]


def twist_step(
    pose: ArrayLike, v_x: ArrayLike, v_y: ArrayLike, omega: ArrayLike, dt: float | FloatArray
) -> FloatArray:
    """Exact pose after moving with a constant body twist for ``dt`` seconds.

    Parameters
    ----------
    pose : (..., 3) ``[x, y, heading]`` (m, m, rad).
    v_x, v_y : (...) body-frame velocity of the reference point (m/s).
    omega : (...) yaw rate (rad/s).
    dt : time step (s), a float or ``(...)`` broadcast with the twist.

    Returns
    -------
    (..., 3) new pose; the heading is not wrapped (integrators keep it continuous).

    Notes
    -----
    The SE(2) exponential. With ``v_y = 0`` it is the exact arc [seed002 eq25]: the chord
    ``ΔD·sin(Δθ/2)/(Δθ/2)`` [seed002 eq23] [seed002 eq24] along the mid heading; a series
    expansion is used for ``|Δθ/2| < 1e-4`` so straight lines lose no precision. The equation's
    one form is the compiled kernel :func:`agvnav.kinematics.twist.twist_pose`; this is its
    broadcasting wrapper (:func:`~agvnav.kinematics.twist.twist_steps`).
    """
    pose = np.asarray(pose, dtype=np.float64)
    if pose.shape[-1:] != (3,):
        raise ValueError(f"pose must have a trailing length of 3, got shape {pose.shape}")
    parts = np.broadcast_arrays(pose[..., 0], *(np.asarray(a, dtype=np.float64) for a in (v_x, v_y, omega, dt)))
    shape = parts[0].shape
    flat = [np.ascontiguousarray(a).reshape(-1) for a in parts[1:]]
    start = np.ascontiguousarray(np.broadcast_to(pose, (*shape, 3))).reshape(-1, 3)
    return np.asarray(twist_steps(start, *flat), dtype=np.float64).reshape(*shape, 3)


def rk4_step(
    f: Callable[[FloatArray, FloatArray], FloatArray], state: FloatArray, u: FloatArray, dt: float, substeps: int = 1
) -> FloatArray:
    """Classical fourth-order Runge-Kutta over ``dt`` with ``substeps`` equal sub-steps, input held."""
    x = np.asarray(state, dtype=np.float64)
    h = dt / substeps
    for _ in range(substeps):
        k1 = f(x, u)
        k2 = f(x + 0.5 * h * k1, u)
        k3 = f(x + 0.5 * h * k2, u)
        k4 = f(x + h * k3, u)
        x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return x


def numerical_jacobian(
    f: Callable[[FloatArray], FloatArray], x: ArrayLike, eps: float = 1e-6
) -> FloatArray:
    """Central-difference Jacobian ``(..., p, q)`` of ``f: (..., q) -> (..., p)`` (tests and checks)."""
    x = np.asarray(x, dtype=np.float64)
    cols = []
    for j in range(x.shape[-1]):
        d = np.zeros(x.shape[-1])
        d[j] = eps
        cols.append((f(x + d) - f(x - d)) / (2.0 * eps))
    return np.stack(cols, axis=-1)


class KinematicModel(ABC):
    """Common interface of every vehicle model (docs/ARCHITECTURE.md, kinematics).

    Subclasses define ``state_names``, ``input_names``, ``derivative`` and the
    two Jacobians; ``step`` defaults to sub-stepped RK4 and is overridden where
    a closed form exists. ``n_config`` and ``constraint_matrix`` give the
    Pfaffian constraints ``A(q)·q' = 0`` of seed 003 §3.2, so the degrees of
    freedom are ``n_config - n_constraints``.
    """

    state_names: tuple[str, ...] = ()
    input_names: tuple[str, ...] = ()
    #: RK4 sub-steps used by the default ``step``.
    substeps: int = 4

    @property
    def n_state(self) -> int:
        """Length of the state vector."""
        return len(self.state_names)

    @property
    def n_input(self) -> int:
        """Length of the input vector."""
        return len(self.input_names)

    @property
    def dof(self) -> int:
        """Degrees of freedom as seed 003 counts them: configuration variables minus constraints."""
        return self.n_state - self.n_constraints

    @property
    def n_constraints(self) -> int:
        """Number of independent non-holonomic constraints (rows of ``constraint_matrix``)."""
        return 0

    def constraint_matrix(self, state: ArrayLike) -> FloatArray:
        """Pfaffian constraint matrix ``A (..., k, n)`` with ``A·state' = 0`` (seed 003 §3.2)."""
        state = np.asarray(state, dtype=np.float64)
        return np.zeros(state.shape[:-1] + (0, self.n_state))

    # ------------------------------------------------- kernels (no checking)
    @abstractmethod
    def derivative_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """Kernel of ``derivative``: no validation (hot loops, batches pre-flagged with ``input_valid``)."""

    @abstractmethod
    def jacobian_state_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """Kernel of ``jacobian_state``: no validation."""

    @abstractmethod
    def jacobian_input_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """Kernel of ``jacobian_input``: no validation."""

    def step_unchecked(self, state: ArrayLike, u: ArrayLike, dt: float) -> FloatArray:
        """Kernel of ``step``: RK4 with ``substeps`` sub-steps, input held, no validation and no limits."""
        return rk4_step(self.derivative_unchecked, np.asarray(state, np.float64), np.asarray(u, np.float64), dt,
                        self.substeps)

    # ------------------------------------------------- validated public API
    def derivative(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """State derivative ``(..., n)`` for state ``(..., n)`` and input ``(..., m)``.

        Raises ValueError naming ``state``/``u`` (wrong trailing length) or the variable (NaN/inf).
        """
        return self.derivative_unchecked(*self._finite_pair(state, u))

    def jacobian_state(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂derivative/∂state``, shape ``(..., n, n)`` (validated like ``derivative``)."""
        return self.jacobian_state_unchecked(*self._finite_pair(state, u))

    def jacobian_input(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂derivative/∂u``, shape ``(..., n, m)`` (validated like ``derivative``)."""
        return self.jacobian_input_unchecked(*self._finite_pair(state, u))

    def step(self, state: ArrayLike, u: ArrayLike, dt: float) -> FloatArray:
        """State after ``dt`` s with the input held: the validated API path.

        Checks the shapes, finiteness and limits of ``state`` and ``u``, that ``dt`` is a positive
        finite number, and the resulting state: a step that ends beyond a state limit (e.g. a
        steering angle pushed past ``max_steer`` by an unlimited steering rate) raises ValueError
        rather than clamping, because clamping would silently change the commanded motion.
        Use ``step_unchecked`` in hot loops.
        """
        dt = _check_dt(dt)
        new = self.step_unchecked(self.check_state(state), self.check_input(u), dt)
        try:
            return self.check_state(new)
        except ValueError as exc:
            raise ValueError(f"after a step of dt={dt!r} s: {exc}") from None

    def _finite_pair(self, state: ArrayLike, u: ArrayLike) -> tuple[FloatArray, FloatArray]:
        state = require_last_dim("state", as_float_array("state", state), self.n_state)
        u = require_last_dim("u", as_float_array("u", u), self.n_input)
        _raise_nonfinite(state, self.state_names, "state")
        _raise_nonfinite(u, self.input_names, "input")
        return state, u

    # ------------------------------------------------------------------ checks
    def input_violations(self, u: FloatArray) -> list[tuple[str, NDArray[np.bool_]]]:
        """Per-limit masks ``(name, bad (...))`` of inputs beyond the model's limits."""
        return []

    def state_violations(self, state: FloatArray) -> list[tuple[str, NDArray[np.bool_]]]:
        """Per-limit masks ``(name, bad (...))`` of states beyond the model's limits."""
        return []

    def input_valid(self, u: ArrayLike) -> NDArray[np.bool_]:
        """Batch flag ``(...)``: True where the input is finite and within limits (never raises on values)."""
        u = require_last_dim("u", as_float_array("u", u), self.n_input)
        ok = np.all(np.isfinite(u), axis=-1)
        with np.errstate(invalid="ignore"):
            for _, bad in self.input_violations(u):
                ok &= ~bad
        return ok

    def state_valid(self, state: ArrayLike) -> NDArray[np.bool_]:
        """Batch flag ``(...)``: True where the state is finite and within limits (never raises on values)."""
        state = require_last_dim("state", as_float_array("state", state), self.n_state)
        ok = np.all(np.isfinite(state), axis=-1)
        with np.errstate(invalid="ignore"):
            for _, bad in self.state_violations(state):
                ok &= ~bad
        return ok

    def check_input(self, u: ArrayLike) -> FloatArray:
        """Return ``u`` as float ``(..., m)``; ValueError naming the input if bad shape, NaN or beyond a limit."""
        u = require_last_dim("u", as_float_array("u", u), self.n_input)
        _raise_nonfinite(u, self.input_names, "input")
        for name, bad in self.input_violations(u):
            if np.any(bad):
                raise ValueError(f"{type(self).__name__}: {name} beyond its limit")
        return u

    def check_state(self, state: ArrayLike) -> FloatArray:
        """Return ``state`` as float ``(..., n)``; ValueError naming the variable if bad shape, NaN or out of range."""
        state = require_last_dim("state", as_float_array("state", state), self.n_state)
        _raise_nonfinite(state, self.state_names, "state")
        for name, bad in self.state_violations(state):
            if np.any(bad):
                raise ValueError(f"{type(self).__name__}: {name} beyond its limit")
        return state

    def checked_step(self, state: ArrayLike, u: ArrayLike, dt: float) -> FloatArray:
        """Alias of ``step`` (kept for callers of the earlier API; ``step`` now validates)."""
        return self.step(state, u, dt)


def _check_dt(dt: float) -> float:
    try:
        value = float(dt)
    except (TypeError, ValueError):
        raise ValueError(f"dt must be a positive finite number, got {dt!r}") from None
    if not np.isfinite(value) or value <= 0.0:
        raise ValueError(f"dt must be a positive finite number, got {dt!r}")
    return value


def _raise_nonfinite(arr: FloatArray, names: tuple[str, ...], what: str) -> None:
    finite = np.isfinite(arr)
    if not np.all(finite):
        bad = [names[j] for j in range(arr.shape[-1]) if not np.all(finite[..., j])]
        raise ValueError(f"{what} {', '.join(bad)} contains NaN or inf")


def scalar_inputs_or_flag(
    angles: dict[str, ArrayLike] | None = None, **values: ArrayLike
) -> tuple[list[FloatArray], NDArray[np.bool_]]:
    """Convert the inputs of a free kinematics function; validate the scalar path, flag the batch path.

    ``values`` are finite quantities; ``angles`` (rad) must also satisfy ``|angle| < π/2``.
    When every input is a scalar (0-d), a NaN/inf or an angle at/beyond ±90° raises a ValueError
    naming it. Otherwise returns the arrays and a broadcast ``ok`` mask; the caller writes NaN
    into the elements where ``ok`` is False (the batch flag), leaving neighbours untouched.
    """
    angles = angles or {}
    arrays = {name: as_float_array(name, v) for name, v in {**values, **angles}.items()}
    ok = np.ones(np.broadcast_shapes(*(a.shape for a in arrays.values())), dtype=bool)
    for name, a in arrays.items():
        with np.errstate(invalid="ignore"):
            bad = ~np.isfinite(a) | ((np.abs(a) >= np.pi / 2) if name in angles else False)
        if np.any(bad) and ok.ndim == 0:
            what = "NaN or inf" if not np.all(np.isfinite(a)) else f"|{name}| >= pi/2 rad"
            raise ValueError(f"{name} must be finite" + ("" if name not in angles else " with |angle| < pi/2 rad")
                             + f", got {float(a)!r} ({what})")
        ok = ok & ~bad
    return [arrays[n] for n in (*values, *angles)], ok


def check_angle_limit(name: str, value: float, upper: float = np.pi / 2) -> float:
    """Validate a steering limit: finite, in ``(0, upper]`` rad."""
    v = float(value)
    if not np.isfinite(v) or v <= 0.0 or v > upper:
        raise ValueError(f"{name} must be in (0, {upper:.6g}] rad, got {value!r}")
    return v


def check_rate_limit(name: str, value: float) -> float:
    """Validate a rate limit: > 0, ``inf`` allowed (no limit)."""
    v = float(value)
    if np.isnan(v) or v <= 0.0:
        raise ValueError(f"{name} must be > 0 (inf for no limit), got {value!r}")
    return v
