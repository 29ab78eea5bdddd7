"""Guidance errors of seed 000 Fig. 5 ([seed000 eq9] [seed000 eq10]) on lines and arcs, and the feed-forward.

Vehicle (seed 000 §3.1, [seed000 eq8]): point O midway between the fork wheels, point
C the drive/steer wheel centre at distance L ahead of O on the body x-axis,
heading psi, steering angle gamma, v the (signed) speed of C::

    x_O' = v cos(gamma) cos(psi),  y_O' = v cos(gamma) sin(psi),  psi' = v sin(gamma) / L.

Errors (all measured in the *reference body frame* of the path: x along the
tangent for a forward segment and against it for a reverse one, so that [seed000 eq14]
[seed000 eq15] [seed000 eq16] hold for both signs of v):

* ``eps_o``, ``eps_c``: lateral deviation (m) of O and C, left positive;
* ``xi``: vehicle heading error (rad);
* ``xi_r``: drive-wheel heading error (rad).

Curvature feed-forward (derivation). In steady motion with constant gamma the
body turns about the instantaneous centre of rotation, where the normals to
the velocities of O (along the body x-axis) and C (along the wheel) meet.
From [seed000 eq8], psi' = v sin(gamma) / L, |v_O| = |v| cos(gamma), |v_C| = |v|, so
with the path tangent ``theta`` and arclength ``s`` along the motion
(ds/dt = |v_P|) the curvature of the path of each point is
``kappa_P = d(theta)/ds = psi' / |v_P|``:

* O: ``kappa_O = sign(v) tan(gamma) / L``  ->  ``tan(gamma_ss) = d L kappa``;
* C: ``kappa_C = sign(v) sin(gamma) / L``  ->  ``sin(gamma_ss) = d L kappa``
  (radius of C is R_C = L / |sin gamma|: the wheel is tangent to the circle,
  which needs R_C >= L),

where ``d = sign(v)`` is the segment's direction of travel. On a line
``gamma_ss = 0``. The errors are taken *relative to the feed-forward*: the
reference body heading on an arc is the one of the steady turn, so that

* tracked point O: ``xi = psi - psi_ref``, ``xi_r = xi + (gamma - gamma_ss)``;
* tracked point C: ``xi_r = psi + gamma - psi_ref`` (the wheel is tangent at
  steady state), ``xi = xi_r - (gamma - gamma_ss)``;

with ``psi_ref`` the path tangent (+ pi when reversing). [seed000 eq9] becomes
``xi_r = xi + (gamma - gamma_ss)`` and [seed000 eq10] ``eps_c = eps_o + L sin(xi)``
(exact, used to derive the error of the untracked point). On a line both are
the seed's relations and the derived lateral error is the true lateral
deviation of the other point; on an arc it is its first-order equivalent. At
the steady turn (zero lateral error, gamma = gamma_ss) every error is zero, so
a law that is linear in these errors and in ``gamma - gamma_ss`` holds the
path with zero steady-state error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_last_dim, require_positive
from agvnav.geometry.angles import wrap_angle, wrap_angle_scalar
from agvnav.guidance.paths import Path

__all__ = [
    "POINTS",
    "TrackingErrors",
    "errors_from_projection",
    "feedforward_steering",
    "point_c",
    "tracking_errors",
    "tracking_errors_scalar",
]

POINTS = ("O", "C")
"""Trackable points: O (between the fork wheels, base_link) and C (drive-wheel centre)."""


def _check_point(point: str) -> str:
    if point not in POINTS:
        raise ValueError(f"point must be 'O' or 'C', got {point!r}")
    return point


@dataclass(frozen=True)
class TrackingErrors:
    """Errors of seed 000 Fig. 5 relative to the feed-forward (arrays of shape ``(...)``).

    ``eps_c``, ``eps_o`` (m), ``xi``, ``xi_r`` (rad), ``s`` arclength of the
    tracked point's projection (m), ``gamma_ss`` feed-forward steering angle
    (rad), ``kappa`` path curvature (1/m), ``direction`` (+1/-1), ``valid``
    (False where the feed-forward is impossible: C on an arc of radius < L).
    """

    eps_c: NDArray[np.float64] | float
    eps_o: NDArray[np.float64] | float
    xi: NDArray[np.float64] | float
    xi_r: NDArray[np.float64] | float
    s: NDArray[np.float64] | float
    gamma_ss: NDArray[np.float64] | float
    kappa: NDArray[np.float64] | float
    direction: NDArray[np.int64] | int
    valid: NDArray[np.bool_] | bool

    def as_dict(self) -> dict[str, float]:
        """Scalar errors as a flat dict of floats (for recording one time step)."""
        return {k: float(getattr(self, k)) for k in ("eps_c", "eps_o", "xi", "xi_r", "s", "gamma_ss", "kappa")}


def feedforward_steering(
    kappa: ArrayLike, wheelbase: float, point: str, direction: ArrayLike = 1
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Steady-state steering angle gamma_ss (rad) holding the tracked point on curvature ``kappa``.

    ``tan(gamma_ss) = d L kappa`` for O and ``sin(gamma_ss) = d L kappa`` for C
    (derived from [seed000 eq8] in the module docstring); ``d`` = direction of
    travel. Returns ``(gamma_ss, valid)``; for C with ``L |kappa| > 1`` the
    angle saturates at +/- pi/2 and ``valid`` is False.
    """
    L = require_positive("wheelbase", wheelbase)
    q = np.asarray(direction, dtype=np.float64) * L * np.asarray(kappa, dtype=np.float64)
    if _check_point(point) == "O":
        return np.arctan(q), np.ones(q.shape, dtype=bool)
    valid = np.abs(q) <= 1.0
    return np.arcsin(np.clip(q, -1.0, 1.0)), valid


