"""Accuracy bounds for bearing-only fixes: Jacobian, Cramér-Rao bound, PDOP, encoder noise.

The measurement model is the goniometer bearing of reflector ``R_i`` seen from
the head centre ``P = (x, y)`` with heading ``psi`` (seed 000, §2.2, Fig. 1a):

.. math:: \\theta_i = \\operatorname{atan2}(y_i - y, x_i - x) - \\psi

Its Jacobian rows are ``[dy_i / d_i², -dx_i / d_i², -1]`` with ``dx_i = x_i - x``.
With independent Gaussian bearing noise of std ``sigma_i`` the Fisher information is
``J^T R^-1 J`` and the Cramér-Rao bound its inverse.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import as_float_array, require_positive

__all__ = ["bearing_jacobian", "crlb", "encoder_bearing_std", "fisher_information", "pdop"]


def encoder_bearing_std(pulses_per_rev: float) -> float:
    """Bearing std (rad) of a goniometer encoder with ``pulses_per_rev`` pulses per revolution.

    Uniform quantisation of step ``Δ = 2π / N`` has std ``Δ / √12``. The seed's head
    (seed 000, §4.1: 65535 pulses/rev, "0,095 mrad" resolution) gives 2.77e-5 rad.
    """
    n = require_positive("pulses_per_rev", pulses_per_rev)
    return (2.0 * math.pi / n) / math.sqrt(12.0)


def bearing_jacobian(reflectors: ArrayLike, pose: ArrayLike) -> NDArray[np.float64]:
    """Jacobian ``d theta_i / d [x, y, psi]`` of the bearings, shape ``(..., N, 3)``.

    ``reflectors`` ``(..., N, 2)`` in m, ``pose`` ``(..., 3)`` = ``[x, y, heading]``;
    rows are ``[dy/d², -dx/d², -1]`` (units 1/m, 1/m, 1).
    """
    r = as_float_array("reflectors", reflectors)
    p = as_float_array("pose", pose)
    dx = r[..., 0] - p[..., None, 0]
    dy = r[..., 1] - p[..., None, 1]
    d2 = dx * dx + dy * dy
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.stack([dy / d2, -dx / d2, -np.ones_like(d2)], axis=-1)


def fisher_information(
    reflectors: ArrayLike, pose: ArrayLike, bearing_std: ArrayLike
) -> NDArray[np.float64]:
    """Fisher information ``J^T R^-1 J`` ``(..., 3, 3)`` of N bearings with std ``bearing_std`` (rad).

    ``bearing_std`` broadcasts against ``(..., N)``.
    """
    jac = bearing_jacobian(reflectors, pose)
    sigma = as_float_array("bearing_std", bearing_std)
    w = 1.0 / np.broadcast_to(sigma, jac.shape[:-1]) ** 2
    return np.einsum("...ni,...n,...nj->...ij", jac, w, jac)


def inv_sym3(a: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Inverse of symmetric 3x3 matrices ``(..., 3, 3)`` by the adjugate, with a ``valid`` flag.

    A batch helper: a singular element gives NaN and ``valid=False`` and never
    raises (``numpy.linalg.inv`` would abort the whole batch).
    """
    a00, a01, a02 = a[..., 0, 0], a[..., 0, 1], a[..., 0, 2]
    a11, a12, a22 = a[..., 1, 1], a[..., 1, 2], a[..., 2, 2]
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    det = a00 * c00 + a01 * c01 + a02 * c02
    scale = np.abs(a00 * c00) + np.abs(a01 * c01) + np.abs(a02 * c02)
    valid = np.isfinite(det) & (np.abs(det) > 1e-13 * scale)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_det = np.where(valid, 1.0 / np.where(valid, det, 1.0), np.nan)
    rows = [[c00, c01, c02], [c01, c11, c12], [c02, c12, c22]]
    out = np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)
    return out * inv_det[..., None, None], valid


def crlb(reflectors: ArrayLike, pose: ArrayLike, bearing_std: ArrayLike) -> NDArray[np.float64]:
    """Cramér-Rao bound ``(J^T R^-1 J)^-1`` on ``[x, y, heading]``, shape ``(..., 3, 3)`` (m², m·rad, rad²).

    ``reflectors`` ``(..., N, 2)`` (m), ``pose`` ``(..., 3)``, ``bearing_std`` (rad) broadcasting
    against ``(..., N)``. Unobservable geometry (fewer than three usable bearings, or
    the head on the critical circle through three reflectors) gives NaN.

    Bad input raises ValueError naming it: ``reflectors`` not ``(..., N, 2)``, ``pose`` not
    ``(..., 3)``, NaN/inf in either, ``bearing_std`` not positive and finite.
    """
    r, p = _check_geometry(reflectors, pose)
    std = as_float_array("bearing_std", bearing_std)
    if not np.all(np.isfinite(std)) or not np.all(std > 0.0):
        raise ValueError(f"bearing_std must be positive and finite, got {bearing_std!r}")
    info = fisher_information(r, p, std)
    cov, _ = inv_sym3(info)
    return cov


def _check_geometry(reflectors: ArrayLike, pose: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    r = as_float_array("reflectors", reflectors)
    p = as_float_array("pose", pose)
    if r.ndim < 2 or r.shape[-1] != 2:
        raise ValueError(f"reflectors must have shape (..., N, 2), got {r.shape}")
    if p.ndim < 1 or p.shape[-1] != 3:
        raise ValueError(f"pose must have shape (..., 3) = [x, y, heading], got {p.shape}")
    for name, arr in (("reflectors", r), ("pose", p)):
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN or inf")
    return r, p


def pdop(reflectors: ArrayLike, pose: ArrayLike) -> NDArray[np.float64]:
    """Position dilution of precision (m/rad): ``sqrt(trace of the CRLB position block)`` for unit bearing std.

    Multiply by the bearing std (rad) to get the best achievable RMS position error (m).
    Validates ``reflectors`` and ``pose`` like :func:`crlb` (ValueError naming them).
    """
    cov = crlb(reflectors, pose, 1.0)
    return np.sqrt(cov[..., 0, 0] + cov[..., 1, 1])
