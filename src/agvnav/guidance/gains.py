"""Gain design for the seed-000 guidance laws from closed-loop poles per metre travelled.

Error dynamics (seed 000 §3.2). Linearised, eqs 14-16 read
``eps_c' = v xi_r``, ``eps_o' = v xi``, ``xi' = (v/L) gamma``; with the
general law eq. 11, ``gamma' = -a eps_o - b xi - c gamma``, and ``q = eps_o``:
``q' = v xi``, ``q'' = (v^2/L) gamma``, ``q''' = (v^2/L) gamma'
= -(v^2/L) a q - (v/L) b q' - c q''``, i.e.::

    q''' + c q'' + (v/L) b q' + (v^2/L) a q = 0          (eq. 17)

The extracted text of eq. 17 is garbled (it shows ``q''`` as leading term);
the derivation above, repeated for eps_c, xi, xi_r and gamma (all linear
combinations of eps_o and its derivatives), confirms the third-order form.
Routh-Hurwitz on ``s^3 + c s^2 + (v b/L) s + v^2 a/L`` gives ``c > 0``,
``v b > 0``, ``a > 0`` and ``c (v b / L) > v^2 a / L``, i.e. eqs 18 (v > 0) and 19
(v < 0): the sign of b must follow the direction of travel.

Poles per metre. Writing the dynamics against the distance travelled
``sigma = |v| t`` makes the poles ``lambda_i = p_i / |v|`` (1/m) independent of
speed; then ``c = |v| e1``, ``b = L v e2``, ``a = L |v| e3`` where
``prod(s - lambda_i) = s^3 + e1 s^2 + e2 s + e3``. The convergence distance
stays fixed and a, b, c scale with v.

Simple law (seed 000 §3.3, eq. 23): ``q'' + b q' + a v q = 0`` for
``q = eps_c, xi_r``; with poles per metre ``mu_i``: ``b = v f1``, ``a = v f2``
where ``prod(s - mu_i) = s^2 + f1 s + f2``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_positive

__all__ = [
    "GeneralGains",
    "SimpleGains",
    "SETTLING_FRACTION",
    "poles_for_convergence",
    "convergence_distance",
    "general_gains",
    "general_gains_from_coefficients",
    "characteristic_coefficients",
    "general_characteristic",
    "routh_hurwitz_ok",
    "check_routh_hurwitz",
    "simple_gains",
    "simple_characteristic",
    "check_simple_stability",
]

SETTLING_FRACTION = 0.02
"""The convergence distance is where the slowest mode has decayed to 2 % of its start."""


@dataclass(frozen=True)
class GeneralGains:
    """Gains of the general law (seed 000 eqs 11-13): a (1/(m s)), b (1/s, sign of v), c (1/s)."""

    a: float
    b: float
    c: float


@dataclass(frozen=True)
class SimpleGains:
    """Gains a (1/(m s)) and b (1/s) of the simple law (seed 000 eqs 20-22)."""

    a: float
    b: float


def poles_for_convergence(
    distance: float, damping: float = 1.0 / math.sqrt(2.0), order: int = 3, real_ratio: float = 1.0
) -> NDArray[np.complex128]:
    """Closed-loop poles per metre (1/m) converging within ``distance`` (m).

    As the seed chooses (§3.2), one real pole and a complex pair (``order=3``),
    or only the pair (``order=2``, simple law). The pair has damping ratio
    ``damping`` and real part ``-sigma`` with ``sigma = ln(1/0.02) / distance``;
    the real pole is ``-real_ratio * sigma``.
    """
    d = require_positive("distance", distance)
    if not (0.0 < damping <= 1.0):
        raise ValueError(f"damping must be in (0, 1], got {damping!r}")
    if order not in (2, 3):
        raise ValueError(f"order must be 2 or 3, got {order!r}")
    sigma = math.log(1.0 / SETTLING_FRACTION) / d
    omega_d = sigma * math.sqrt(1.0 - damping**2) / damping
    pair = [complex(-sigma, omega_d), complex(-sigma, -omega_d)]
    if order == 2:
        return np.array(pair)
    return np.array([complex(-require_positive("real_ratio", real_ratio) * sigma, 0.0), *pair])


def convergence_distance(poles_per_m: ArrayLike) -> float:
    """Distance (m) for the slowest mode of ``poles_per_m`` (1/m) to decay to 2 %; inf if unstable."""
    p = np.asarray(poles_per_m, dtype=np.complex128)
    sigma = -float(np.max(p.real))
    return math.log(1.0 / SETTLING_FRACTION) / sigma if sigma > 0 else math.inf


def _monic_real(poles: ArrayLike, order: int) -> NDArray[np.float64]:
    p = np.asarray(poles, dtype=np.complex128).ravel()
    if p.size != order:
        raise ValueError(f"poles_per_m must hold {order} poles, got {p.size}")
    if not np.all(np.isfinite(p)):
        raise ValueError("poles_per_m contains NaN or inf")
    coeffs = np.poly(p)
    if np.max(np.abs(coeffs.imag)) > 1e-9 * max(1.0, float(np.max(np.abs(coeffs)))):
        raise ValueError("poles_per_m must be real or come in complex-conjugate pairs")
    if np.any(p.real >= 0.0):
        raise ValueError(f"poles_per_m must all have negative real parts, got {p}")
    return coeffs.real


def characteristic_coefficients(poles_per_m: ArrayLike, order: int) -> NDArray[np.float64]:
    """Real coefficients ``[1, e1, ..., e_order]`` of ``prod(s - lambda_i)`` for poles per metre (1/m).

    Raises ValueError unless there are ``order`` finite poles, real or in
    conjugate pairs, all with negative real parts.
    """
    return _monic_real(poles_per_m, order)


def general_gains_from_coefficients(coeffs: NDArray[np.float64], v: float, wheelbase: float) -> GeneralGains:
    """``c = |v| e1``, ``b = L v e2``, ``a = L |v| e3`` from ``coeffs = [1, e1, e2, e3]`` (module docstring)."""
    _, e1, e2, e3 = coeffs
    return GeneralGains(a=wheelbase * abs(v) * e3, b=wheelbase * v * e2, c=abs(v) * e1)


def general_gains(poles_per_m: ArrayLike, v: float, wheelbase: float) -> GeneralGains:
    """a, b, c of the general law placing the eq.-17 poles at ``poles_per_m`` (1/m) at speed ``v`` (m/s).

    ``c = |v| e1``, ``b = L v e2``, ``a = L |v| e3`` (module docstring). At
    ``v = 0`` all gains are 0 (nothing moves, nothing to correct).
    """
    L = require_positive("wheelbase", wheelbase)
    return general_gains_from_coefficients(_monic_real(poles_per_m, 3), float(v), L)


def general_characteristic(a: float, b: float, c: float, v: float, wheelbase: float) -> NDArray[np.float64]:
    """Coefficients ``[1, c, v b / L, v^2 a / L]`` of eq. 17's characteristic polynomial (time domain)."""
    L = require_positive("wheelbase", wheelbase)
    return np.array([1.0, c, v * b / L, v * v * a / L])


