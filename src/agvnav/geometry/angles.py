"""Angles: wrapping and differences. Every angle residual in agvnav goes through here.

One convention everywhere: angles are wrapped to the half-open interval ``[-pi, pi)``, so
``pi`` itself maps to ``-pi`` (``math.remainder`` or ``atan2(sin, cos)`` would keep ``+pi``).
The reduction is exact: the result is ``a - k * TWO_PI`` for an integer ``k`` with no
rounding (``fmod`` is exact and the one correction step is exact by Sterbenz's lemma), so
an angle already in ``[-pi, pi)`` comes back bit for bit, however small. ``TWO_PI`` is the
double nearest ``2 pi``; for ``|a|`` far beyond ``2 pi`` the result is the exact remainder
modulo that double, which differs from the true remainder modulo ``2 pi`` by about
``|a| * 2.4e-16``. ``wrap_angle`` is the vectorised form, ``wrap_angle_scalar`` the one-float
fast path of the scalar loops; both give the same bits. ``wrap_angle_kernel`` is
``wrap_angle_scalar`` as a kernel (:mod:`agvnav._jit`): the same source, called by the compiled
kernels (``sensors.beam``, ``positioning.gating``) in either mode, so the scalar wrap is written
once.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._jit import jit

__all__ = [
    "PI", "TWO_PI", "angle_diff", "deg2rad", "rad2deg", "wrap_angle", "wrap_angle_kernel", "wrap_angle_scalar",
]

#: ``pi`` (rad), the double nearest it; the open end of the wrap interval.
PI = math.pi
#: ``2 pi`` (rad), the double nearest it (exactly ``2 * PI``); the wrap modulus.
TWO_PI = 2.0 * math.pi
_INF = math.inf


def wrap_angle(angle: ArrayLike) -> NDArray[np.float64]:
    """Wrap angles to the half-open interval ``[-pi, pi)`` (rad).

    Parameters
    ----------
    angle : array_like
        Angles (rad), any shape.

    Returns
    -------
    ndarray of float64
        Same shape, in ``[-pi, pi)``; ``a - k * TWO_PI`` exactly for an integer ``k``
        (a NumPy float64 scalar for a scalar input, as NumPy ufuncs return). NaN and
        ``+-inf`` give NaN (NumPy warns "invalid value" for an infinite array element).

    Examples
    --------
    >>> float(wrap_angle(math.pi)), float(wrap_angle(-math.pi))
    (-3.141592653589793, -3.141592653589793)
    >>> wrap_angle([1e-300, 3 * math.pi / 2]).tolist() == [1e-300, -math.pi / 2]
    True
    """
    a = np.asarray(angle, dtype=np.float64)
    if a.ndim == 0:  # one value: the scalar path is about 20 times faster than the ufuncs
        return np.float64(wrap_angle_scalar(float(a)))  # type: ignore[return-value]  # 0-d: NumPy's scalar
    r = np.fmod(a, TWO_PI)  # exact, in (-2 pi, 2 pi), sign of a
    r[r >= PI] -= TWO_PI  # exact: Sterbenz, r within a factor 2 of TWO_PI
    r[r < -PI] += TWO_PI
    return r


def wrap_angle_scalar(angle: float) -> float:
    """:func:`wrap_angle` for one Python float (rad): the same ``[-pi, pi)`` result, bit for bit.

    About ten times faster than the array form on one value; for the scalar loops of the
    simulator and the single-fix kernels. NaN and ``+-inf`` give NaN. Written in the subset
    numba compiles (:data:`wrap_angle_kernel` is this function as a kernel; ``math.fmod`` is
    C's ``fmod`` there too, see :mod:`agvnav._jit`).

    Examples
    --------
    >>> wrap_angle_scalar(math.pi), wrap_angle_scalar(7.0) == 7.0 - TWO_PI
    (-3.141592653589793, True)
    """
    if -PI <= angle < PI:  # already wrapped (most calls): fmod would return it unchanged
        return float(angle)
    if not -_INF < angle < _INF:  # NaN: itself (its bits, as fmod keeps them); +-inf (math.fmod raises): NaN
        return float(angle) if angle != angle else math.nan
    r = math.fmod(angle, TWO_PI)  # exact, in (-2 pi, 2 pi), sign of angle
    if r >= PI:  # one exact shift (Sterbenz)
        return r - TWO_PI
    if r < -PI:
        return r + TWO_PI
    return r


#: :func:`wrap_angle_scalar` as a compiled-capable kernel (:mod:`agvnav._jit`), for other kernels to call:
#: the one scalar wrap, bit for bit the same in either mode.
wrap_angle_kernel = jit(wrap_angle_scalar)


def angle_diff(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Smallest signed difference ``a - b`` (rad), wrapped to ``[-pi, pi)``.

    Parameters
    ----------
    a, b : array_like
        Angles (rad); broadcast against each other.

    Returns
    -------
    ndarray of float64
        ``wrap_angle(a - b)``; a difference of exactly ``pi`` gives ``-pi``.
    """
    return wrap_angle(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64))


def deg2rad(degrees: ArrayLike) -> NDArray[np.float64]:
    """Degrees to radians, for the user's edge (CLI, scenario files)."""
    return np.deg2rad(np.asarray(degrees, dtype=np.float64))


def rad2deg(radians: ArrayLike) -> NDArray[np.float64]:
    """Radians to degrees, for the user's edge (tables, plots)."""
    return np.rad2deg(np.asarray(radians, dtype=np.float64))
