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
  ``P <- (I - K H) P (I - K H)^T + K R K^T`` (Joseph form, stays symmetric positive);
  :func:`ekf_update` is that update, the estimator's own is its Schmidt-Kalman form below.

Survey errors as consider parameters (issue 12). A reflector's surveyed position errs by a
constant ``p_j`` (2-D, std ``survey_std_j`` per axis: the map's ``survey_std_m``, else
``map_std``), the same in every revolution. Taken as white bearing noise
``(map_std / d)^2`` the filter averages it away and ends overconfident; adding a survey
floor afterwards counts it twice. The estimator instead keeps the survey errors as
*consider* parameters (Schmidt-Kalman filter): never estimated, fixed covariance
``P_pp = diag(survey_std_j^2)``, but their cross-covariance with the pose, ``P_xp``
(3 x 2N), is carried:

* predict: ``P_xp <- F P_xp``;
* a bearing of reflector j, ``y = H e + H_p p_j + w`` with ``H_p = -H[:2]`` (the bearing
  moves with the reflector as against the head), ``v = P_xp,j H_p^T``,
  ``b = H_p P_pp,j H_p^T``: ``S = H P H^T + 2 H v + b + sigma^2``, ``K = (P H^T + v) / S``
  on the pose only, ``P <- A P A^T - A v K^T - K v^T A^T + (b + sigma^2) K K^T`` with
  ``A = I - K H`` (:func:`~agvnav.positioning._fast.schmidt_update`), and
  ``P_xp <- A P_xp - K H_p P_pp,j`` (only reflector j's columns get the last term);
* an ultrasonic range (no survey error): the ordinary update, ``P_xp <- A P_xp``.

The gate uses the same ``S`` (:func:`~agvnav.positioning._fast.gate_one` with
``consider``). ``P`` is then the covariance of the pose error survey errors included,
and :attr:`EkfEstimator.covariance` reports it alone (no survey floor).

Cost: ``P_xp`` is kept factored, ``P_xp = M C^T`` with ``M`` 3x3 and ``C (N, 6)`` (row j:
reflector j's two columns). Every left multiplication (``F``, ``A``) touches ``M`` only, and
an update writes reflector j's row, ``C[j] += M^-1 (K h_p svar_j)``: O(1) per prediction
and per bearing, whatever the map. ``M`` shrinks with every update (``det A = 1 - H K``),
so once ``|det M| < CONSIDER_MIN_DET`` or an entry of ``M`` exceeds ``CONSIDER_MAX_ENTRY``
it is folded into ``C`` (``C <- C M^T`` per reflector, one NumPy call over the map, O(N))
and reset to ``I``; ``M^-1`` is only applied to a well-conditioned ``M``.

Odometry calibration errors as consider parameters (issue 12). A steered vehicle's
odometry errs systematically too: the drive wheel's radius by a scale ``eps``, the steering
zero by an offset ``beta``, the same in every step. Left out (or taken as white noise) they
make the heading overconfident on every straight; the filter given a
:class:`~agvnav.odometry.SteeredOdometryNoise` with a calibration tolerance keeps
``c = (eps, beta)`` as two more consider parameters, fixed covariance
``P_cc = diag(radius_scale_std^2, steering_offset_std^2)``, cross-covariance ``P_xc`` (3 x 2,
kept explicit: six floats):

* predict: with ``W = G B`` (3 x 2) the pose's sensitivity to ``c`` over the increment
  (:func:`~agvnav.positioning._fast.steered_noise`), the augmented transition
  ``[[F, W], [0, I]]`` gives ``P <- F P F^T + Q + (F P_xc) W^T + W (F P_xc)^T + W P_cc W^T``
  and ``P_xc <- F P_xc + W P_cc`` (:func:`~agvnav.positioning._fast.calibration_predict`);
* any update (no measurement sees ``c``): ``P_xc <- A P_xc``
  (:func:`~agvnav.positioning._fast.calibration_update`).

Consider rather than estimated calibration states: the pose stays the 3-state every fast
path (gate, Joseph and Schmidt updates, the integrity monitor's checks) is written for, a
prediction costs ~40 more flops and an update ~12, and the reported covariance is honest
for whatever the calibration really is within its tolerance. Estimating ``c`` would also
shrink the error (the reflectors observe the heading drift), at the price of a 5-state
filter throughout; ``tests/positioning/test_calibration_consider.py`` checks the consider
form against the augmented-state reference.

Because every bearing updates the state at the instant it was measured, the motion
between reflections never enters the measurement: this is the filter-based answer to
the problem of seed 000 §2.2, which the seeds instead solve by propagating the angles.
Seed 000 §2.2 argues the errors of raw dynamic triangulation are not Gaussian; here the
filter never sees those errors, only the bearing noise and the odometry noise.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import wrap_angle
from agvnav.positioning import _fast
from agvnav.positioning.estimator import StreamingEstimator
from agvnav.positioning.identification import Association
from agvnav.positioning.wall_ranges import WallRangeModel

__all__ = ["CONSIDER_MAX_ENTRY", "CONSIDER_MIN_DET", "EkfEstimator", "ekf_predict", "ekf_update"]

#: ``M`` of the factored ``P_xp = M C^T`` is folded into ``C`` below this ``|det M|`` ...
CONSIDER_MIN_DET = 0.05
#: ... or above this largest ``|M_ik|`` (keeps ``M^-1`` well conditioned, see the module docstring).
CONSIDER_MAX_ENTRY = 20.0

_IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


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
    consider = True

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
        self._gate_consts = _fast.gate_constants(  # the compiled update's fold limits and P_xc too
            self._spec, self._mount_t, self._grid_consts, self.bearing_std**2, CONSIDER_MIN_DET, CONSIDER_MAX_ENTRY,
            self._calibration_var != (0.0, 0.0),
        )
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
        if not hasattr(self, "_C"):  # no initial pose: the consider state starts with the search
            self._consider_reset()

    @property
    def covariance(self) -> NDArray[np.float64]:
        """``(3, 3)`` covariance of :attr:`pose` (m², rad²; NaN while initialising).

        The consider filter's ``P`` alone: it already holds the reflectors' survey errors
        (module docstring), so no survey floor is added (the fix-based estimators add one).
        At standstill it converges to the monitor's survey floor (within 2 %,
        ``tests/positioning/test_integrity.py``).

        Consistency over 200 runs (``agvnav bench consistency``, seeds 0-199, band 2.67-3.35;
        position part band 1.73-2.29, heading 0.81-1.21), with the tricycles' exact wheel model
        and their radius scale and steering offset as consider parameters
        (:class:`~agvnav.odometry.SteeredOdometryNoise`), each run's truth radius and steering
        errors drawn from the filter's stated tolerance (0.3 %, 0.2 deg std;
        :func:`agvnav.bench.consistency.draw_calibration`): NEES guidance_test 2.85 (position
        1.92, heading 0.92), seed000_guidance_agvnav 2.79 (1.90, 0.88), seed000_positioning_agvnav
        2.78 (1.87, 0.88), tricycle_rear_loop 2.97 (2.04, 0.94): all inside, parts too. With the
        truth fixed at the tolerance in every run (the ``(truth as shipped)`` rows, 40 runs, band
        2.29-3.81): 2.74, 2.75, 2.74, 2.87 (200 runs before the draw: 2.80, 2.73, 2.80, 2.91).
        Before the wheel model, with Crowley's bound of the random errors alone:
        2.47, 2.34, 2.57 (heading 0.57-0.68, pessimistic) and 3.34 (heading 1.38, optimistic).
        differential_loop (Crowley's coefficients of its slip; its wheel-diameter and track
        errors not modelled) stays 2.38 (heading 0.68), below its band. Without any survey or
        systematic error (truth and filter), guidance_test gives 1.84 (position 1.11, heading 0.49; 20 runs):
        the survey and calibration terms dominate the shipped figures, and something else is
        still pessimistic. Candidates, not measured: the bearing noise taken as white
        quantisation, and the truth's slip drawn once per control step while the engine splits
        a step's odometry at each reflection into pieces the filter takes as independent
        (variance ``f`` instead of ``f^2`` of the step's for a fraction ``f``).
        """
        return self._P

    @property
    def cross_covariance(self) -> NDArray[np.float64]:
        """``(3, 2N)`` ``P_xp``: covariance of the pose error with the reflectors' survey errors (m², m rad).

        Columns ``2j, 2j+1``: reflector j's x and y error (map rows).
        """
        return np.asarray(self._M).reshape(3, 3) @ self._C.reshape(-1, 3).T

    @property
    def calibration_cross_covariance(self) -> NDArray[np.float64]:
        """``(3, 2)`` ``P_xc``: covariance of the pose error with the odometry calibration errors.

        Columns: the drive-wheel radius scale error (m, m, rad per unit scale) and the
        steering offset (m rad, m rad, rad²); zero unless the odometry noise is a
        :class:`~agvnav.odometry.SteeredOdometryNoise` with a calibration tolerance.
        """
        return np.asarray(self._Pxc, dtype=np.float64).reshape(3, 2)

    # ------------------------------------------------------------------ consider state
    def _consider_reset(self) -> None:
        n = self.reflector_xy.shape[0]
        self._M: tuple[float, ...] = _IDENTITY
        self._C = np.zeros((n, 6))
        self._svar = (self.survey_std**2).tolist()
        self._Pxc: tuple[float, ...] = (0.0,) * 6
        self._calibrated = self._calibration_var != (0.0, 0.0)

    def _consider_args(self, f02: float, f12: float) -> Any:
        M = self._M if f02 == 0.0 and f12 == 0.0 else _fast.shear(self._M, f02, f12)
        return M, self._C, self._svar

    def _consider_factors(self) -> tuple[tuple[float, ...], NDArray[np.float64]]:
        return self._M, self._C

    def _move_factors(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        return self._M, self._Pxc

    def _moved_factors(self, M: tuple[float, ...], X: tuple[float, ...]) -> None:
        self._M, self._Pxc = M, X

    def _fold(self, M: tuple[float, ...]) -> None:
        """``C <- C M^T`` (``P_xp = M C^T`` unchanged) and ``M <- I``: O(N), rare."""
        C3 = self._C.reshape(-1, 3)
        C3[...] = C3 @ np.asarray(M).reshape(3, 3).T
        self._M = _IDENTITY

    def _fold_into_row(self, M: tuple[float, ...], K: Sequence[float], j: int, h0: float, h1: float) -> None:
        """Fold ``M`` (:meth:`_fold`), then add reflector ``j``'s new ``P_xp`` columns ``K (h0, h1) svar_j``.

        The compiled update's folded case: the same operations as the folded branch of :meth:`_accept`.
        """
        self._fold(M)
        svar = self._svar[j]
        u0, u1, u2 = K
        row = self._C[j].tolist()
        ax, ay = h0 * svar, h1 * svar
        self._C[j] = (row[0] + u0 * ax, row[1] + u1 * ax, row[2] + u2 * ax, row[3] + u0 * ay, row[4] + u1 * ay,
                      row[5] + u2 * ay)

    def _left(self, K: Sequence[float], H: Sequence[float]) -> tuple[float, ...]:
        """``M <- (I - K H) M``; returns the new ``M`` folded to ``I`` when ill-conditioned."""
        M = _fast.left_update(self._M, K, H)
        if not (abs(_fast.det3(M)) >= CONSIDER_MIN_DET and max(map(abs, M)) <= CONSIDER_MAX_ENTRY):
            self._fold(M)
            M = _IDENTITY
        self._M = M
        return M

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
        try:
            t = self._check_time(t, "ranges")
            if self._t is not None and t > self._t + 1e-9:
                raise ValueError(
                    f"ranges at t={t!r} s are ahead of the latest odometry at t={self._t!r} s; predict first"
                )
        except ValueError as exc:  # a running vehicle drops them (counted)
            self._refuse(self.t, "ranges_time", str(exc))
            return 0
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
            K = _fast.gain(self._P_t, assoc.H, assoc.R)
            self._x_t, self._P_t = _fast.joseph_update(self._x_t, self._P_t, assoc.innovation, assoc.H, assoc.R)
            self._left(K, tuple(assoc.H))  # P_xp <- (I - K H) P_xp: a range does not see the survey errors
            if self._calibrated:
                self._Pxc = _fast.calibration_update(self._Pxc, K, tuple(assoc.H))
            self.last_range = assoc
            fused += 1
        self.n_ranges_accepted += fused
        if fused:
            self._t_last_accept = t
        self._judge_state(t)
        return fused

    def _gate_accept(self, t: float, z: float) -> Association:
        """:meth:`_gate` and :meth:`_accept` in one compiled call (:func:`~agvnav.positioning._fast.gate_accept`).

        The same numbers as the two methods; a fold of ``M`` (rare) is finished here, as
        :meth:`_accept` does it.
        """
        sight = self._sight(t)
        (j, y, nis, n_in, h0, h1, h2, S, R), x1, P1, K, M, X, fold = _fast.gate_accept(
            z, t, self._x_t, self._P_t, self._M, self._Pxc, self._C, self._claimed,
            self._in_sight_all if sight is None else sight, self._gate_tab, self._gate_consts, *self._gate_grid,
        )
        assoc = Association(j, y, nis, n_in, np.array((h0, h1, h2)), S, R)
        if j < 0:
            return assoc
        self._x_t, self._P_t, self._Pxc = x1, P1, X
        if fold:  # as _left and the folded branch of _accept
            self._fold_into_row(M, K, j, h0, h1)
        else:
            self._M = M
        self.last_innovation = y
        self.last_nis = nis
        self.last_reflector = j
        return assoc

    def _accept(self, t: float, bearing: float, assoc: Any) -> None:
        """The Schmidt-Kalman update of one identified bearing (module docstring).

        One kernel call (:func:`~agvnav.positioning._fast.schmidt_accept`), unless ``M`` must be
        folded: then the fold and reflector ``j``'s row are done here (:meth:`_fold_into_row`).
        """
        j = assoc.index
        h0, h1 = float(assoc.H[0]), float(assoc.H[1])
        H = (h0, h1, float(assoc.H[2]))
        self._x_t, self._P_t, K, M, self._Pxc, fold = _fast.schmidt_accept(
            self._x_t, self._P_t, self._M, self._Pxc, self._C, j, self._svar[j], assoc.innovation, H,
            self.bearing_std**2, self._calibrated, CONSIDER_MIN_DET, CONSIDER_MAX_ENTRY,
        )
        if fold:  # as _left
            self._fold_into_row(M, K, j, h0, h1)
        else:
            self._M = M
        self.last_innovation = assoc.innovation
        self.last_nis = assoc.nis
        self.last_reflector = assoc.index
