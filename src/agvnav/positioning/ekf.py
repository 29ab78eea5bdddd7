"""Extended Kalman filter on the base_link pose, one bearing at a time (the seeds' future work).

State ``x = [x, y, psi]`` of base_link in ``map``, covariance ``P``.

* predict (odometry, [seed002 eq14]; :meth:`StreamingEstimator.predict`):
  ``x <- f(x, dD, dtheta, dlateral)``, the SE(2) exponential of the body-twist increment
  (for ``dlateral = 0`` the arc rule [seed002 eq25]), ``P <- F P F^T + Q`` with ``F`` its
  pose Jacobian (:func:`agvnav.odometry.pose_jacobian` when ``dlateral = 0``) and ``Q``
  seed 002's noise model [seed002 eq17] plus a lateral term for holonomic vehicles
  (:func:`agvnav.odometry.motion_covariance` when ``dlateral = 0``);
* update (one reflection, at its own instant): ``y = wrap(z - h(x))`` with ``h`` the
  leading-edge bearing of the identified reflector from the head
  (:func:`~agvnav.positioning.identification.bearing_model`, seed 000 §2.1),
  ``S = H P H^T + R``, ``K = P H^T S^-1``, ``x <- x + K y``,
  ``P <- (I - K H) P (I - K H)^T + K R K^T`` (Joseph form, stays symmetric positive).

Because every bearing updates the state at the instant it was measured, the motion
between reflections never enters the measurement: this is the filter-based answer to
the problem of seed 000 §2.2, which the seeds instead solve by propagating the angles.
Seed 000 §2.2 argues the errors of raw dynamic triangulation are not Gaussian; here the
filter never sees those errors, only the bearing noise and the odometry noise.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import wrap_angle
from agvnav.positioning import _fast
from agvnav.positioning.estimator import StreamingEstimator
from agvnav.positioning.wall_ranges import WallRangeModel

__all__ = ["EkfEstimator", "ekf_predict", "ekf_update"]


def ekf_predict(
    x_pred: ArrayLike, P: ArrayLike, F: ArrayLike, Q: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Covariance prediction ``P' = F P F^T + Q``; ``x_pred (..., 3)`` is passed through wrapped.

    ``P, F, Q`` are ``(..., 3, 3)``; the state prediction ``f(x, u)`` itself is
    :func:`agvnav.odometry.integrate_pose`.
    """
    x = np.array(x_pred, dtype=np.float64)
    x[..., 2] = wrap_angle(x[..., 2])
    F = np.asarray(F, dtype=np.float64)
    P_new = F @ np.asarray(P, dtype=np.float64) @ np.swapaxes(F, -1, -2) + np.asarray(Q, dtype=np.float64)
    return x, 0.5 * (P_new + np.swapaxes(P_new, -1, -2))


