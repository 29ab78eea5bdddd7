"""Seed-000 guidance laws: steering rate gamma' (rad/s) from the errors of Fig. 5.

Pure kernels, vectorised over the batch. Errors are those of
:mod:`agvnav.guidance.errors`, taken relative to the curvature feed-forward:
``dgamma = gamma - gamma_ss`` replaces the seed's ``gamma`` (on a line
``gamma_ss = 0`` and the laws are exactly the seed's). Since ``gamma_ss`` is
constant along a segment, the steady turn (all errors zero, ``dgamma = 0``)
is an equilibrium of the closed loop: zero steady-state error on arcs.
Without the feed-forward (``gamma_ss`` forced to 0) the general law settles on
an arc where ``a eps_o + c gamma_ss ~ 0``, i.e. a lateral offset of about
``-c gamma_ss / a``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["GENERAL_FORMS", "SIMPLE_FORMS", "general_law", "simple_law"]

GENERAL_FORMS = (11, 12, 13)
SIMPLE_FORMS = (20, 21, 22)

#: What the laws return: a float when every input is a Python float (the controllers'
#: one-vehicle fast path, no NumPy), else a float64 array of the broadcast shape.
LawValue = NDArray[np.float64] | float


def _f(x: ArrayLike) -> LawValue:
    """Plain floats pass through (the controllers' fast path); anything else becomes an array."""
    return x if isinstance(x, float) else np.asarray(x, dtype=np.float64)


def _sin(x: LawValue) -> LawValue:
    return math.sin(x) if isinstance(x, float) else np.sin(x)


def _cos(x: LawValue) -> LawValue:
    return math.cos(x) if isinstance(x, float) else np.cos(x)


def general_law(
    form: int,
    eps_c: ArrayLike,
    eps_o: ArrayLike,
    xi: ArrayLike,
    xi_r: ArrayLike,
    dgamma: ArrayLike,
    a: ArrayLike,
    b: ArrayLike,
    c: ArrayLike,
    wheelbase: float,
    *,
    v: ArrayLike | None = None,
    gamma_ss: ArrayLike | None = None,
) -> LawValue:
    """General three-parameter law of seed 000 (rad/s), ``form`` 11, 12 or 13.

    * [seed000 eq11] (point O, manoeuvres, v of either sign): ``-a eps_o - b xi - c dgamma``
    * [seed000 eq12] (point C): ``-a eps_c - (b - a L) xi - c dgamma``
    * [seed000 eq13] (point C): ``-a eps_c - (b - a L) xi_r - (c - b + a L) dgamma``

    The three are the same law rewritten with [seed000 eq9] and [seed000 eq10] (linearised);
    their closed loop obeys [seed000 eq17] (see :mod:`agvnav.guidance.gains`).
    Only the errors a form uses are read.

    Exact body rotation (form 13 only, when ``v`` (m/s) and ``gamma_ss`` (rad)
    are given): the part ``(v cos(gamma_ss) / L) dgamma`` of the last term is
    replaced by ``(v/L) (sin(gamma) - sin(gamma_ss))``, equal to first order,
    so the closed loop [seed000 eq17] and its poles are unchanged. Deviation, as in :func:`simple_law`:
    that part cancels the body rotation ``psi' = (v/L) sin(gamma)`` [seed000 eq8] in
    ``xi_r'``; with the real pole at ``-cos(gamma_ss)/L``
    (:func:`agvnav.guidance.gains.hidden_real_pole`) the whole last term is
    that part and [seed000 eq13] is then [seed000 eq20] exactly, also far from the linear
    range (e.g. the wheel straight at the start of an arc).
    """
    a, b, c, L = _f(a), _f(b), _f(c), float(wheelbase)
    if form == 13 and v is not None and gamma_ss is not None:
        vv, gss, dg = _f(v), _f(gamma_ss), _f(dgamma)
        lin = c - b + a * L - (vv / L) * _cos(gss)
        rot = (vv / L) * (_sin(dg + gss) - _sin(gss))
        return -a * _f(eps_c) - (b - a * L) * _f(xi_r) - lin * dg - rot
    if form == 11:
        return -a * _f(eps_o) - b * _f(xi) - c * _f(dgamma)
    if form == 12:
        return -a * _f(eps_c) - (b - a * L) * _f(xi) - c * _f(dgamma)
    if form == 13:
        return -a * _f(eps_c) - (b - a * L) * _f(xi_r) - (c - b + a * L) * _f(dgamma)
    raise ValueError(f"general law form must be one of {GENERAL_FORMS} (seed 000 eqs 11-13), got {form!r}")


def simple_law(
    form: int,
    eps_c: ArrayLike,
    eps_o: ArrayLike,
    xi: ArrayLike,
    xi_r: ArrayLike,
    gamma: ArrayLike,
    gamma_ss: ArrayLike,
    a: ArrayLike,
    b: ArrayLike,
    v: ArrayLike,
    wheelbase: float,
) -> LawValue:
    """Simple two-parameter law of seed 000 for v > 0 (rad/s), ``form`` 20, 21 or 22.

    * [seed000 eq20]: ``-a eps_c - b xi_r - (v/L) dsin``
    * [seed000 eq21]: ``-a eps_c - b xi - b dgamma - (v/L) dsin``
    * [seed000 eq22]: ``-a eps_o - (b + a L) xi - b dgamma - (v/L) dsin``

    with ``dgamma = gamma - gamma_ss`` and ``dsin = sin(gamma) - sin(gamma_ss)``.
    Deviation: the seed writes ``(v/L) gamma``; the term is there to cancel the
    body rotation ``psi' = (v/L) sin(gamma)`` of [seed000 eq8] in ``xi_r'``, so we use
    the sine (equal to first order on a line, and exact on an arc, where the
    cancellation leaves ``xi_r' = -a eps_c - b xi_r`` plus the curvature term
    ``-kappa^2 v eps_c``). Linearised: [seed000 eq23] ``q'' + b q' + a v q = 0``.
    """
    a, b, v, L = _f(a), _f(b), _f(v), float(wheelbase)
    dgamma = _f(gamma) - _f(gamma_ss)
    rot = (v / L) * (_sin(_f(gamma)) - _sin(_f(gamma_ss)))
    if form == 20:
        return -a * _f(eps_c) - b * _f(xi_r) - rot
    if form == 21:
        return -a * _f(eps_c) - b * _f(xi) - b * dgamma - rot
    if form == 22:
        return -a * _f(eps_o) - (b + a * L) * _f(xi) - b * dgamma - rot
    raise ValueError(f"simple law form must be one of {SIMPLE_FORMS} (seed 000 eqs 20-22), got {form!r}")