def routh_hurwitz_ok(a: ArrayLike, b: ArrayLike, c: ArrayLike, v: ArrayLike) -> NDArray[np.bool_]:
    """Vectorised Routh-Hurwitz test of eq. 17 (seed 000 eqs 18-19); False at v = 0."""
    a, b, c, v = (np.asarray(x, dtype=np.float64) for x in (a, b, c, v))
    return (a > 0) & (c > 0) & (v * b > 0) & (c * np.abs(b) > np.abs(v) * a)


def check_routh_hurwitz(a: float, b: float, c: float, v: float) -> None:
    """Raise ValueError naming the violated condition of seed 000 eq. 18 (v > 0) or 19 (v < 0)."""
    if v == 0:
        raise ValueError("Routh-Hurwitz check needs v != 0 (eq. 17 degenerates at standstill)")
    eq = "18" if v > 0 else "19"
    if not a > 0:
        raise ValueError(f"unstable guidance gains: a = {a:g} must be > 0 (seed 000 eq. {eq})")
    if not c > 0:
        raise ValueError(f"unstable guidance gains: c = {c:g} must be > 0 (seed 000 eq. {eq})")
    if not v * b > 0:
        need = "> 0 for v > 0" if v > 0 else "< 0 for v < 0"
        raise ValueError(f"unstable guidance gains: b = {b:g} must be {need} (seed 000 eq. {eq})")
    if not abs(b) * c / a > abs(v):
        raise ValueError(
            f"unstable guidance gains: |b| c / a = {abs(b) * c / a:g} m/s must exceed |v| = {abs(v):g} m/s "
            f"(seed 000 eq. {eq})"
        )


def simple_gains(poles_per_m: ArrayLike, v: float) -> SimpleGains:
    """a, b of the simple law placing the eq.-23 poles at ``poles_per_m`` (1/m) for ``v`` > 0 (m/s)."""
    if v < 0:
        raise ValueError(f"the simple law is for v > 0 (seed 000 §3.3), got v = {v:g} m/s")
    _, f1, f2 = _monic_real(poles_per_m, 2)
    return SimpleGains(a=float(v) * f2, b=float(v) * f1)


def simple_characteristic(a: float, b: float, v: float) -> NDArray[np.float64]:
    """Coefficients ``[1, b, a v]`` of eq. 23's characteristic polynomial (time domain)."""
    return np.array([1.0, b, a * v])


def check_simple_stability(a: float, b: float, v: float) -> None:
    """Raise ValueError unless v > 0 and a, b > 0 (seed 000 §3.3, stability of eq. 23 and 24)."""
    if not v > 0:
        raise ValueError(
            f"the simple law is stable only for v > 0 (seed 000 §3.3); got v = {v:g} m/s: use the general law"
        )
    if not (a > 0 and b > 0):
        raise ValueError(f"unstable simple-law gains: need a > 0 and b > 0 (seed 000 eq. 23), got a={a:g}, b={b:g}")
