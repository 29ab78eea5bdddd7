"""The streaming positioning interface shared by every method, and the factory by name.

One object serves a real vehicle and the simulator alike: feed timestamped odometry
increments of base_link (:meth:`StreamingEstimator.predict`) and raw anonymous
reflections (:meth:`StreamingEstimator.update`) in time order; read ``t``, ``pose``,
``covariance`` and ``status`` of the latest estimate at any moment.

What the methods share lives here: time ordering, the odometric prediction of the pose
and its covariance between absolute corrections (``P' = F P F^T + Q`` [seed002 eq14]:
the SE(2) exponential of the body-twist increment, for a non-holonomic vehicle the
seed-002 arc rule [seed002 eq25], and seed 002's noise model [seed002 eq17] with a
lateral term for holonomic vehicles), the identification of each reflection by a
chi-square gate (:func:`~agvnav.positioning.identification.gate_reflection`; on maps of
``INDEX_MIN_REFLECTORS`` or more reflectors only the candidates of a vectorised
:class:`~agvnav.positioning.gating.BearingIndex` are evaluated), the start-up pose
search when no initial pose is given, and the degraded ``"dead_reckoning"`` state. What
differs -- how an identified reflection corrects the pose -- is the subclass's
``_accept``.

The methods are created by name with :func:`make_estimator`: each concrete class names
itself in its ``method`` attribute and registers when it is defined
(``__init_subclass__``), so this module never imports the modules that subclass it.

Speed: one call handles one increment or one reflection, so the inner loop runs the
scalar fast paths of :mod:`agvnav.positioning._fast` (the same equations as the
vectorised kernels, tested against them to 1e-12) on state kept as Python floats;
``_x``, ``_P`` and ``_odom`` give it to subclasses as arrays. A prediction is one kernel call
(:mod:`agvnav._jit`, compiled or interpreted: :func:`~agvnav.positioning._fast.move_state`) and
the gate one more (:func:`~agvnav.positioning._fast.gate_rows`; the EKF's gate and update
together, :func:`~agvnav.positioning._fast.gate_accept`), in either mode (issue 11, 27).

Reflections usually fall between two odometry samples. The estimator then extrapolates
the odometry to the reflection instant at the rate of the last increment, and deducts
that advance from the next increment, so the odometric path is never counted twice and
never jumps.
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import as_float_array, require_finite, require_nonnegative, require_positive
from agvnav.geometry import wrap_angle
from agvnav.odometry import OdometryNoise, SteeredOdometryNoise
from agvnav.positioning import _fast
from agvnav.positioning.bounds import encoder_bearing_std
from agvnav.positioning.gating import INDEX_MIN_REFLECTORS, BearingIndex, GateSpec
from agvnav.positioning.identification import CHI2_1DOF_999, Association, InitialPoseResult, initial_pose_search
from agvnav.positioning.integrity import IntegrityLimits, IntegrityMonitor, reflectors_in_sight
from agvnav.positioning.plausibility import (
    MAX_DEPARTURE,
    DropCounter,
    PlausibilityLimits,
    check_covariance,
    implausible_increment,
    sound_state,
)

__all__ = ["METHODS", "STATUSES", "StreamingEstimator", "make_estimator"]

#: Method names accepted by :func:`make_estimator` (seed 000 §2.2 and issue 4 §4).
METHODS = ("naive", "angle_propagation", "batch_ml", "ekf")
#: Values of :attr:`StreamingEstimator.status`.
STATUSES = ("initialising", "tracking", "degraded", "dead_reckoning", "lost")


#: Lock-out inflation stops once the position variance trace reaches this (m²).
MAX_INFLATED_POSITION_VAR = 0.25

_INF = math.inf

#: Placeholders of the compiled kernels' consider and steering arguments for estimators without them.
_NO_M = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
_NO_X = (0.0,) * 6
_NO_C = np.zeros((0, 6))

#: The concrete estimator classes by method name, filled as they are defined.
_ESTIMATORS: dict[str, type[StreamingEstimator]] = {}

class StreamingEstimator:
    """Base of the streaming estimators: odometry prediction, gating, status, counters.

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
    #: Whether the estimator keeps the reflectors' survey errors as Schmidt-Kalman consider
    #: parameters (the EKF): its gate then takes the consider filter's ``S``
    #: (:func:`~agvnav.positioning._fast.gate_rows`), and :meth:`_consider_args`,
    #: :meth:`_move_factors` and :meth:`_consider_reset` keep the cross-covariance.
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
        noise = self.odometry_noise
        #: The exact steered-wheel model's constants for :func:`~agvnav.positioning._fast.steered_noise`
        #: (``front, L, slip_k, steering_std^2 step_m, min_roll_per_rad``), None for Crowley's coefficients;
        #: and the calibration consider parameters' variances (radius scale, steering offset rad²), EKF only.
        self._steered: tuple[bool, float, float, float, float] | None = None
        self._calibration_var = (0.0, 0.0)
        if isinstance(noise, SteeredOdometryNoise) and self.consider:  # else its Crowley bound (docstring)
            self._steered = (noise.front, noise.wheelbase_m, noise.slip_k, noise.steering_std**2 * noise.step_m,
                             noise.min_roll_per_rad)
            self._calibration_var = (noise.radius_scale_std**2, noise.steering_offset_std**2)
        k_lat = self.odometry_noise.k_d if k_lateral is None else k_lateral
        self.k_lateral = require_nonnegative("k_lateral", k_lat)
        self.rate_hz = require_positive("rate_hz", rate_hz)
        self.max_range = require_positive("max_range", max_range)
        self.dead_reckoning_after = require_positive("dead_reckoning_after", dead_reckoning_after)
        self.gate = require_positive("gate", gate)
        self.strict = bool(strict)
        self.plausibility = PlausibilityLimits() if plausibility is None else plausibility
        self.drops = DropCounter()
        self.monitor = IntegrityMonitor(
            self.reflector_xy, self.reflector_radius, self.mount, self.bearing_std, 1.0 / self.rate_hz, integrity,
            map_std=np.maximum(survey, map_std), max_range=self.max_range,
            walls=getattr(world, "wall_segments", None),
            odometry_noise=(self.odometry_noise.k_d, self.odometry_noise.k_dtheta, self.odometry_noise.k_theta),
        )
        self.ambiguous = False
        self.n_relocalisations = 0
        self.n_unreachable = 0
        self._trusted: tuple[float, float, float, float] | None = None  # x, y (m), var x + var y (m²), t (s)
        self._next_search_t = -math.inf
        self.n_accepted = 0
        self.n_rejected = 0
        self.n_inflations = 0
        self._recent: deque[tuple[float, bool]] = deque()
        self._recent_ok = 0  # accepted reflections in _recent
        self._sight_mask: NDArray[np.bool_] | None = None  # reflectors in sight (see _sight)
        self._sight_t = -math.inf
        self.last_search: InitialPoseResult | None = None
        self._t: float | None = None
        self._t_odometry: float | None = None
        self._rate = (0.0, 0.0, 0.0)  # odometry rate (m/s, rad/s, lateral m/s) of the last increment
        self._advance = (0.0, 0.0, 0.0)  # extrapolated odometry not yet covered by an increment
        self._odom_t = (0.0, 0.0, 0.0)  # odometric pose of base_link in the odom frame
        self._t_first: float | None = None
        self._t_last_accept: float | None = None
        self._claimed = np.full(self.reflector_xy.shape[0], -math.inf)  # claim times (s); an array for gate_rows
        self._init_buffer: list[tuple[float, float]] = []
        self._rows = _fast.reflector_rows(self.reflector_xy, self.reflector_radius)
        self._mount_t = tuple(float(v) for v in self.mount)
        self._spec = GateSpec(
            self.bearing_std**2, self.max_range, self.gate, self.map_std, 0.75 / self.rate_hz, self.consider
        )
        self._index = (
            BearingIndex(self.reflector_xy, self.reflector_radius, self.mount, self._spec)
            if len(self._rows) >= INDEX_MIN_REFLECTORS else None
        )
        #: The compiled kernels' constants and map (:mod:`agvnav.positioning._fast`), fixed for the run.
        self._grid_consts = None if self._index is None else self._index.grid_constants()
        self._gate_consts = _fast.gate_constants(self._spec, self._mount_t, self._grid_consts, self.bearing_std**2)
        self._gate_tab = _fast.gate_table(self._rows, self.survey_std**2 if self.consider else None)
        self._gate_grid = (
            (np.zeros(2, np.int64), np.zeros(0, np.int64)) if self._index is None else self._index.grid_cells()
        )
        self._in_sight_all = np.ones(len(self._rows), dtype=np.bool_)
        k = self.odometry_noise
        self._move_consts = _fast.move_constants(
            (k.k_d, k.k_dtheta, k.k_theta, self.k_lateral), self._steered, self.consider,
            self._calibration_var != (0.0, 0.0), self._calibration_var,
        )
        self._wide_spec: GateSpec | None = None  # the monitor's attribution gate (:meth:`_attribute`), made once needed
        self._wide_index: BearingIndex | None = None
        self._x_t: tuple[float, ...] = (math.nan,) * 3  # pose [x, y, psi]
        self._P_t: tuple[float, ...] = (math.nan,) * 9  # covariance, flat row-major
        if initial_covariance is not None:
            check_covariance("initial_covariance", initial_covariance)
        if initial_pose is not None:
            self._start(initial_pose, initial_covariance)

    # ------------------------------------------------------------------ state as arrays
    @property
    def _x(self) -> NDArray[np.float64]:
        return np.array(self._x_t)

    @_x.setter
    def _x(self, value: ArrayLike) -> None:
        self._x_t = tuple(np.asarray(value, dtype=np.float64).reshape(3).tolist())

    @property
    def _P(self) -> NDArray[np.float64]:
        return np.array(self._P_t).reshape(3, 3)

    @_P.setter
    def _P(self, value: ArrayLike) -> None:
        self._P_t = tuple(np.asarray(value, dtype=np.float64).reshape(9).tolist())

    @property
    def _odom(self) -> NDArray[np.float64]:
        return np.array(self._odom_t)

    def _has_pose(self) -> bool:
        x, y, psi = self._x_t
        return math.isfinite(x) and math.isfinite(y) and math.isfinite(psi)

    # ------------------------------------------------------------------ read
    @property
    def t(self) -> float:
        """Time (s) of the latest input (NaN before the first one)."""
        return float("nan") if self._t is None else self._t

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
        if not self._has_pose():
            return "initialising"
        verdict = self.monitor.verdict
        if verdict == "lost":
            return "lost"
        if self._dead_reckoning():
            return "dead_reckoning"
        return "degraded" if verdict == "degraded" else "tracking"

    @property
    def quality(self) -> float:
        """0-1 quality figure of the latest integrity check (0 while initialising or lost)."""
        return self.monitor.quality if self._has_pose() else 0.0

    @property
    def reflectors_used(self) -> int:
        """Distinct reflectors that supported the estimate over the monitor's window."""
        return self.monitor.reflectors_used

    @property
    def n_dropped(self) -> dict[str, int]:
        """Inputs dropped as implausible (``strict=False``), per reason."""
        return dict(self.drops.by_reason)

    def _dead_reckoning(self) -> bool:
        since = self._t_last_accept if self._t_last_accept is not None else self._t_first
        return self._t is not None and since is not None and self._t - since > self.dead_reckoning_after

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
        holonomic term ``var_l = k_lateral |delta_lateral|``. With ``delta_lateral = 0``
        the prediction is today's non-holonomic one, bit for bit.
        A :class:`~agvnav.odometry.SteeredOdometryNoise` replaces this ``Q`` by its exact
        rank-one model of the drive wheel's slip and steering error (issue 12).
        """
        checked = self._checked_odometry(t, delta_d, delta_theta, delta_lateral)
        if checked is None:
            return
        t, dd, dth, dl = checked
        if self._t_odometry is not None and t > self._t_odometry:
            self._rate = self._plausible_rate(t - self._t_odometry, dd, dth, dl)
        ahead = self._advance
        self._advance = (0.0, 0.0, 0.0)
        self._t_odometry = t
        self._t = t
        self._move(dd - ahead[0], dth - ahead[1], dl - ahead[2])
        if abs(dd) > 1e-9 or abs(dth) > 1e-9 or abs(dl) > 1e-9:
            self._init_buffer.clear()  # the start-up search and relocalisation need a standing vehicle
        if self.monitor.due(t):  # _watch_integrity(t) returns at once otherwise (issue 11: one call fewer)
            self._watch_integrity(t)
        self._judge_state(t)

    def update(self, t: float, bearing: float) -> bool:
        """One raw anonymous reflection: time ``t`` (s), head-frame bearing (rad) of its start.

        Returns True when the reflection was identified and used, False when rejected
        (spurious, ambiguous, already claimed in this sweep) or buffered for start-up.
        """
        checked = self._checked_reflection(t, bearing)
        if checked is None:
            return False
        t, z = checked
        if self._t is not None and t < self._t:
            accepted = self._late(t, z)
            self._judge_state(t)
            return accepted
        # extrapolated no farther than max_gap_s past the latest odometry: beyond, the motion is
        # unknown (the next odometry message is a time gap, :meth:`_blow_up`), and a reflection
        # 1e300 s ahead once moved the pose 3e300 m with an inf covariance
        horizon = _INF if self._t_odometry is None else self._t_odometry + self.plausibility.max_gap_s
        if self._t_odometry is not None and self._t is not None and min(t, horizon) > self._t:
            span = min(t, horizon) - self._t
            ahead_d, ahead_th, ahead_l = self._rate[0] * span, self._rate[1] * span, self._rate[2] * span
            done = self._advance
            self._advance = (done[0] + ahead_d, done[1] + ahead_th, done[2] + ahead_l)
            self._move(ahead_d, ahead_th, ahead_l)
        self._t = t
        if not self._has_pose() or self.monitor.verdict == "lost":
            self._init_buffer.append((t, z))
            self._try_start()
            self._judge_state(t)
            return False
        before = (self._x_t, self._P_t)  # the prior of the fused call's update
        # the gate and the update in one call -- unless an acceptance may inflate P in
        # _watch_lockout between them (its window and counts do not depend on the state)
        fused = self.consider and not self._lockout_on_accept(t)
        assoc = self._gate_accept(t, z) if fused else self._gate(t, z)
        accepted = self._after_gate(t, z, assoc, fused, before)
        self._judge_state(t)
        return accepted

    def _after_gate(
        self, t: float, z: float, assoc: Association, fused: bool, before: tuple[tuple[float, ...], tuple[float, ...]]
    ) -> bool:
        """:meth:`update` once the reflection ``(t s, z rad)`` is gated: lock-out watch, counters, the update, monitor.

        ``fused``: :meth:`_gate_accept` already made the update (then ``before`` is its prior
        ``(x, P)``); else :meth:`_accept` makes it here when the gate identified a reflector.
        """
        if assoc.index >= 0 or assoc.n_in_gate == 0:  # an ambiguous gate says nothing of a lock-out
            self._watch_lockout(t, assoc.index >= 0)
        if assoc.index < 0:
            self.n_rejected += 1
            if assoc.n_in_gate == 0:  # off its prediction; an ambiguous one has its reflector in the gate
                self.monitor.rejected(t)
                self._attribute(t, z)
            return False
        self.n_accepted += 1
        self._claimed[assoc.index] = t
        self._t_last_accept = t
        if not fused:
            before = (self._x_t, self._P_t)  # after a lock-out inflation, the prior the update sees
            self._accept(t, z, assoc)
        if self.monitor.verdict == "ok":
            self._trusted = (self._x_t[0], self._x_t[1], self._P_t[0] + self._P_t[4], t)
        self.monitor.accepted(t, assoc.nis, assoc.index, z, self._odom_t, self._correction(*before),
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

    # ------------------------------------------------------------------ plausibility (issue 12)
    def _refuse(self, t: float, reason: str, message: str) -> None:
        """ValueError with ``message`` (strict), else count the dropped reading under ``reason``."""
        if self.strict:
            raise ValueError(message)
        self.drops.drop(t, reason)

    def _checked_odometry(
        self, t: float, delta_d: float, delta_theta: float, delta_lateral: float
    ) -> tuple[float, float, float, float] | None:
        """``(t, dd, dth, dl)`` to integrate, or None when the message is dropped (see :mod:`.plausibility`).

        A non-finite or impossible increment is replaced by the motion at the last
        rate over its span (the vehicle most likely went on; the rate capped at the
        limits, :meth:`_plausible_rate`); a time gap beyond ``max_gap_s`` is not
        integrated. Either way the motion of the span is unknown, and the position and
        heading variances grow by what the vehicle could have done in it (:meth:`_blow_up`).

        The first message is judged too, as if it spanned ``max_gap_s``
        (:func:`~agvnav.positioning.plausibility.implausible_increment`): there is no earlier
        time to judge a speed by, and an increment of -1e6 m once moved the pose 1,000 km.
        Refused, it is replaced by no motion, the variances growing over the time since the
        first input (none when it is the first).

        The closed loop's every call (finite Python floats, in time order, plausible) takes a
        fast path that skips the conversions; anything else takes the full one.
        """
        t_prev, t_odo = self._t, self._t_odometry
        if (
            type(t) is float and type(delta_d) is float and type(delta_theta) is float
            and type(delta_lateral) is float and t_prev is not None and t_odo is not None
            and self._t_first is not None and _INF > t >= t_prev and -_INF < delta_d < _INF
            and -_INF < delta_theta < _INF and -_INF < delta_lateral < _INF
            and implausible_increment(self.plausibility, t - t_odo, delta_d, delta_theta, delta_lateral) is None
        ):
            return t, delta_d, delta_theta, delta_lateral
        try:
            t = _finite_float("t", t)
        except ValueError:
            self._refuse(self.t, "non_finite", "t contains NaN or inf")
            return None
        if self._t is not None and t < self._t:
            self._refuse(t, "out_of_order", f"odometry at t={t!r} s is earlier than the previous input at "
                         f"t={self._t!r} s; feed odometry and reflections in time order")
            return None
        self._check_time(t, "odometry")
        first = self._t_odometry is None
        # the first message's span is unknown (judged over max_gap_s); a refused one is replaced by
        # no motion, the pose's uncertainty growing over the time known since the first input
        span = t - (self._t_first if first else self._t_odometry)  # type: ignore[operator]
        try:
            inc = (
                _finite_float("odometry increment", delta_d),
                _finite_float("odometry increment", delta_theta),
                _finite_float("odometry increment", delta_lateral),
            )
            reason = implausible_increment(self.plausibility, None if first else span, *inc)
        except ValueError as exc:
            inc, reason, message = (math.nan,) * 3, "non_finite", f"{exc} (t={t!r} s)"
        if reason is None:  # the message is formatted only for a dropped increment (issue 11: 16 us a call)
            return t, inc[0], inc[1], inc[2]
        if reason != "non_finite":
            message = (
                f"odometry increment {inc} over {span!r} s at t={t!r} s is implausible ({reason}); "
                f"limits {self.plausibility}"
            )
        self._refuse(t, reason, message)
        rate = (0.0, 0.0, 0.0) if reason == "time_gap" or first else self._rate
        self._blow_up(span, rate)
        return t, rate[0] * span, rate[1] * span, rate[2] * span

    def _judge_state(self, t: float) -> None:
        """After every call: a pose and covariance that are not sound make the estimator ``"lost"``.

        Sound: a finite pose and a finite, symmetric, positive-definite ``P``
        (:func:`~agvnav.positioning.plausibility.sound_state`). The inputs are checked before
        they reach the state (plausibility, time gaps, the first odometry message, fixes
        against the prediction), so this is the last line: whatever still broke the state
        (rounding in an update of an extreme ``P``) never leaves a usable status over it. Lost,
        the estimator stops correcting and relocalises (class docstring); the event is
        counted in :attr:`n_dropped` as ``"broken_state"`` (never raised: it is no input).
        """
        if sound_state(self._x_t, self._P_t) or not self._has_pose() or self.monitor.verdict == "lost":
            return
        self._lose(t, "broken_state")

    def _lose(self, t: float, reason: str) -> None:
        """Make the verdict ``"lost"`` for ``reason``, counted in :attr:`n_dropped` (see :meth:`_judge_state`)."""
        self.drops.drop(t, reason)
        self.monitor.verdict = "lost"
        self.monitor.reasons = (reason,)
        self.monitor.quality = 0.0
        self._init_buffer.clear()

    def _plausible_rate(self, span: float, dd: float, dth: float, dl: float) -> tuple[float, float, float]:
        """The rate (m/s, rad/s, m/s) of an accepted increment over ``span`` (s), capped at the plausibility limits.

        An increment over a short span passes the check on its slack (``slack_m``), not on
        the speed limit: the first piece of a burst that carries seconds of missed motion
        (``odometry_lost``: 4 mm in 0.8 ms, 5 m/s) passed, and the pieces after it, refused
        as too fast, were replaced by the motion at that rate -- the estimate ran 0.25 m
        ahead in 50 ms while its sigma stayed at 5 mm. The rate that stands in for a
        refused increment (and extrapolates to a reflection) is one the vehicle can have.
        """
        lim = self.plausibility
        v_d, w, v_l = dd / span, dth / span, dl / span
        speed = math.hypot(v_d, v_l)
        if speed > lim.max_speed_m_s:
            v_d, v_l = v_d * lim.max_speed_m_s / speed, v_l * lim.max_speed_m_s / speed
        return v_d, max(-lim.max_yaw_rate_rad_s, min(lim.max_yaw_rate_rad_s, w)), v_l

    def _blow_up(self, span: float, rate: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        """Grow ``P`` by what the vehicle could have done in ``span`` s beyond moving at ``rate``.

        A refused increment (a time gap, or motion beyond the limits) leaves the motion of
        its span unknown: it is replaced by ``rate`` times the span, and the position and
        heading variances grow by the square of the largest departure from that the limits
        allow, ``(max_speed_m_s + |v|) span`` and ``(max_yaw_rate_rad_s + |omega|) span``
        (a time gap: the rate is 0).
        """
        lim = self.plausibility
        # capped: a gap of 1e300 s would overflow (``**`` raises OverflowError, ``*`` gives inf)
        d = min((lim.max_speed_m_s + math.hypot(rate[0], rate[2])) * span, MAX_DEPARTURE)
        a = min((lim.max_yaw_rate_rad_s + abs(rate[1])) * span, MAX_DEPARTURE)
        d2, a2 = d * d, a * a
        P = list(self._P_t)
        P[0], P[4], P[8] = P[0] + d2, P[4] + d2, P[8] + a2
        self._P_t = tuple(P)

    def _checked_reflection(self, t: float, bearing: float) -> tuple[float, float] | None:
        """``(t, bearing + offset)``, or None when dropped (non-finite, or older than the late window)."""
        try:
            t, b = _finite_float("t", t), _finite_float("bearing", bearing)
        except ValueError as exc:
            self._refuse(self.t, "non_finite", str(exc))
            return None
        if self._t is not None and t < self._t - self.plausibility.late_window_s:
            self._refuse(t, "late", f"reflection at t={t!r} s is earlier than the previous input at t={self._t!r} s "
                         f"by more than late_window_s={self.plausibility.late_window_s!r} s")
            return None
        if self._t_first is None:
            self._t_first = t
        return t, _fast.wrap(b + self.bearing_offset)

    def _late(self, t: float, z: float) -> bool:
        """A reflection up to ``late_window_s`` late: gated and applied at its own instant.

        The pose then is the current one moved back along the last odometry rate
        (``x_r = x (+) exp(-rate (t_now - t))``, :func:`~agvnav.positioning._fast.twist_step`),
        with ``P_r = F P F^T`` (and a consider filter's ``P_xp,r = F P_xp``); the
        measurement row on the current state is ``H_r F`` (``F = d x_r / d x``), so the
        update corrects the current pose.
        """
        if not self.late_updates or not self._has_pose() or self.monitor.verdict == "lost":
            self._refuse(t, "late", f"reflection at t={t!r} s arrived after t={self._t!r} s")
            return False
        t_now = self._t if self._t is not None else t  # moved back only over the extrapolated span (update)
        if self._t_odometry is not None:
            t_now = min(t_now, self._t_odometry + self.plausibility.max_gap_s)
        span = max(t_now - t, 0.0)
        back = (-self._rate[0] * span, -self._rate[1] * span, -self._rate[2] * span)
        x, y, psi = self._x_t
        xr, yr, psir, f02, f12 = _fast.twist_step(x, y, psi, *back)
        P_r = _fast.predict_covariance(self._P_t, f02, f12, (0.0,) * 9)
        j, y, nis, n_in, H, S, R = _fast.gate_one(
            z, (xr, yr, _fast.wrap(psir)), P_r, self._mount_t, self._rows, self._spec, self._claimed, t, None,
            self._consider_args(f02, f12) if self.consider else None,
        )
        if j < 0:
            self.n_rejected += 1
            return False
        H_now = (H[0], H[1], H[0] * f02 + H[1] * f12 + H[2])
        self.n_accepted += 1
        self._claimed[j] = t
        self._t_last_accept = max(t, self._t_last_accept or t)
        before = (self._x_t, self._P_t)
        self._accept(t, z, Association(j, y, nis, n_in, np.array(H_now), S, R))
        ox, oy, opsi = self._odom_t
        self.monitor.accepted(t, nis, j, z, _fast.twist_step(ox, oy, opsi, *back)[:3], self._correction(*before),
                              self._innovation(y, S, H_now))
        return True

    # ------------------------------------------------------------------ integrity (issue 12)
    def _correction(
        self, x0: tuple[float, ...], P0: tuple[float, ...]
    ) -> tuple[float, float, float, float, float] | None:
        """The last update's position correction and covariance decrease (the EKF's), for the monitor."""
        if self.method != "ekf":
            return None
        x1, P1 = self._x_t, self._P_t
        return (x1[0] - x0[0], x1[1] - x0[1], P0[0] - P1[0], P0[1] - P1[1], P0[4] - P1[4])

    def _innovation(
        self, y: float, S: float, H: ArrayLike
    ) -> tuple[float, float, float, float, float] | None:
        """The update's innovation, its variance and Jacobian row for the monitor's RAIM (EKF only)."""
        if self.method != "ekf":
            return None
        h = np.asarray(H, dtype=np.float64).reshape(-1)
        return (float(y), float(S), float(h[0]), float(h[1]), float(h[2]))

    def _attribute(self, t: float, z: float) -> None:
        """Hand the monitor a rejected bearing ``z`` (rad) at ``t`` (s) that one unseen reflector explains.

        The gate of :meth:`_gate` widened to the monitor's attribution gate
        (:meth:`~agvnav.positioning.integrity.IntegrityMonitor.attribution_gate`), over every
        reflector in sight but the excluded ones, claimed in this sweep or not: when exactly
        one lies inside and it is not yet claimed in the sweep, the reflection is its
        sighting for the RAIM only (:meth:`~agvnav.positioning.integrity.IntegrityMonitor.attributed`;
        the filter never uses it). EKF only (the RAIM judges Kalman innovations).
        """
        if self.method != "ekf" or not self.monitor.limits.attribute:
            return
        spec = self._wide_spec
        if spec is None:
            spec = self._wide_spec = dataclasses.replace(self._spec, gate=self.monitor.attribution_gate())
            if self._index is not None:
                self._wide_index = BearingIndex(self.reflector_xy, self.reflector_radius, self.mount, spec)
        cand = None if self._wide_index is None else self._wide_index.candidates(z, self._x_t, self._P_t)
        sight = self._sight(t)
        if sight is not None:
            cand = [j for j in (range(len(self._rows)) if cand is None else cand) if sight[j]]
        seen_or_not = [math.inf if c == math.inf else -math.inf for c in self._claimed]  # excluded: claimed forever
        j, y, _, _, H, S, _ = _fast.gate_one(
            z, self._x_t, self._P_t, self._mount_t, self._rows, spec, seen_or_not, t, cand,
            self._consider_args(0.0, 0.0) if self.consider else None,
        )
        if j >= 0 and not t - self._claimed[j] < spec.sweep:
            self.monitor.attributed(t, j, (float(y), float(S), float(H[0]), float(H[1]), float(H[2])))

    def _watch_integrity(self, t: float, force: bool = False) -> None:
        """Once per revolution, or now with ``force``: the monitor's check; inflate ``P`` when it asks.

        In a drift episode the monitor also hands the position noise of the measured drift
        (:attr:`~agvnav.positioning.integrity.IntegrityMonitor.drift_noise`, m²), added to
        ``P``'s position block as process noise (the consider cross-covariances stay: the
        noise is independent of the survey errors).
        """
        if not self._has_pose() or self.monitor.verdict == "lost" or not (force or self.monitor.due(t)):
            return
        n_excluded = len(self.monitor.excluded)
        if self.monitor.check(t, self._x, self._P, self._odom_t, self._dead_reckoning()):
            k = self.monitor.limits.inflation
            self._P_t = tuple(k * v for v in self._P_t)
            self.n_inflations += 1
        q00, q01, q11 = self.monitor.drift_noise
        if q00 or q11:
            P = list(self._P_t)
            P[0] += q00
            P[1] += q01
            P[3] += q01
            P[4] += q11
            self._P_t = tuple(P)
        if len(self.monitor.excluded) != n_excluded:
            self.apply_exclusions()

    def apply_exclusions(self) -> None:
        """Never associate the reflectors the monitor excluded (claimed forever: outside every sweep)."""
        for j in self.monitor.excluded:
            self._claimed[j] = math.inf

    # ------------------------------------------------------------------ internals
    def _gate(self, t: float, z: float) -> Association:
        """:func:`~agvnav.positioning.identification.gate_reflection` on the current estimate.

        One kernel call (:func:`agvnav.positioning._fast.gate_rows`); a reflector claimed less
        than 3/4 of a revolution ago is excluded. On large maps only the
        :class:`~agvnav.positioning.gating.BearingIndex` candidates are evaluated (a superset of
        the reflectors inside the gate: same association).
        """
        sight = self._sight(t)
        M, C = self._consider_factors()
        j, y, nis, n_in, h0, h1, h2, S, R = _fast.gate_rows(
            z, t, self._x_t, self._P_t, M, C, self._claimed, self._in_sight_all if sight is None else sight,
            self._gate_tab, self._gate_consts, *self._gate_grid,
        )
        return Association(j, y, nis, n_in, np.array((h0, h1, h2)), S, R)

    def _sight(self, t: float) -> NDArray[np.bool_] | None:
        """``(N,)`` bool: the reflectors in sight of the estimated head, refreshed once per revolution.

        The goniometer's own line-of-sight test
        (:func:`~agvnav.positioning.integrity.reflectors_in_sight`, walls, racks and other
        reflectors hide a reflector) with the monitor's map walls; None without walls (every
        reflector is a candidate). A reflector hidden behind a rack cannot have made a
        reflection, so it is no candidate of the gate: in the racked warehouse aisles the
        hidden reflectors lie within a degree of the visible ones down the aisle and made
        half of each revolution's reflections ambiguous (several reflectors in the gate),
        so a single covariance inflation left no reflection identifiable.
        """
        walls = self.monitor.walls
        if walls is None or walls.shape[0] == 0 or not self._has_pose():
            return None
        if self._sight_mask is None or not 0.0 <= t - self._sight_t < 1.0 / self.rate_hz:
            x, y, psi = self._x_t[0], self._x_t[1], self._x_t[2]
            mx, my = self._mount_t[0], self._mount_t[1]
            c, sn = math.cos(psi), math.sin(psi)
            hx, hy = x + c * mx - sn * my, y + sn * mx + c * my
            self._sight_mask = reflectors_in_sight(
                self.reflector_xy, self.reflector_radius, (hx, hy), walls, self.monitor.max_range
            )
            self._sight_t = t
        return self._sight_mask

    def _check_time(self, t: float, what: str) -> float:
        t = _finite_float("t", t)
        if self._t is not None and t < self._t:
            raise ValueError(
                f"{what} at t={t!r} s is earlier than the previous input at t={self._t!r} s; "
                "feed odometry and reflections in time order"
            )
        if self._t_first is None:
            self._t_first = t
        return t

    def _lockout_on_accept(self, t: float) -> bool:
        """Whether :meth:`_watch_lockout` may inflate ``P`` if the reflection at ``t`` (s) is accepted.

        Its counts alone (the room left below ``MAX_INFLATED_POSITION_VAR`` depends on ``P``,
        which the update changes). Drops the entries older than the window first, as
        :meth:`_watch_lockout` does (the same pruning, done early).
        """
        window = 1.5 / self.rate_hz
        recent = self._recent
        while recent and not t - recent[0][0] <= window:
            self._recent_ok -= recent.popleft()[1]
        n_ok = self._recent_ok + 1
        n_bad = len(recent) + 1 - n_ok
        return n_bad >= 4 and 2 * n_ok < n_bad

    def _gate_accept(self, t: float, z: float) -> Association:  # pragma: no cover - abstract
        """:meth:`_gate` and, when it identifies a reflector, :meth:`_accept`, in one kernel call.

        For ``consider`` estimators; :meth:`update` calls it only
        when an acceptance would not make :meth:`_watch_lockout` inflate ``P`` between the two
        (:meth:`_lockout_on_accept`), so the result is the one of the two calls.
        """
        raise NotImplementedError

    def _watch_lockout(self, t: float, accepted: bool) -> None:
        """Inflate ``P`` x4 when most reflections of the last 1.5 revolutions miss their gates.

        A wrong early association (a spurious reflection inside a wide initial gate) can leave
        a confident but wrong estimate that then rejects the true reflections: the classic
        EKF lock-out. Genuine operation rejects only spurious reflections, a small fraction;
        when rejections outnumber acceptances twice over (and at least four), the covariance
        is inflated -- never the pose -- until the gates admit the reflectors again
        (counted in :attr:`n_inflations`), up to ``MAX_INFLATED_POSITION_VAR``.

        Only reflections that fall into no gate count as rejections here (the caller
        passes no ambiguous one): a reflection rejected because several reflectors share
        its gate has its reflector *inside* the gate -- the opposite of a lock-out -- and
        inflating then only widens the gates and makes more reflections ambiguous. In the
        racked warehouse aisles the reflectors hidden behind the racks lie within a degree
        of the visible ones down the aisle, so half of each revolution is ambiguous there;
        counting those inflated ``P`` x4 per 1.5 revolutions until the verdict was ``lost``
        with the estimate 6 mm from the truth.

        An inflation runs the monitor's check at once rather than at the next revolution:
        the differential AGV whose encoders dropped out (zero increments while it drove on,
        so ``Q = 0`` and ``P`` shrank) stood 14-25 cm and 160 mrad off while "tracking" for
        1.05 s, the gates rejecting and the inflations following, before the
        once-a-revolution check caught up. The check, not the inflation, decides the
        verdict: heavy clutter (12 spurious reflections per revolution) inflates with the
        pose sound, and declaring every inflation ``degraded`` slowed the tricycle into a
        timeout in every severe-clutter run.
        """
        window = 1.5 / self.rate_hz
        recent = self._recent
        while recent and not t - recent[0][0] <= window:  # times never decrease: the old ones lead
            self._recent_ok -= recent.popleft()[1]
        recent.append((t, accepted))
        self._recent_ok += accepted
        n_ok = self._recent_ok  # kept as a running count: the window holds ~1.5 N reflections
        n_bad = len(recent) - n_ok
        room = self._P_t[0] + self._P_t[4] < MAX_INFLATED_POSITION_VAR
        if n_bad >= 4 and 2 * n_ok < n_bad and room:
            self._P_t = tuple(4.0 * v for v in self._P_t)
            self.n_inflations += 1
            self._watch_integrity(t, force=True)  # judge the estimate now, not a revolution later
            recent.clear()
            self._recent_ok = 0

    def _move(self, delta_d: float, delta_theta: float, delta_lateral: float) -> None:
        """Dead-reckon the odom pose, and the map pose with ``P' = F P F^T + Q`` (see :meth:`predict`).

        One kernel call (:func:`~agvnav.positioning._fast.move_state`): the SE(2) exponential
        (:func:`~agvnav.positioning._fast.twist_step`; for ``delta_lateral = 0``
        :func:`~agvnav.odometry.integrate_pose`'s arc rule [seed002 eq25]) and the noise
        (:func:`~agvnav.positioning._fast.process_noise`, [seed002 eq17]). The noise model's
        constants were packed at construction (``_move_consts``); a consider filter moves its own
        factors in the same call (:meth:`_move_factors`).
        """
        self._odom_t, self._x_t, self._P_t, M, X = _fast.MOVE_STATE.bound()(
            self._odom_t, self._x_t, self._P_t, *self._move_factors(), delta_d, delta_theta, delta_lateral,
            self._move_consts,
        )
        self._moved_factors(M, X)

    def _move_factors(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """``(M, P_xc)`` a consider filter moves with the pose (placeholders without consider)."""
        return _NO_M, _NO_X

    def _moved_factors(self, M: tuple[float, ...], X: tuple[float, ...]) -> None:
        """Keep the ``(M, P_xc)`` :meth:`_move` returned (a consider filter's; nothing without)."""

    def _start(self, pose: ArrayLike, covariance: ArrayLike | None) -> None:
        x = require_finite("initial_pose", pose)
        if x.shape != (3,):
            raise ValueError(f"initial_pose must have shape (3,), got {x.shape}")
        P = np.diag([0.05, 0.05, 0.02]) ** 2 if covariance is None else require_finite("initial_covariance", covariance)
        if P.shape != (3, 3):
            raise ValueError(f"initial_covariance must have shape (3, 3), got {P.shape}")
        self._x = (x[0], x[1], wrap_angle(x[2]))
        self._P = 0.5 * (P + P.T)
        if self.consider:
            self._consider_reset()  # a new start is independent of the survey errors
        self._t_last_accept = self._t  # None before the first input: counted from the first one
        self.monitor.reset()
        self._claimed = np.full(self.reflector_xy.shape[0], -math.inf)
        self.apply_exclusions()
        self._recent.clear()
        self._recent_ok = 0

    def _try_start(self) -> None:
        """Start-up search once a full revolution of reflections at standstill is buffered."""
        times = np.array([b[0] for b in self._init_buffer])
        if times[-1] - times[0] < 1.0 / self.rate_hz or times[-1] < self._next_search_t:
            return
        sweep = [z for (tb, z) in self._init_buffer if times[-1] - tb < 1.0 / self.rate_hz]
        result = initial_pose_search(
            sweep, self.reflector_xy, self.reflector_radius, self.mount, self.bearing_std,
            max_range=self.max_range, gate=self.gate, map_std=self.map_std,
        )
        self.last_search = result
        self.ambiguous = bool(result.ambiguous)
        self._init_buffer = [b for b in self._init_buffer if times[-1] - b[0] < 1.0 / self.rate_hz]
        relocalising = self._has_pose()
        if result.found and relocalising and not self._reachable(result.pose, float(times[-1])):
            self.n_unreachable += 1
            self._next_search_t = float(times[-1]) + 1.0
            return
        if result.found:
            self._start(result.pose, result.covariance + np.diag([1e-6, 1e-6, 1e-8]))
            self.n_relocalisations += relocalising
            self._init_buffer.clear()
            self._on_start()
        elif relocalising:  # lost: the search costs ~0.1 s, try again a second later
            self._next_search_t = float(times[-1]) + 1.0

    def _reachable(self, pose: NDArray[np.float64], t: float) -> bool:
        """Whether base_link could have reached ``pose`` (m) at ``t`` (s) from the last trusted pose."""
        if self._trusted is None:
            return True
        x, y, var, t0 = self._trusted
        lim = self.plausibility
        reach = lim.max_speed_m_s * max(t - t0, 0.0) + 3.0 * math.sqrt(max(var, 0.0)) + lim.slack_m
        return math.hypot(float(pose[0]) - x, float(pose[1]) - y) <= reach

    def _on_start(self) -> None:
        """Hook for subclasses: called once the start-up search has set the pose."""

    # consider-filter hooks (``consider = True``; :class:`~agvnav.positioning.ekf.EkfEstimator`)
    def _consider_args(self, f02: float, f12: float) -> Any:  # pragma: no cover - abstract
        """``(M, C, svar)`` for :func:`~agvnav.positioning._fast.gate_one`, ``M`` moved by ``F(f02, f12)``."""
        raise NotImplementedError

    def _consider_factors(self) -> tuple[tuple[float, ...], NDArray[np.float64]]:
        """``(M, C)`` of the factored ``P_xp = M C^T`` for the compiled gate (placeholders without consider)."""
        return _NO_M, _NO_C

    def _consider_reset(self) -> None:  # pragma: no cover - abstract
        """``P_xp <- 0`` (a new start)."""
        raise NotImplementedError

    def _accept(self, t: float, bearing: float, assoc: Any) -> None:  # pragma: no cover - abstract
        raise NotImplementedError


def _finite_float(name: str, value: Any) -> float:
    """``value`` as a finite float, else ValueError naming ``name`` (scalar fast path of ``require_finite``)."""
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric: {exc}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} contains NaN or inf")
    return v


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
