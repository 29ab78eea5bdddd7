"""The streaming positioning interface shared by every method, assembled from parts, and the factory by name.

One object serves a real vehicle and the simulator alike: feed timestamped odometry
increments of base_link (:meth:`StreamingEstimator.predict`) and raw anonymous
reflections (:meth:`StreamingEstimator.update`) in time order; read ``t``, ``pose``,
``covariance`` and ``status`` of the latest estimate at any moment, and the latest
measurement step (:attr:`StreamingEstimator.last_step`, an
:class:`~agvnav.positioning.ekf_core.EkfStep`; every step with
:meth:`StreamingEstimator.record_steps`).

The estimator is assembled from parts, each a module with its own state:

* :class:`~agvnav.positioning.inputs.InputChecks` -- time order, plausibility of every
  input, the odometry clock (the rate of the last increment, the odometry extrapolated to
  a reflection and deducted from the next increment);
* :class:`~agvnav.positioning.ekf_core.EkfCore` -- the pose, ``P`` and the consider state:
  ``P' = F P F^T + Q`` [seed002 eq14] from each increment (the SE(2) exponential, the
  seed-002 arc rule [seed002 eq25], seed 002's noise model [seed002 eq17]), and the update
  by any :class:`~agvnav.positioning.measurement.MeasurementModel`;
* :class:`~agvnav.positioning.association.BearingAssociation` -- which reflector made an
  anonymous reflection (the chi-square gate, claims per sweep, line of sight);
* :mod:`agvnav.positioning.lifecycle` -- the status, the start-up and relocalisation
  search, the lock-out watch; and the :class:`~agvnav.positioning.integrity.IntegrityMonitor`.

The class itself stands on two bases: :class:`~agvnav.positioning.readout.EstimatorReadout`
(the read side: pose, covariance, status, counters, measurement steps) and
:class:`~agvnav.positioning.supervision.EstimatorSupervision` (start, loss, lock-out and the
wiring of the integrity monitor); this module assembles the parts and feeds them.

What differs between the methods -- how an identified reflection corrects the pose -- is
the subclass's ``_accept`` (:mod:`agvnav.positioning.ekf`: a measurement-model update;
:mod:`agvnav.positioning.dynamic`: a triangulated fix). The methods are created by name
with :func:`make_estimator`: each concrete class names itself in its ``method`` attribute
and registers when it is defined (``__init_subclass__``).

Speed: one call handles one increment or one reflection; a prediction is one kernel call
(:func:`~agvnav.positioning._fast.move_state`) and the gate one more
(:func:`~agvnav.positioning._fast.gate_rows`; the EKF's gate and bearing update together,
:func:`~agvnav.positioning._fast.gate_accept`), on state kept as Python floats.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import as_float_array, require_finite, require_nonnegative, require_positive
from agvnav.odometry import OdometryNoise
from agvnav.positioning import _fast
from agvnav.positioning.association import BearingAssociation
from agvnav.positioning.bearing_gate import CHI2_1DOF_999, Association
from agvnav.positioning.bounds import encoder_bearing_std
from agvnav.positioning.ekf_core import EkfCore, EkfStep, RawStep, noise_constants
from agvnav.positioning.gating import GateSpec
from agvnav.positioning.inputs import InputChecks
from agvnav.positioning.integrity import IntegrityLimits, IntegrityMonitor
from agvnav.positioning.lifecycle import (  # noqa: F401 - MAX_INFLATED_POSITION_VAR re-exported
    MAX_INFLATED_POSITION_VAR,
    STATUSES,
    LockoutWatch,
    StartUp,
)
from agvnav.positioning.plausibility import PlausibilityLimits, check_covariance
from agvnav.positioning.supervision import EstimatorSupervision

__all__ = ["METHODS", "STATUSES", "StreamingEstimator", "make_estimator"]

#: Method names accepted by :func:`make_estimator` (seed 000 §2.2 and issue 4 §4).
METHODS = ("naive", "angle_propagation", "batch_ml", "ekf")


_NAN3 = (math.nan,) * 3

#: The concrete estimator classes by method name, filled as they are defined.
_ESTIMATORS: dict[str, type[StreamingEstimator]] = {}

class StreamingEstimator(EstimatorSupervision):
    """Base of the streaming estimators: assembles the parts (module docstring), keeps the counters.

    Parameters
    ----------
    world:
        A :class:`~agvnav.world.WorldMap` (only ``reflector_xy`` and ``reflector_radius`` are read).
    mount:
        ``(3,)`` pose of the goniometer head centre P in base_link (m, rad).
    bearing_std:
        Std (rad) of one bearing; default the encoder quantisation of ``pulses_per_rev``.
    odometry_noise:
        :class:`~agvnav.odometry.OdometryNoise` for the covariance growth ``Q``; a
        :class:`~agvnav.odometry.SteeredOdometryNoise` gives a steered vehicle's exact
        model instead (:func:`~agvnav.positioning._fast.steered_noise`), and the EKF keeps
        its calibration errors as consider parameters (:mod:`agvnav.positioning.ekf`);
        the other methods, which keep no consider parameters, take its Crowley bound
        (the inherited ``k_d, k_dtheta, k_theta``; the exact random part alone would leave
        the calibration errors out).
    k_lateral:
        Variance of the lateral increment per metre of sideways travel (m²/m), the
        holonomic extension of ``Q`` (see :meth:`predict`); default ``odometry_noise.k_d``,
        the same error per metre across as along.
    initial_pose, initial_covariance:
        ``(3,)`` base_link pose in ``map`` and ``(3, 3)`` covariance; without them the
        estimator starts ``"initialising"`` and searches the pose from one revolution of
        reflections at standstill.
    rate_hz:
        Head rotation rate (Hz): one revolution is the "sweep" in which a reflector can be
        claimed only once, and the time the start-up search collects.
    max_range:
        Reflectors farther than this (m) are never predicted visible.
    dead_reckoning_after:
        Seconds without an accepted reflection after which ``status`` becomes
        ``"dead_reckoning"`` (the covariance then keeps growing with the odometry).
    gate:
        Chi-square threshold (1 dof) on the innovation of one bearing.
    map_std:
        Survey error std (m) of the reflector positions; adds ``(map_std / d)^2`` to the
        variance of a bearing at distance d (seed 000 §4.1: topographically measured).
        A map stating a reflector's ``survey_std_m`` raises it to the largest one in the
        gate (conservative: the gate takes one value) and sets that reflector's own value
        in the survey floor of :attr:`covariance`. The EKF instead keeps each reflector's
        survey error as a consider parameter of std :attr:`survey_std` (the map's
        ``survey_std_m``, else ``map_std``; :mod:`agvnav.positioning.ekf`).
    bearing_offset:
        Added to every reported bearing (rad). Default half a pulse, ``pi / pulses_per_rev``:
        an incremental encoder reports the last whole pulse passed, so a CCW head's reading
        lags the beam by half a pulse on average (:meth:`~agvnav.sensors.goniometer.Goniometer.encoder_bearing`).
    strict:
        True (the API): an implausible or non-finite input raises ValueError. False (a
        running vehicle, the simulator): it is dropped and counted in :attr:`n_dropped`
        per reason; one bad reading never aborts a run.
    plausibility:
        :class:`~agvnav.positioning.plausibility.PlausibilityLimits` (max speed and yaw
        rate, max odometry gap, late-reflection window).
    integrity:
        :class:`~agvnav.positioning.integrity.IntegrityLimits` of the integrity monitor
        (issue 12): it makes ``status`` ``"degraded"`` (covariance inflated) or ``"lost"``
        when the support of the estimate fails; lost, the estimator stops correcting and
        relocalises with :func:`~agvnav.positioning.identification.initial_pose_search`
        once a revolution of reflections at standstill is collected, accepting only an
        unambiguous pose (``ambiguous`` reports the other case; ``n_relocalisations``)
        and within reach of the last trusted one: no farther from the pose of the last
        reflection accepted with the verdict ok than ``plausibility.max_speed_m_s`` times the time since, plus
        3 sigma of that pose and ``plausibility.slack_m`` (``n_unreachable`` counts the
        refused ones). Odometry that reads zero while the vehicle moves (an encoder
        dropout) makes the estimator believe it stands still, and a revolution of
        bearings taken on the move can fit a wrong pose metres away.
    """

    method: ClassVar[str] = "base"
    #: Whether a late reflection (within ``plausibility.late_window_s``) is applied at its
    #: own instant through the odometry (:meth:`_late`); else it is dropped as ``"late"``.
    late_updates: ClassVar[bool] = False
    #: Whether the estimator keeps the reflectors' survey errors (and the odometry calibration
    #: errors) as Schmidt-Kalman consider parameters (the EKF): its core then holds a
    #: :class:`~agvnav.positioning.ekf_core.ConsiderState`, and its gate takes the consider ``S``.
    consider: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Register a concrete estimator under its ``method`` name (one of :data:`METHODS`)."""
        super().__init_subclass__(**kwargs)
        name = cls.__dict__.get("method")
        if name in METHODS and name not in _ESTIMATORS:
            _ESTIMATORS[name] = cls

    def __init__(
        self,
        world: Any,
        mount: ArrayLike = (0.0, 0.0, 0.0),
        *,
        bearing_std: float | None = None,
        pulses_per_rev: int = 65535,
        bearing_offset: float | None = None,
        map_std: float = 0.001,
        odometry_noise: OdometryNoise | None = None,
        k_lateral: float | None = None,
        initial_pose: ArrayLike | None = None,
        initial_covariance: ArrayLike | None = None,
        rate_hz: float = 8.0,
        max_range: float = 30.0,
        dead_reckoning_after: float = 1.0,
        gate: float = CHI2_1DOF_999,
        strict: bool = True,
        plausibility: PlausibilityLimits | None = None,
        integrity: IntegrityLimits | None = None,
    ) -> None:
        self.reflector_xy = np.asarray(world.reflector_xy, dtype=np.float64)
        self.reflector_radius = np.asarray(world.reflector_radius, dtype=np.float64)
        self.mount = require_finite("mount", mount)
        if self.mount.shape != (3,):
            raise ValueError(f"mount must have shape (3,), got {self.mount.shape}")
        std = encoder_bearing_std(int(pulses_per_rev)) if bearing_std is None else bearing_std
        self.bearing_std = require_positive("bearing_std", std)
        offset = np.pi / int(pulses_per_rev) if bearing_offset is None else bearing_offset
        self.bearing_offset = float(require_finite("bearing_offset", offset))
        survey = np.asarray(getattr(world, "reflector_survey_std", np.zeros(len(self.reflector_radius))), float)
        map_std = require_nonnegative("map_std", map_std)
        self.map_std = max(map_std, float(survey.max(initial=0.0)))
        #: ``(N,)`` survey std of each reflector (m per axis): the map's ``survey_std_m``, else ``map_std``.
        self.survey_std = np.where(survey > 0.0, survey, map_std)
        self.odometry_noise = OdometryNoise() if odometry_noise is None else odometry_noise
        k_lat = self.odometry_noise.k_d if k_lateral is None else k_lateral
        self.k_lateral = require_nonnegative("k_lateral", k_lat)
        self.rate_hz = require_positive("rate_hz", rate_hz)
        self.max_range = require_positive("max_range", max_range)
        self.dead_reckoning_after = require_positive("dead_reckoning_after", dead_reckoning_after)
        self.gate = require_positive("gate", gate)
        #: The input part: time order, plausibility, the odometry clock.
        self.inputs = InputChecks(strict, PlausibilityLimits() if plausibility is None else plausibility)
        self.monitor = IntegrityMonitor(
            self.reflector_xy, self.reflector_radius, self.mount, self.bearing_std, 1.0 / self.rate_hz, integrity,
            map_std=np.maximum(survey, map_std), max_range=self.max_range,
            walls=getattr(world, "wall_segments", None),
            odometry_noise=(self.odometry_noise.k_d, self.odometry_noise.k_dtheta, self.odometry_noise.k_theta),
        )
        lim = self.inputs.plausibility
        #: The lifecycle parts: start-up / relocalisation search and the lock-out watch.
        self.startup = StartUp(self.reflector_xy, self.reflector_radius, self.mount, self.bearing_std,
                               1.0 / self.rate_hz, self.max_range, self.gate, self.map_std, lim.max_speed_m_s,
                               lim.slack_m)
        self.lockout = LockoutWatch(1.5 / self.rate_hz)
        spec = GateSpec(self.bearing_std**2, self.max_range, self.gate, self.map_std, 0.75 / self.rate_hz,
                        self.consider)
        #: The association part: the gate, the claims per sweep, the line of sight.
        self.association = BearingAssociation(
            self.reflector_xy, self.reflector_radius, self.mount, spec, self.bearing_std**2,
            self.survey_std**2 if self.consider else None, self.monitor.walls, self.monitor.max_range,
            1.0 / self.rate_hz,
        )
        #: The filter core: pose, covariance and (EKF) the consider state.
        consts, self._calibration_var = noise_constants(self.odometry_noise, self.k_lateral, self.consider)
        self.core = EkfCore(consts, self._new_consider())
        self.n_accepted = 0
        self.n_rejected = 0
        self.n_inflations = 0
        self._t_last_accept: float | None = None
        self._step: RawStep | None = None
        self._recorder: Callable[[EkfStep], None] | None = None
        if initial_covariance is not None:
            check_covariance("initial_covariance", initial_covariance)
        if initial_pose is not None:
            self._start(initial_pose, initial_covariance)

    # ------------------------------------------------------------------ feed
    def predict(self, t: float, delta_d: float, delta_theta: float, delta_lateral: float = 0.0) -> None:
        """Odometry increment of base_link since the previous call, as a body twist.

        Parameters
        ----------
        t:
            Time (s) the increment runs to, from the previous :meth:`predict`.
        delta_d:
            ``integral v_x dt`` (m): distance along the body x axis (for the tricycle
            ``ds_C cos(gamma)`` [seed000 eq8]).
        delta_theta:
            ``integral omega dt`` (rad): heading change (tricycle: ``ds_C sin(gamma) / L``).
        delta_lateral:
            ``integral v_y dt`` (m): sideways distance along the body y axis, for
            holonomic vehicles (mecanum); 0 for every non-holonomic one.

        Notes
        -----
        The pose moves by the SE(2) exponential of the increment, exact for a constant
        twist over the step (for ``delta_lateral = 0`` the seed-002 arc rule
        [seed002 eq25]); ``P' = F P F^T + Q`` [seed002 eq14] with ``F`` the exponential's
        Jacobian with respect to the pose and ``Q = J diag(var_d, var_th, var_l) J^T``
        [seed002 eq17], ``J`` its Jacobian with respect to the increment to leading order
        (see :func:`agvnav.positioning._fast.process_noise`): ``var_d = K_D |delta_d|``,
        ``var_th = K_Dtheta hypot(delta_d, delta_lateral) + K_theta |delta_theta|`` and the
        holonomic term ``var_l = k_lateral |delta_lateral|``.
        A :class:`~agvnav.odometry.SteeredOdometryNoise` replaces this ``Q`` by its exact
        rank-one model of the drive wheel's slip and steering error (issue 12). A refused
        increment (implausible, a time gap) is replaced by the motion at the last rate and
        the variances grow by what the vehicle could have done instead
        (:meth:`~agvnav.positioning.inputs.InputChecks.odometry`).
        """
        checked = self.inputs.odometry(t, delta_d, delta_theta, delta_lateral)
        if checked is None:
            return
        t, dd, dth, dl, blow = checked
        if blow is not None:
            self._blow_up(*blow)
        self.core.predict(*self.inputs.take_odometry(t, dd, dth, dl))
        if abs(dd) > 1e-9 or abs(dth) > 1e-9 or abs(dl) > 1e-9:
            self.startup.buffer.clear()  # the start-up search and relocalisation need a standing vehicle
        if self.monitor.due(t):  # _watch_integrity(t) returns at once otherwise (issue 11: one call fewer)
            self._watch_integrity(t)
        self._judge_state(t)

    def _blow_up(self, span: float, rate: tuple[float, float, float]) -> None:
        """Grow the position and heading variances for ``span`` s of unknown motion (a refused increment)."""
        d2, a2 = self.inputs.blow_up_variances(span, rate)
        P = list(self.core.P)
        P[0], P[4], P[8] = P[0] + d2, P[4] + d2, P[8] + a2
        self.core.P = tuple(P)

    def update(self, t: float, bearing: float) -> bool:
        """One raw anonymous reflection: time ``t`` (s), head-frame bearing (rad) of its start.

        Returns True when the reflection was identified and used, False when rejected
        (spurious, ambiguous, already claimed in this sweep) or buffered for start-up.
        """
        inputs = self.inputs
        checked = inputs.reflection(t, bearing, self.bearing_offset)
        if checked is None:
            return False
        t, z = checked
        if inputs.t is not None and t < inputs.t:
            accepted = self._late(t, z)
            self._judge_state(t)
            return accepted
        ahead = inputs.extrapolate(t)
        if ahead is not None:
            self.core.predict(*ahead)
        inputs.t = t
        core = self.core
        if not core.has_pose() or self.monitor.verdict == "lost":
            self.startup.buffer.append((t, z))
            self._try_start()
            self._judge_state(t)
            return False
        before = (core.x, core.P)  # the prior of the fused call's update
        # the gate and the update in one call -- unless an acceptance may inflate P in
        # the lock-out watch between them (its window and counts do not depend on the state)
        fused = self.consider and not self.lockout.would_trigger(t)
        assoc, K = self._gate_accept(t, z) if fused else (self._gate(t, z), None)
        accepted = self._after_gate(t, z, assoc, K, before)
        self._judge_state(t)
        return accepted

    def _after_gate(
        self, t: float, z: float, assoc: Association, K: Sequence[float] | None,
        before: tuple[tuple[float, ...], tuple[float, ...]],
    ) -> bool:
        """:meth:`update` once the reflection ``(t s, z rad)`` is gated: lock-out watch, counters, the update, monitor.

        ``K`` not None: :meth:`_gate_accept` already made the update with that gain (then
        ``before`` is its prior ``(x, P)``); else :meth:`_accept` makes it here when the gate
        identified a reflector.
        """
        if assoc.index >= 0 or assoc.n_in_gate == 0:  # an ambiguous gate says nothing of a lock-out
            self._watch_lockout(t, assoc.index >= 0)
        if assoc.index < 0:
            self.n_rejected += 1
            x, P = self.core.x, self.core.P
            reason = "outside_gate" if assoc.n_in_gate == 0 else "ambiguous"
            self._keep_step((t, "bearing", -1, z, x, P, math.nan, math.nan, _NAN3, x, P, False, reason))
            if assoc.n_in_gate == 0:  # off its prediction; an ambiguous one has its reflector in the gate
                self.monitor.rejected(t)
                self._attribute(t, z)
            return False
        self.n_accepted += 1
        self.association.claimed[assoc.index] = t
        self._t_last_accept = t
        if K is None:
            before = (self.core.x, self.core.P)  # after a lock-out inflation, the prior the update sees
            K = self._accept(t, z, assoc) or _NAN3
        x1, P1 = self.core.x, self.core.P
        self._keep_step((t, "bearing", assoc.index, z, before[0], before[1], assoc.innovation, assoc.S, K, x1, P1,
                         True, "accepted"))
        if self.monitor.verdict == "ok":
            self.startup.trusted = (x1[0], x1[1], P1[0] + P1[4], t)
        self.monitor.accepted(t, assoc.nis, assoc.index, z, self.core.odom, self._correction(*before),
                              self._innovation(assoc.innovation, assoc.S, assoc.H))
        self._watch_integrity(t)
        return True

    def update_many(self, t: ArrayLike, bearings: ArrayLike) -> NDArray[np.bool_]:
        """Several reflections in time order: ``t (k,)``, ``bearings (k,)`` -> accepted ``(k,)``."""
        tt = np.atleast_1d(as_float_array("t", t))
        zz = np.atleast_1d(as_float_array("bearings", bearings))
        if tt.shape != zz.shape:
            raise ValueError(f"t and bearings must have the same shape, got {tt.shape} and {zz.shape}")
        return np.array([self.update(float(a), float(b)) for a, b in zip(tt, zz, strict=True)], dtype=bool)

    # ------------------------------------------------------------------ association
    def _gate(self, t: float, z: float) -> Association:
        """The association part's gate on the current estimate (:meth:`BearingAssociation.gate`)."""
        c = self.core.consider
        if c is None:
            return self.association.gate(t, z, self.core.x, self.core.P)
        return self.association.gate(t, z, self.core.x, self.core.P, c.M, c.C)

    def _gate_accept(self, t: float, z: float) -> tuple[Association, Sequence[float]]:  # pragma: no cover
        """:meth:`_gate` and, when it identifies a reflector, :meth:`_accept`, in one kernel call (consider only)."""
        raise NotImplementedError

    def _accept(self, t: float, bearing: float, assoc: Association) -> Sequence[float]:  # pragma: no cover
        """Correct the pose with the identified reflection; returns the gain (NaN when there is none)."""
        raise NotImplementedError

    def _late(self, t: float, z: float) -> bool:
        """A reflection up to ``late_window_s`` late: gated and applied at its own instant.

        The pose then is the current one moved back along the last odometry rate
        (``x_r = x (+) exp(-rate (t_now - t))``, :func:`~agvnav.positioning._fast.twist_step`),
        with ``P_r = F P F^T`` (and a consider filter's ``P_xp,r = F P_xp``); the
        measurement row on the current state is ``H_r F`` (``F = d x_r / d x``), so the
        update corrects the current pose.
        """
        core = self.core
        if not self.late_updates or not core.has_pose() or self.monitor.verdict == "lost":
            self.inputs.refuse(t, "late", f"reflection at t={t!r} s arrived after t={self.inputs.t!r} s")
            return False
        span = self.inputs.late_span(t)
        rate = self.inputs.rate
        back = (-rate[0] * span, -rate[1] * span, -rate[2] * span)
        x, y, psi = core.x
        xr, yr, psir, f02, f12 = _fast.twist_step(x, y, psi, *back)
        P_r = _fast.predict_covariance(core.P, f02, f12, (0.0,) * 9)
        j, y, nis, n_in, H, S, R = self.association.gate_at(t, z, (xr, yr, _fast.wrap(psir)), P_r,
                                                            self._consider_args(f02, f12))
        if j < 0:
            self.n_rejected += 1
            return False
        H_now = (H[0], H[1], H[0] * f02 + H[1] * f12 + H[2])
        self.n_accepted += 1
        self.association.claimed[j] = t
        self._t_last_accept = max(t, self._t_last_accept or t)
        before = (core.x, core.P)
        K = self._accept(t, z, Association(j, y, nis, n_in, np.array(H_now), S, R)) or _NAN3
        self._keep_step((t, "bearing", j, z, before[0], before[1], y, S, K, core.x, core.P, True, "accepted"))
        ox, oy, opsi = core.odom
        self.monitor.accepted(t, nis, j, z, _fast.twist_step(ox, oy, opsi, *back)[:3], self._correction(*before),
                              self._innovation(y, S, H_now))
        return True

def make_estimator(
    method: str = "ekf", world: Any = None, mount: ArrayLike = (0.0, 0.0, 0.0), **kwargs: Any
) -> StreamingEstimator:
    """Build a streaming estimator by name: ``"naive"``, ``"angle_propagation"``, ``"batch_ml"`` or ``"ekf"``.

    ``world`` is the :class:`~agvnav.world.WorldMap`, ``mount`` the head pose in base_link;
    other keyword arguments go to the estimator (see :class:`StreamingEstimator`). The
    classes are those registered under :data:`METHODS` (:mod:`agvnav.positioning.ekf`
    and :mod:`agvnav.positioning.dynamic`, which ``agvnav.positioning`` imports).
    """
    if method not in METHODS:
        raise ValueError(f"unknown positioning method {method!r}; choose one of {list(METHODS)}")
    if world is None:
        raise ValueError("make_estimator needs a world map (world=...)")
    return _ESTIMATORS[method](world, mount, **kwargs)