def ekf_update(
    x: ArrayLike, P: ArrayLike, innovation: ArrayLike, H: ArrayLike, R: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Scalar-measurement EKF update in Joseph form, vectorised over leading dimensions.

    Parameters
    ----------
    x, P:
        ``(..., 3)`` prior state and ``(..., 3, 3)`` covariance.
    innovation:
        ``(...)`` ``y = wrap(z - h(x))`` (rad), already wrapped by the caller.
    H, R:
        ``(..., 3)`` measurement Jacobian row and ``(...)`` measurement variance (rad²).

    Returns the posterior ``(x, P)``; the heading is wrapped.
    """
    x = np.asarray(x, dtype=np.float64)
    P = np.asarray(P, dtype=np.float64)
    H = np.asarray(H, dtype=np.float64)
    R = np.asarray(R, dtype=np.float64)
    PHt = np.einsum("...ij,...j->...i", P, H)
    S = np.einsum("...i,...i->...", H, PHt) + R
    K = PHt / S[..., None]
    x_new = x + K * np.asarray(innovation, dtype=np.float64)[..., None]
    x_new[..., 2] = wrap_angle(x_new[..., 2])
    I_KH = np.eye(3) - K[..., :, None] * H[..., None, :]
    P_new = I_KH @ P @ np.swapaxes(I_KH, -1, -2) + R[..., None, None] * K[..., :, None] * K[..., None, :]
    return x_new, 0.5 * (P_new + np.swapaxes(P_new, -1, -2))


class EkfEstimator(StreamingEstimator):
    """Streaming EKF (default method of :func:`~agvnav.positioning.make_estimator`).

    Prediction from each odometry increment (base class), sequential update per
    identified reflection at its own instant. Inspectable after each update:
    ``last_innovation`` (rad), ``last_nis`` and ``last_reflector`` (map row).

    Built with ``walls`` ``(M, 2, 2)`` and ``rangers`` (an
    :class:`~agvnav.sensors.ultrasonic.UltrasonicArray`), it also fuses ultrasonic
    ranges, one scalar update per associated range (:meth:`update_ranges`,
    :mod:`agvnav.positioning.wall_ranges`); ``range_beam`` and ``range_end_margin``
    go to :class:`~agvnav.positioning.wall_ranges.WallRangeModel`. Counters
    ``n_ranges_accepted`` / ``n_ranges_rejected``; ``last_range`` is the latest
    :class:`~agvnav.positioning.wall_ranges.RangeAssociation`.
    """

    method = "ekf"
    late_updates = True

    def __init__(
        self,
        world: Any,
        mount: ArrayLike = (0.0, 0.0, 0.0),
        *,
        walls: ArrayLike | None = None,
        rangers: Any = None,
        range_beam: str = "cone",
        range_end_margin: float = 0.05,
        **kwargs: Any,
    ) -> None:
        super().__init__(world, mount, **kwargs)
        self.last_innovation = float("nan")
        self.last_nis = float("nan")
        self.last_reflector = -1
        self.wall_ranges: WallRangeModel | None = None
        if walls is not None or rangers is not None:
            if walls is None:
                raise ValueError("rangers need the walls they measure: give walls= too")
            self.wall_ranges = WallRangeModel(walls, rangers, beam=range_beam, end_margin=range_end_margin)
        self.n_ranges_accepted = 0
        self.n_ranges_rejected = 0
        self.last_range: Any = None

    def update_ranges(self, t: float, ranges: Mapping[str, float]) -> int:
        """Ultrasonic readings ``{sensor: range (m)}`` made at ``t`` (s); returns how many were fused.

        One Joseph-form update per reading whose nearest modelled wall passes the
        chi-square gate [seed004 eq8] (a side pair's two ranges also fix the heading,
        as [seed004 eq6] [seed004 eq7] do). nan readings (no echo) are skipped. The
        ranges must come after :meth:`predict` up to ``t`` (the closed loop does so).
        """
        if self.wall_ranges is None:
            raise ValueError(
                "this estimator was built without walls and rangers (make_estimator(..., walls=, rangers=))"
            )
        self.wall_ranges.check_names(list(ranges))
        t = self._check_time(t, "ranges")
        if self._t is not None and t > self._t + 1e-9:
            raise ValueError(f"ranges at t={t!r} s are ahead of the latest odometry at t={self._t!r} s; predict first")
        self._t = t
        if not self._has_pose():
            return 0
        fused = 0
        for name, r in ranges.items():
            if not math.isfinite(r):
                continue
            assoc = self.wall_ranges.associate(name, float(r), self._x_t, self._P_t, self.gate)
            if assoc is None:
                self.n_ranges_rejected += 1
                continue
            self._x_t, self._P_t = _fast.joseph_update(self._x_t, self._P_t, assoc.innovation, assoc.H, assoc.R)
            self.last_range = assoc
            fused += 1
        self.n_ranges_accepted += fused
        if fused:
            self._t_last_accept = t
        return fused

    def _accept(self, t: float, bearing: float, assoc: Any) -> None:
        # scalar fast path of ekf_update (Joseph form), tested against it to 1e-12
        H = (float(assoc.H[0]), float(assoc.H[1]), float(assoc.H[2]))
        self._x_t, self._P_t = _fast.joseph_update(self._x_t, self._P_t, assoc.innovation, H, assoc.R)
        self.last_innovation = assoc.innovation
        self.last_nis = assoc.nis
        self.last_reflector = assoc.index
