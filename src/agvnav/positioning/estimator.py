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
from agvnav.geometry import wrap_angle
from agvnav.odometry import OdometryNoise, SteeredOdometryNoise
from agvnav.positioning import _fast
from agvnav.positioning.association import BearingAssociation
from agvnav.positioning.bounds import encoder_bearing_std
from agvnav.positioning.ekf_core import ConsiderState, EkfCore, EkfStep, RawStep, make_step
from agvnav.positioning.gating import GateSpec
from agvnav.positioning.identification import CHI2_1DOF_999, Association, InitialPoseResult
from agvnav.positioning.inputs import InputChecks
from agvnav.positioning.integrity import IntegrityLimits, IntegrityMonitor
from agvnav.positioning.lifecycle import STATUSES, LockoutWatch, StartUp, status_of
from agvnav.positioning.plausibility import DropCounter, PlausibilityLimits, check_covariance, sound_state

__all__ = ["METHODS", "STATUSES", "StreamingEstimator", "make_estimator"]

#: Method names accepted by :func:`make_estimator` (seed 000 §2.2 and issue 4 §4).
METHODS = ("naive", "angle_propagation", "batch_ml", "ekf")

#: Lock-out inflation stops once the position variance trace reaches this (m²).
MAX_INFLATED_POSITION_VAR = 0.25

_NAN3 = (math.nan,) * 3

#: The concrete estimator classes by method name, filled as they are defined.
_ESTIMATORS: dict[str, type[StreamingEstimator]] = {}

