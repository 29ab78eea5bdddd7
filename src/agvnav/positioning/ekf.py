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
  (:func:`~agvnav.positioning.edge_bearing.bearing_model`, seed 000 §2.1),
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
from agvnav.positioning.bearing_gate import Association
from agvnav.positioning.ekf_core import CONSIDER_MAX_ENTRY, CONSIDER_MIN_DET, ConsiderState, Linearisation
from agvnav.positioning.estimator import StreamingEstimator
from agvnav.positioning.wall_ranges import RangeAssociation, WallRangeModel

__all__ = ["CONSIDER_MAX_ENTRY", "CONSIDER_MIN_DET", "EkfEstimator", "ekf_predict", "ekf_update"]


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
        assoc = self.association
        assoc.consts = _fast.gate_constants(  # the compiled update's fold limits and P_xc too
            assoc.spec, assoc.mount_t, assoc.grid_consts, self.bearing_std**2, CONSIDER_MIN_DET, CONSIDER_MAX_ENTRY,
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
        self.last_range: RangeAssociation | None = None

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
    def _consider(self) -> ConsiderState:
        c = self.core.consider
        assert c is not None  # a consider filter's core always holds one
        return c

    @property
    def cross_covariance(self) -> NDArray[np.float64]:
        """``(3, 2N)`` ``P_xp``: covariance of the pose error with the reflectors' survey errors (m², m rad).

        Columns ``2j, 2j+1``: reflector j's x and y error (map rows).
        """
        return self._consider.cross_covariance()

    @property
    def calibration_cross_covariance(self) -> NDArray[np.float64]:
        """``(3, 2)`` ``P_xc``: covariance of the pose error with the odometry calibration errors.

        Columns: the drive-wheel radius scale error (m, m, rad per unit scale) and the
        steering offset (m rad, m rad, rad²); zero unless the odometry noise is a
        :class:`~agvnav.odometry.SteeredOdometryNoise` with a calibration tolerance.
        """
        return np.asarray(self._consider.Pxc, dtype=np.float64).reshape(3, 2)

    def update_ranges(self, t: float, ranges: Mapping[str, float]) -> int:
        """Ultrasonic readings ``{sensor: range (m)}`` made at ``t`` (s); returns how many were fused.

        One update of the core per reading whose nearest modelled wall passes the
        chi-square gate [seed004 eq8] (a side pair's two ranges also fix the heading,
        as [seed004 eq6] [seed004 eq7] do): the measurement model
        :class:`~agvnav.positioning.measurement.WallRangeMeasurement`
        (:meth:`~agvnav.positioning.wall_ranges.WallRangeModel.measurement`). nan readings
        (no echo) are skipped. The ranges must come after :meth:`predict` up to ``t``.
        """
        if self.wall_ranges is None:
            raise ValueError(
                "this estimator was built without walls and rangers (make_estimator(..., walls=, rangers=))"
            )
        self.wall_ranges.check_names(list(ranges))
        inputs = self.inputs
        try:
            t = inputs.check_time(t, "ranges")
            if inputs.t is not None and t > inputs.t + 1e-9:
                raise ValueError(
                    f"ranges at t={t!r} s are ahead of the latest odometry at t={inputs.t!r} s; predict first"
                )
        except ValueError as exc:  # a running vehicle drops them (counted)
            inputs.refuse(inputs.now, "ranges_time", str(exc))
            return 0
        inputs.t = t
        if not self.core.has_pose():
            return 0
        fused = 0
        for name, r in ranges.items():
            if not math.isfinite(r):
                continue
            model = self.wall_ranges.measurement(name, float(r), self.core.x, self.gate)
            if model is None:
                self.n_ranges_rejected += 1
                continue
            step = self.core.update(model, float(r), t)
            self._keep_step(step)
            if not step[11]:
                self.n_ranges_rejected += 1
                continue
            y, S, H = step[6], step[7], model.jacobian(step[4])
            self.last_range = RangeAssociation(model.index, y, H, model.range_var, S, y * y / S)
            fused += 1
        self.n_ranges_accepted += fused
        if fused:
            self._t_last_accept = t
        self._judge_state(t)
        return fused

    def _gate_accept(self, t: float, z: float) -> tuple[Association, Sequence[float]]:
        """:meth:`_gate` and :meth:`_accept` in one compiled call (:func:`~agvnav.positioning._fast.gate_accept`).

        The bearing model's compiled form: the same numbers as the core's update with a
        :class:`~agvnav.positioning.measurement.BearingMeasurement` (to 1e-12,
        ``tests/positioning/test_ekf_core.py``); a fold of ``M`` (rare) is finished here.
        """
        a, core, c = self.association, self.core, self._consider
        sight = a.sight(t, core.x)
        (j, y, nis, n_in, h0, h1, h2, S, R), x1, P1, K, M, X, fold = _fast.gate_accept(
            z, t, core.x, core.P, c.M, c.Pxc, c.C, a.claimed, a.in_sight_all if sight is None else sight,
            a.table, a.consts, *a.grid,
        )
        assoc = Association(j, y, nis, n_in, np.array((h0, h1, h2)), S, R)
        if j < 0:
            return assoc, K
        core.x, core.P, c.Pxc = x1, P1, X
        c.keep(M, K, fold, j, h0, h1)
        self.last_innovation = y
        self.last_nis = nis
        self.last_reflector = j
        return assoc, K

    def _accept(self, t: float, bearing: float, assoc: Association) -> Sequence[float]:
        """The Schmidt-Kalman update of one identified bearing (module docstring), by the core.

        The gate's linearisation (innovation, ``H``) with ``R = sigma_b^2`` and the reflector's
        survey error as the consider block (``H_p = -H[:2]``).
        """
        H = (float(assoc.H[0]), float(assoc.H[1]), float(assoc.H[2]))
        lin = Linearisation(assoc.innovation, H, self.bearing_std**2, assoc.index, (-H[0], -H[1]))
        step = self.core.apply(lin, t, "bearing", assoc.index, bearing)
        self.last_innovation = assoc.innovation
        self.last_nis = assoc.nis
        self.last_reflector = assoc.index
        return step[8]