def point_c(pose_o: ArrayLike, wheelbase: float) -> NDArray[np.float64]:
    """Position (..., 2) of C, at distance L ahead of O along the body x-axis (seed 000 Fig. 4b)."""
    p = np.asarray(pose_o, dtype=np.float64)
    return p[..., :2] + wheelbase * np.stack([np.cos(p[..., 2]), np.sin(p[..., 2])], axis=-1)


def errors_from_projection(
    psi: ArrayLike,
    gamma: ArrayLike,
    lateral: ArrayLike,
    path_heading: ArrayLike,
    kappa: ArrayLike,
    direction: ArrayLike,
    wheelbase: float,
    point: str,
) -> tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
    NDArray[np.bool_],
]:
    """Errors (eps_c, eps_o, xi, xi_r, gamma_ss, valid) from the tracked point's projection.

    Pure kernel, vectorised over the batch. ``psi``, ``gamma`` (rad) of the
    vehicle; ``lateral`` (m, left of the tangent), ``path_heading`` (rad),
    ``kappa`` (1/m), ``direction`` (+1/-1) of the path at the projection of the
    tracked ``point`` ("O" or "C"). [seed000 eq9] and [seed000 eq10] relative to the
    feed-forward (see module docstring).
    """
    L = require_positive("wheelbase", wheelbase)
    d = np.asarray(direction, dtype=np.float64)
    gamma = np.asarray(gamma, dtype=np.float64)
    gamma_ss, valid = feedforward_steering(kappa, L, point, d)
    psi_ref = np.asarray(path_heading, dtype=np.float64) + np.where(d < 0, math.pi, 0.0)
    eps = d * np.asarray(lateral, dtype=np.float64)
    if point == "O":
        eps_o = eps
        xi = wrap_angle(np.asarray(psi, dtype=np.float64) - psi_ref)
        xi_r = wrap_angle(xi + gamma - gamma_ss)  # eq. 9 relative to the feed-forward
        eps_c = eps_o + L * np.sin(xi)  # eq. 10
    else:
        eps_c = eps
        xi_r = wrap_angle(np.asarray(psi, dtype=np.float64) + gamma - psi_ref)
        xi = wrap_angle(xi_r - (gamma - gamma_ss))  # eq. 9
        eps_o = eps_c - L * np.sin(xi)  # eq. 10
    return eps_c, eps_o, xi, xi_r, gamma_ss, valid


def tracking_errors(
    path: Path,
    pose_o: ArrayLike,
    gamma: ArrayLike,
    wheelbase: float,
    point: str = "C",
    s_hint: ArrayLike | None = None,
    window: float | None = None,
    feedforward: bool = True,
) -> TrackingErrors:
    """Seed 000 Fig. 5 errors of a vehicle at ``pose_o`` (..., 3) with steering ``gamma`` (...) (rad).

    ``path`` is the planned path of the tracked ``point`` ("O" or "C"). The
    tracked point is projected onto the path (optionally within ``s_hint +/-
    window``, m) and :func:`errors_from_projection` gives the errors.
    """
    pose = require_last_dim("pose_o", require_finite("pose_o", pose_o), 3)
    L = require_positive("wheelbase", wheelbase)
    p = pose[..., :2] if _check_point(point) == "O" else point_c(pose, L)
    proj = path.project(p, s_hint=s_hint, window=window)
    kappa_ff = proj.curvature if feedforward else np.zeros_like(proj.curvature)
    eps_c, eps_o, xi, xi_r, gamma_ss, valid = errors_from_projection(
        pose[..., 2], gamma, proj.lateral, proj.heading, kappa_ff, proj.direction, L, point
    )
    return TrackingErrors(eps_c, eps_o, xi, xi_r, proj.s, gamma_ss, proj.curvature, proj.direction, valid)


def tracking_errors_scalar(
    path: Path,
    pose_o: tuple[float, float, float],
    gamma: float,
    wheelbase: float,
    point: str = "C",
    s_hint: float | None = None,
    window: float | None = None,
    feedforward: bool = True,
) -> TrackingErrors:
    """Scalar fast path of :func:`tracking_errors` (plain floats in and out), for controllers.

    Same equations ([seed000 eq9] [seed000 eq10] relative to the feed-forward); wrapping
    to ``[-pi, pi)`` by :func:`agvnav.geometry.wrap_angle_scalar`. No input checks: the caller validates.
    """
    x, y, psi = pose_o
    L = wheelbase
    if point == "C":
        x, y = x + L * math.cos(psi), y + L * math.sin(psi)
    pr = path.project_point(x, y, s_hint, window)
    d = pr.direction
    kappa = pr.curvature if feedforward else 0.0
    q = d * L * kappa
    valid = True
    if point == "O":
        gamma_ss = math.atan(q)
    else:
        valid = abs(q) <= 1.0
        gamma_ss = math.asin(min(max(q, -1.0), 1.0))
    psi_ref = pr.heading + (math.pi if d < 0 else 0.0)
    eps = d * pr.lateral
    if point == "O":
        eps_o, xi = eps, wrap_angle_scalar(psi - psi_ref)
        xi_r = wrap_angle_scalar(xi + gamma - gamma_ss)
        eps_c = eps_o + L * math.sin(xi)
    else:
        eps_c, xi_r = eps, wrap_angle_scalar(psi + gamma - psi_ref)
        xi = wrap_angle_scalar(xi_r - (gamma - gamma_ss))
        eps_o = eps_c - L * math.sin(xi)
    return TrackingErrors(eps_c, eps_o, xi, xi_r, pr.s, gamma_ss, pr.curvature, d, valid)
