"""Predicted accuracy of the *filtered* estimate: a covariance analysis along the route.

The single-revolution CRLB (:mod:`agvnav.layout.prediction`) bounds one fix. The
vehicle's EKF also carries the previous fixes forward through odometry, so its
error is smaller. This module runs the filter's covariance recursion without
noise (a Riccati recursion): between route poses the covariance grows by the
odometry model, ``P⁻ = F P Fᵀ + Q`` ([seed002 eq14], [seed002 eq17] via
:func:`agvnav.odometry.covariance.propagate`), and at each pose the bearings of
the revolutions made since the last pose add their Fisher information,
``P = (P⁻⁻¹ + n_rev I_k)⁻¹`` [seed000 §2.2]. It is the prediction the closed-loop
check compares with.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import wrap_angle
from agvnav.layout.prediction import information
from agvnav.odometry import OdometryNoise
from agvnav.odometry.covariance import propagate

__all__ = ["filtered_rms"]


def _matrix(i6: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.array([[i6[0], i6[1], i6[2]], [i6[1], i6[3], i6[4]], [i6[2], i6[4], i6[5]]])


def filtered_rms(pose: NDArray[np.float64], head: NDArray[np.float64], refl: NDArray[np.float64],
                 visible: NDArray[np.bool_], bearing_std: float, revolutions_per_m: float,
                 initial_std: tuple[float, float, float] = (0.02, 0.02, math.radians(1.0)),
                 noise: OdometryNoise | None = None) -> NDArray[np.float64]:
    """``sqrt(trace P_xy)`` (m) of the filtered estimate at each of the consecutive route poses ``pose`` ``(K, 3)``.

    ``head`` ``(K, 2)`` goniometer positions, ``refl`` ``(S, 2)`` reflectors with
    ``visible`` ``(K, S)``; ``revolutions_per_m`` = head rate / speed (rev/m).
    """
    if revolutions_per_m <= 0.0:
        raise ValueError(f"revolutions_per_m must be positive, got {revolutions_per_m}")
    info = information(head, refl, visible, bearing_std)
    p = np.diag(np.square(initial_std))
    out = np.empty(pose.shape[0])
    for k in range(pose.shape[0]):
        if k > 0:
            dd = float(np.hypot(*(pose[k, :2] - pose[k - 1, :2])))
            dth = float(wrap_angle(pose[k, 2] - pose[k - 1, 2]))
            _, p = propagate(pose[k - 1], p, dd, dth, noise)
            n_rev = max(1.0, dd * revolutions_per_m)
        else:
            n_rev = 1.0
        p = np.linalg.inv(np.linalg.inv(p) + n_rev * _matrix(info[k]))
        out[k] = math.sqrt(max(p[0, 0] + p[1, 1], 0.0))
    return out
