"""The odometry noise model as a kernel: the variances of one increment [seed002 eq17], written once.

Seed 002's model (after Crowley 1992, corrected to a covariance in :mod:`agvnav.odometry.covariance`)
puts independent errors on the increments: ``var(ΔD) = K_D |ΔD|`` and ``var(Δθ) = K_Dθ |ΔD| + K_θ |Δθ|``.
:func:`increment_variances` is that formula, compiled with :func:`agvnav._jit.jit` (numba, or plain
Python in interpreted mode). Every user of the model calls it:

* the streaming estimators' process noise (:func:`agvnav.positioning._fast.process_noise`, which maps
  the variances through the twist step's Jacobian ``G`` and adds a holonomic lateral term) and the
  integrity monitor's dead-reckoning growth;
* the layout's filtered-accuracy recursion (:mod:`agvnav.layout.filtered`, a numba kernel);
* the NumPy batch form :meth:`agvnav.odometry.OdometryNoise.increment_covariance` (hence
  :func:`agvnav.odometry.motion_covariance`), which runs the same source on arrays
  (:func:`increment_variances_array`).

The source uses only ``abs`` and arithmetic, so it runs unchanged on floats and on NumPy arrays.
"""

from __future__ import annotations

from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._jit import Kernel, jit

__all__ = ["increment_variances", "increment_variances_array"]


@jit
def increment_variances(
    dist: float, dth: float, k_d: float, k_dtheta: float, k_theta: float
) -> tuple[float, float]:
    """Variances of one odometry increment's distance and heading, ``(var_d, var_th)`` (m², rad²).

    [seed002 eq17] corrected to a covariance (see :mod:`agvnav.odometry.covariance`):
    ``var_d = K_D |s|`` and ``var_th = K_Dtheta |s| + K_theta |dth|`` for ``s`` = ``dist`` m
    travelled and ``dth`` rad turned; ``k_d`` (m²/m), ``k_dtheta`` (rad²/m), ``k_theta``
    (rad²/rad) Crowley's coefficients (:class:`agvnav.odometry.OdometryNoise`).
    """
    s = abs(dist)
    return k_d * s, k_dtheta * s + k_theta * abs(dth)


def increment_variances_array(
    dist: ArrayLike, dth: ArrayLike, k_d: float, k_dtheta: float, k_theta: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`increment_variances` [seed002 eq17] over arrays (m², rad²), broadcast; the kernel's own source.

    The batch form for NumPy callers: the same formula in the same operations, evaluated by
    NumPy whichever mode the kernels run in.
    """
    d, t = np.broadcast_arrays(np.asarray(dist, dtype=np.float64), np.asarray(dth, dtype=np.float64))
    var_d, var_th = cast(Kernel, increment_variances).py_func(d, t, k_d, k_dtheta, k_theta)
    return np.asarray(var_d, dtype=np.float64), np.asarray(var_th, dtype=np.float64)
