"""The leading-edge bearing of a cylindrical reflector, the measurement model of the goniometer (batch form).

The goniometer reports the bearing, in the head frame, of the *leading tangent edge* of
a cylindrical reflector of radius r seen from the head centre P: the head turns
counter-clockwise, so the beam meets the edge at ``centre - asin(r / d)`` (seed 000
§2.1: the angle is read "at the start of the reflection"). :func:`bearing_model` is the
NumPy batch form over any leading dimensions (the start-up search, the fix estimators,
the station filter); the streaming filters call the compiled scalar form
(:func:`agvnav.positioning._fast.edge_bearing`, through
:class:`agvnav.positioning.measurement.BearingMeasurement`), checked against this one in
``tests/positioning/test_kernel_oracles.py``. :func:`measurement_variance` is one bearing's
variance with the survey error of the map.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import wrap_angle

__all__ = ["bearing_model", "edge_offset", "measurement_variance"]


def edge_offset(distance: ArrayLike, radius: ArrayLike) -> NDArray[np.float64]:
    """Angle (rad) from a reflector's centre to its leading tangent edge, ``-asin(r / d)``.

    The head turns counter-clockwise, so the reflection starts on the clockwise side of
    the cylinder (seed 000 §2.1). ``distance`` (m) and ``radius`` (m) broadcast; a head
    inside a reflector (``d <= r``) is clipped to ``-pi/2``.
    """
    d = np.asarray(distance, dtype=np.float64)
    r = np.asarray(radius, dtype=np.float64)
    ratio = np.clip(r / np.where(d > 0.0, d, np.inf), 0.0, 1.0)
    return -np.arcsin(np.where(d > 0.0, ratio, 1.0))


def bearing_model(
    pose: ArrayLike, mount: ArrayLike, reflector_xy: ArrayLike, radius: ArrayLike = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Predicted leading-edge bearing of reflectors from the head, and its Jacobian.

    Parameters
    ----------
    pose:
        ``(..., 3)`` base_link pose ``[x, y, psi]`` in ``map`` (m, rad).
    mount:
        ``(3,)`` pose of the head centre P in base_link (m, rad).
    reflector_xy, radius:
        ``(..., 2)`` reflector centres (m) and ``(...)`` radii (m); all broadcast.

    Returns
    -------
    h:
        ``(...)`` bearing in the head frame (rad, wrapped), ``atan2(R - P) - psi_P - asin(r/d)``
        (seed 000 §2.1: the angle theta_i of the beam relative to the frame at the start of
        the reflection).
    H:
        ``(..., 3)`` derivative of ``h`` with respect to ``[x, y, psi]`` of base_link.
    distance:
        ``(...)`` distance (m) from P to the reflector centre.
    """
    pose = np.asarray(pose, dtype=np.float64)
    m = np.asarray(mount, dtype=np.float64)
    xy = np.asarray(reflector_xy, dtype=np.float64)
    r = np.asarray(radius, dtype=np.float64)
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    px = pose[..., 0] + c * m[0] - s * m[1]
    py = pose[..., 1] + s * m[0] + c * m[1]
    dx, dy = xy[..., 0] - px, xy[..., 1] - py
    d2 = dx * dx + dy * dy
    d = np.sqrt(d2)
    h = wrap_angle(np.arctan2(dy, dx) - pose[..., 2] - m[2] + edge_offset(d, r))
    safe_d = np.where(d > 0.0, d, np.inf)
    ratio = np.clip(r / safe_d, 0.0, 1.0 - 1e-12)
    edge_gain = r / (safe_d**3 * np.sqrt(1.0 - ratio**2))  # d/dd of asin(r/d), sign folded below
    dh_dpx = dy / np.where(d2 > 0.0, d2, np.inf) - edge_gain * dx
    dh_dpy = -dx / np.where(d2 > 0.0, d2, np.inf) - edge_gain * dy
    dpx_dpsi = -s * m[0] - c * m[1]
    dpy_dpsi = c * m[0] - s * m[1]
    dh_dpsi = dh_dpx * dpx_dpsi + dh_dpy * dpy_dpsi - 1.0
    H = np.stack(np.broadcast_arrays(dh_dpx, dh_dpy, dh_dpsi), axis=-1)
    return h, H, d


def measurement_variance(bearing_var: ArrayLike, map_std: float, distance: ArrayLike) -> NDArray[np.float64]:
    """Variance (rad²) of one bearing: encoder/bearing noise plus the map survey error seen at ``distance`` (m).

    ``R = sigma_b^2 + (map_std / d)^2``: a reflector displaced by ``map_std`` across the line
    of sight shifts its bearing by ``map_std / d`` (seed 000 §4.1: surveyed positions).
    """
    d = np.asarray(distance, dtype=np.float64)
    return np.asarray(bearing_var, dtype=np.float64) + (float(map_std) / np.where(d > 0.0, d, np.inf)) ** 2