class StreamingEstimator:
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
        self.core = EkfCore(self._move_constants(), self._new_consider())
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

    def _move_constants(self) -> NDArray[np.float64]:
        """The noise model for :func:`~agvnav.positioning._fast.move_state`.

        A :class:`~agvnav.odometry.SteeredOdometryNoise` gives a consider filter the exact
        steered-wheel model (:func:`~agvnav.positioning._fast.steered_noise`) and its
        calibration errors as consider parameters; the other methods take its Crowley bound
        (the inherited ``k_d, k_dtheta, k_theta``).
        """
        k = self.odometry_noise
        steered: tuple[bool, float, float, float, float] | None = None
        cvar = (0.0, 0.0)
        if isinstance(k, SteeredOdometryNoise) and self.consider:
            steered = (k.front, k.wheelbase_m, k.slip_k, k.steering_std**2 * k.step_m, k.min_roll_per_rad)
            cvar = (k.radius_scale_std**2, k.steering_offset_std**2)
        self._calibration_var = cvar
        return _fast.move_constants((k.k_d, k.k_dtheta, k.k_theta, self.k_lateral), steered, self.consider,
                                    cvar != (0.0, 0.0), cvar)

    def _new_consider(self) -> ConsiderState | None:
        """A fresh consider state (``P_xp = 0``, ``P_xc = 0``) for a consider filter, else None."""
        if not self.consider:
            return None
        return ConsiderState((self.survey_std**2).tolist(), self._calibration_var != (0.0, 0.0))

    # ------------------------------------------------------------------ state (the core's) as arrays
    @property
    def _x_t(self) -> tuple[float, ...]:
        return self.core.x

    @_x_t.setter
    def _x_t(self, value: tuple[float, ...]) -> None:
        self.core.x = value

    @property
    def _P_t(self) -> tuple[float, ...]:
        return self.core.P

    @_P_t.setter
    def _P_t(self, value: tuple[float, ...]) -> None:
        self.core.P = value

    @property
    def _x(self) -> NDArray[np.float64]:
        return np.array(self.core.x)

    @_x.setter
    def _x(self, value: ArrayLike) -> None:
        self.core.x = tuple(np.asarray(value, dtype=np.float64).reshape(3).tolist())

    @property
    def _P(self) -> NDArray[np.float64]:
        return np.array(self.core.P).reshape(3, 3)

    @_P.setter
    def _P(self, value: ArrayLike) -> None:
        self.core.P = tuple(np.asarray(value, dtype=np.float64).reshape(9).tolist())

    @property
    def _odom(self) -> NDArray[np.float64]:
        return np.array(self.core.odom)

    # ------------------------------------------------------------------ read
    @property
    def t(self) -> float:
        """Time (s) of the latest input (NaN before the first one)."""
        return self.inputs.now

    @property
    def pose(self) -> NDArray[np.float64]:
        """``(3,)`` base_link pose ``[x, y, psi]`` in ``map`` at :attr:`t` (NaN while initialising)."""
        return self._x

    @property
    def covariance(self) -> NDArray[np.float64]:
        """``(3, 3)`` covariance of :attr:`pose` (m², rad²; NaN while initialising).

        For the fix-based estimators (``naive``, ``angle_propagation``, ``batch_ml``): the
        filter's ``P`` plus the survey floor of the reflectors that support it
        (:attr:`~agvnav.positioning.integrity.IntegrityMonitor.survey_floor`): the
        error a constant survey error of the reflectors leaves, which ``P``, taking it
        as white bearing noise, averages away. The two add (the estimate's error is the
        filter's white error plus the survey bias, independent of each other); the part
        of the survey error ``P`` still holds after averaging over ``n`` revolutions is
        about ``floor / n``, a double count on the safe side. The EKF overrides this:
        its Schmidt-Kalman consider filter carries the survey errors' correlation with
        the pose, so its ``P`` alone is the covariance (:mod:`agvnav.positioning.ekf`;
        with the floor added, 200 runs of ``guidance_test`` gave NEES 2.40, band
        2.67-3.35, the heading part 0.54 of 1: the double count).
        """
        P = self._P
        floor = self.monitor.survey_floor
        if not floor.any():
            return P
        return P + floor

    @property
    def filter_covariance(self) -> NDArray[np.float64]:
        """``(3, 3)`` the filter's own ``P`` (m², rad²), without the survey floor of :attr:`covariance`."""
        return self._P

    @property
    def status(self) -> str:
        """``"initialising"``, ``"tracking"``, ``"degraded"``, ``"dead_reckoning"`` or ``"lost"``.

        ``lost`` and ``degraded`` are the integrity monitor's verdicts (class docstring);
        ``dead_reckoning`` no accepted reflection for ``dead_reckoning_after`` seconds.
        """
        return status_of(self.core.has_pose(), self.monitor.verdict, self._dead_reckoning())

    @property
    def quality(self) -> float:
        """0-1 quality figure of the latest integrity check (0 while initialising or lost)."""
        return self.monitor.quality if self.core.has_pose() else 0.0

    @property
    def reflectors_used(self) -> int:
        """Distinct reflectors that supported the estimate over the monitor's window."""
        return self.monitor.reflectors_used

    @property
    def n_dropped(self) -> dict[str, int]:
        """Inputs dropped as implausible (``strict=False``), per reason."""
        return dict(self.inputs.drops.by_reason)

    @property
    def drops(self) -> DropCounter:
        """The dropped inputs, per reason and time (:class:`~agvnav.positioning.plausibility.DropCounter`)."""
        return self.inputs.drops

    @property
    def strict(self) -> bool:
        """Whether a bad input raises ValueError (True) or is dropped and counted."""
        return self.inputs.strict

    @property
    def plausibility(self) -> PlausibilityLimits:
        """The :class:`~agvnav.positioning.plausibility.PlausibilityLimits` of the inputs."""
        return self.inputs.plausibility

    @property
    def last_search(self) -> InitialPoseResult | None:
        """The latest start-up or relocalisation search's result."""
        return self.startup.last_search

    @property
    def ambiguous(self) -> bool:
        """Whether the latest search found several poses (and took none)."""
        return self.startup.ambiguous

    @property
    def n_relocalisations(self) -> int:
        """Relocalisations (searches that set the pose again after ``lost``)."""
        return self.startup.n_relocalisations

    @property
    def n_unreachable(self) -> int:
        """Relocalised poses refused as out of reach of the last trusted one."""
        return self.startup.n_unreachable

    @property
    def last_step(self) -> EkfStep | None:
        """The latest measurement step (:class:`~agvnav.positioning.ekf_core.EkfStep`), None before any.

        Prior and posterior pose and covariance, innovation, its variance, gain (NaN for
        the fix-based methods, which replace the pose by a fix), accepted or why not.
        """
        return None if self._step is None else make_step(self._step)

    def record_steps(self, recorder: Callable[[EkfStep], None] | None) -> None:
        """Hand every measurement step to ``recorder`` (e.g. ``list.append``); None stops recording."""
        self._recorder = recorder

    def _keep_step(self, raw: RawStep) -> None:
        self._step = raw
        if self._recorder is not None:
            self._recorder(make_step(raw))

    def _dead_reckoning(self) -> bool:
        inputs = self.inputs
        since = self._t_last_accept if self._t_last_accept is not None else inputs.t_first
        return inputs.t is not None and since is not None and inputs.t - since > self.dead_reckoning_after

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

    # ------------------------------------------------------------------ lifecycle
    def _judge_state(self, t: float) -> None:
        """After every call: a pose and covariance that are not sound make the estimator ``"lost"``.

        Sound: a finite pose and a finite, symmetric, positive-definite ``P``
        (:func:`~agvnav.positioning.plausibility.sound_state`). The inputs are checked before
        they reach the state, so this is the last line: whatever still broke the state
        (rounding in an update of an extreme ``P``) never leaves a usable status over it. Lost,
        the estimator stops correcting and relocalises (class docstring); the event is
        counted in :attr:`n_dropped` as ``"broken_state"`` (never raised: it is no input).
        """
        if sound_state(self.core.x, self.core.P) or not self.core.has_pose() or self.monitor.verdict == "lost":
            return
        self._lose(t, "broken_state")

    def _lose(self, t: float, reason: str) -> None:
        """Make the verdict ``"lost"`` for ``reason``, counted in :attr:`n_dropped` (see :meth:`_judge_state`)."""
        self.inputs.drops.drop(t, reason)
        self.monitor.verdict = "lost"
        self.monitor.reasons = (reason,)
        self.monitor.quality = 0.0
        self.startup.buffer.clear()

    def _watch_lockout(self, t: float, accepted: bool) -> None:
        """Inflate ``P`` x4 when most reflections of the last 1.5 revolutions miss their gates.

        A wrong early association (a spurious reflection inside a wide initial gate) can leave
        a confident but wrong estimate that then rejects the true reflections: the classic
        EKF lock-out (:class:`~agvnav.positioning.lifecycle.LockoutWatch`). The covariance is
        inflated -- never the pose -- until the gates admit the reflectors again (counted in
        :attr:`n_inflations`), up to ``MAX_INFLATED_POSITION_VAR``. Only reflections that fall
        into no gate count as rejections (the caller passes no ambiguous one: in the racked
        aisles half of each revolution is ambiguous, with the estimate 6 mm from the truth).

        An inflation runs the monitor's check at once rather than at the next revolution:
        the differential AGV whose encoders dropped out (zero increments while it drove on)
        stood 14-25 cm off while "tracking" for 1.05 s before the once-a-revolution check
        caught up. The check, not the inflation, decides the verdict: heavy clutter inflates
        with the pose sound.
        """
        if not self.lockout.record(t, accepted):
            return
        P = self.core.P
        if P[0] + P[4] < MAX_INFLATED_POSITION_VAR:
            self.core.P = tuple(4.0 * v for v in P)
            self.n_inflations += 1
            self._watch_integrity(t, force=True)  # judge the estimate now, not a revolution later
            self.lockout.clear()

    def _start(self, pose: ArrayLike, covariance: ArrayLike | None) -> None:
        x = require_finite("initial_pose", pose)
        if x.shape != (3,):
            raise ValueError(f"initial_pose must have shape (3,), got {x.shape}")
        P = np.diag([0.05, 0.05, 0.02]) ** 2 if covariance is None else require_finite("initial_covariance", covariance)
        if P.shape != (3, 3):
            raise ValueError(f"initial_covariance must have shape (3, 3), got {P.shape}")
        self._x = (x[0], x[1], wrap_angle(x[2]))
        self._P = 0.5 * (P + P.T)
        self.core.consider = self._new_consider()  # a new start is independent of the survey errors
        self._t_last_accept = self.inputs.t  # None before the first input: counted from the first one
        self.monitor.reset()
        self.association.reset_claims(self.monitor.excluded)
        self.lockout.clear()

    def _try_start(self) -> None:
        """Start-up search once a full revolution of reflections at standstill is buffered."""
        result = self.startup.search(relocalising=self.core.has_pose())
        if result is not None:
            self._start(result.pose, result.covariance + np.diag([1e-6, 1e-6, 1e-8]))
            self._on_start()

    def _on_start(self) -> None:
        """Called once the start-up search has set the pose (a fix-based method drops its buffer)."""

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

    def _consider_args(self, f02: float, f12: float) -> Any:
        """``(M, C, svar)`` for :func:`~agvnav.positioning._fast.gate_one`, ``M`` moved by ``F(f02, f12)``.

        None without consider parameters.
        """
        c = self.core.consider
        if c is None:
            return None
        M = c.M if f02 == 0.0 and f12 == 0.0 else _fast.shear(c.M, f02, f12)
        return M, c.C, c.svar

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

    def _attribute(self, t: float, z: float) -> None:
        """Hand the monitor a rejected bearing ``z`` (rad) at ``t`` (s) that one unseen reflector explains.

        The association part's attribution gate
        (:meth:`~agvnav.positioning.association.BearingAssociation.attribution`) widened to the
        monitor's (:meth:`~agvnav.positioning.integrity.IntegrityMonitor.attribution_gate`);
        the reflection is that reflector's sighting for the RAIM only
        (:meth:`~agvnav.positioning.integrity.IntegrityMonitor.attributed`). EKF only (the
        RAIM judges Kalman innovations).
        """
        if self.method != "ekf" or not self.monitor.limits.attribute:
            return
        found = self.association.attribution(t, z, self.core.x, self.core.P, self.monitor.attribution_gate,
                                             self._consider_args(0.0, 0.0))
        if found is not None:
            j, y, S, H = found
            self.monitor.attributed(t, j, (float(y), float(S), float(H[0]), float(H[1]), float(H[2])))

    # ------------------------------------------------------------------ integrity (issue 12)
    def _watch_integrity(self, t: float, force: bool = False) -> None:
        """Once per revolution, or now with ``force``: the monitor's check; inflate ``P`` when it asks.

        In a drift episode the monitor also hands the position noise of the measured drift
        (:attr:`~agvnav.positioning.integrity.IntegrityMonitor.drift_noise`, m²), added to
        ``P``'s position block as process noise (the consider cross-covariances stay: the
        noise is independent of the survey errors).
        """
        core = self.core
        if not core.has_pose() or self.monitor.verdict == "lost" or not (force or self.monitor.due(t)):
            return
        n_excluded = len(self.monitor.excluded)
        if self.monitor.check(t, self._x, self._P, core.odom, self._dead_reckoning()):
            k = self.monitor.limits.inflation
            core.P = tuple(k * v for v in core.P)
            self.n_inflations += 1
        q00, q01, q11 = self.monitor.drift_noise
        if q00 or q11:
            P = list(core.P)
            P[0] += q00
            P[1] += q01
            P[3] += q01
            P[4] += q11
            core.P = tuple(P)
        if len(self.monitor.excluded) != n_excluded:
            self.apply_exclusions()

    def apply_exclusions(self) -> None:
        """Never associate the reflectors the monitor excluded (claimed forever: outside every sweep)."""
        self.association.exclude(self.monitor.excluded)

    def _correction(
        self, x0: tuple[float, ...], P0: tuple[float, ...]
    ) -> tuple[float, float, float, float, float] | None:
        """The last update's position correction and covariance decrease (the EKF's), for the monitor."""
        if self.method != "ekf":
            return None
        x1, P1 = self.core.x, self.core.P
        return (x1[0] - x0[0], x1[1] - x0[1], P0[0] - P1[0], P0[1] - P1[1], P0[4] - P1[4])

    def _innovation(
        self, y: float, S: float, H: ArrayLike
    ) -> tuple[float, float, float, float, float] | None:
        """The update's innovation, its variance and Jacobian row for the monitor's RAIM (EKF only)."""
        if self.method != "ekf":
            return None
        h = np.asarray(H, dtype=np.float64).reshape(-1)
        return (float(y), float(S), float(h[0]), float(h[1]), float(h[2]))

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
