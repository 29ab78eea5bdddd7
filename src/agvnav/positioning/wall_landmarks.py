"""Dead reckoning corrected by ultrasonic wall landmarks (seed 004 §II-B).

Seed 004 positions a tracked robot on a fixed route by dead reckoning
([seed004 eq3] [seed004 eq4] [seed004 eq5]) and recalibrates it with walls placed along the route as
landmarks, measured by HY-SRF05 rangers (agvnav.sensors.ultrasonic):

the heading from a side pair beside a wall ([seed004 eq6] [seed004 eq7]) and the distance
from a wall ahead ([seed004 eq8], generalised to any wall, heading and mount), whose
relations are in :mod:`agvnav.positioning.wall_ranging` (with the cone-beam deviation from
the seed's arctan); the parameters and the calibration record are in
:mod:`agvnav.positioning.landmark_params`. Dead reckoning uses the Euler rule of
[seed004 eq3] [seed004 eq4] [seed004 eq5], as the seed does, through
agvnav.odometry.integrate_pose (``rule`` selects its exact-arc form instead).

:class:`WallLandmarkLocalizer` is a streaming estimator of its own (the
interface of docs/ARCHITECTURE.md): odometry through ``predict``, the readings
of one ping instant through ``update_ranges``, which associates them with the
walls (which side pair sees which wall, abreast and parallel checks, the front
wall of [seed004 eq8]) and applies the corrections above. Any navigator reads the
corrected pose from it; the seed-004 automaton (agvnav.guidance.hybrid) also
reads its ``history`` of calibrations to know when a landmark is alongside.
The EKF fuses the same ranges one by one (agvnav.positioning.wall_ranges).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_positive
from agvnav.geometry import angle_diff, wrap_angle
from agvnav.odometry import OdometryNoise, integrate_pose
from agvnav.positioning._fast import predict_covariance, process_noise
from agvnav.positioning.landmark_params import Calibration, LandmarkParams
from agvnav.positioning.plausibility import (
    MAX_DEPARTURE,
    DropCounter,
    PlausibilityLimits,
    implausible_increment,
    sound_state,
)
from agvnav.positioning.wall_ranging import check_beam, distance_from_wall, heading_from_side_pair, wall_line
from agvnav.sensors.ultrasonic import ConeEcho, UltrasonicArray, UltrasonicSensor, check_wall_segments

__all__ = ["WallLandmarkLocalizer"]


@dataclass
class _Reading:
    t: float = -math.inf
    range: float = math.nan


class WallLandmarkLocalizer:
    """Dead reckoning recalibrated by ultrasonic wall landmarks: a streaming estimator (seed 004 §II-B).

    Parameters
    ----------
    walls : ``(M, 2, 2)`` landmark wall segments (m) in ``map`` (may be empty).
    rangers : the :class:`~agvnav.sensors.ultrasonic.UltrasonicArray` (names and
        mounts); it must hold every sensor named in ``params``. Without rangers the
        localizer is pure dead reckoning (and :meth:`update_ranges` refuses input).
    params : :class:`LandmarkParams`.
    pose, t : start pose ``(3,)`` (m, m, rad) and time (s).
    beam : range geometry, ``"cone"`` (nearest echo) or ``"ray"`` (see module doc).
    rule : odometry integration rule (``"euler"``: the seed's dead reckoning, see :meth:`predict`).
    wall_ids : names of the walls (for the calibration records).
    odometry_noise : :class:`~agvnav.odometry.OdometryNoise` of the covariance growth.
    initial_covariance : ``(3, 3)`` covariance of ``pose`` (default 1 mm, 1 mrad std).
    range_std : std (m) of one range for the covariance of a calibration (default the
        rangers' mean ``noise_std``, else 3 mm).
    strict : True (the API): a non-finite, out-of-order or implausible input raises
        ValueError. False (a running vehicle): it is dropped and counted in :attr:`n_dropped`
        per reason, as the streaming estimators do
        (:class:`~agvnav.positioning.estimator.StreamingEstimator`).
    plausibility : :class:`~agvnav.positioning.plausibility.PlausibilityLimits` (max speed
        and yaw rate, max odometry gap) an odometry increment is judged by; the first one
        as if it spanned ``max_gap_s`` (its span is unknown).

    A refused odometry increment is replaced by no motion and the covariance grows by what
    the vehicle could have done in its span (as
    :meth:`~agvnav.positioning.estimator.StreamingEstimator.predict` does for a time gap);
    a ping's readings that are not finite ranges are taken as no echo. Whatever would leave
    the pose non-finite or the covariance not symmetric positive definite is not applied
    (``"broken_state"`` in :attr:`n_dropped`).

    The estimator interface of docs/ARCHITECTURE.md: :meth:`predict` with the odometry
    increment, :meth:`update_ranges` with the readings of one instant, then ``pose``,
    ``covariance``, ``status`` and ``t``. ``status`` is ``"tracking"`` right after a
    calibration and ``"dead_reckoning"`` after a prediction. ``history`` keeps every
    :class:`Calibration`.

    Association (per call of :meth:`update_ranges`, from the estimated pose): a side
    pair calibrates when both of its latest readings (at most ``pair_max_age`` old,
    within ``detect_range``) match the range predicted to the same wall within
    ``gate``, the wall runs parallel to the estimated heading and both sensors are
    abreast of it: then the heading (:meth:`calibrate_heading`) and, with ``lateral_calibration``, the
    distance to the wall. The front sensor fixes the position along the normal of a
    wall across the heading within ``front_gate`` (:meth:`calibrate_offset`). Each correction is blended
    by ``calibration_gain`` (a complementary filter; 1 replaces as the seed does).

    Covariance (honest but simple): the odometric growth ``P' = F P F^T + Q`` with
    ``F`` the Jacobian of the Euler step and ``Q`` Crowley's model
    (:func:`agvnav.odometry.motion_covariance`); each correction is a
    fixed-gain update in Joseph form, ``P' = (I - K H) P (I - K H)^T + K R K^T`` with
    ``K = g e`` the blend actually applied, ``H`` the direction it corrects and ``R``
    the variance of the measured heading (``2 range_std^2 / dist^2``) or distance
    (``range_std^2 / k`` for the mean of ``k`` ranges). It describes the estimator's
    own error only as well as ``OdometryNoise`` describes the odometry.
    """

    def __init__(
        self,
        walls: ArrayLike = (),
        rangers: UltrasonicArray | None = None,
        params: LandmarkParams | None = None,
        *,
        pose: ArrayLike = (0.0, 0.0, 0.0),
        t: float = 0.0,
        beam: str = "cone",
        rule: str = "euler",
        wall_ids: Sequence[str] | None = None,
        odometry_noise: OdometryNoise | None = None,
        initial_covariance: ArrayLike | None = None,
        range_std: float | None = None,
        strict: bool = True,
        plausibility: PlausibilityLimits | None = None,
    ) -> None:
        self.strict = bool(strict)
        self.plausibility = PlausibilityLimits() if plausibility is None else plausibility
        self.drops = DropCounter()
        self.params = params or LandmarkParams()
        self.walls = check_wall_segments(walls) if np.size(walls) else np.zeros((0, 2, 2))
        self.rangers = rangers
        if rangers is not None:
            missing = self.params.sensor_names - set(rangers.names)
            if missing:
                raise ValueError(f"ranger array lacks {sorted(missing)} (see agvnav.sensors.seed_004_layout)")
        self.wall_ids = list(wall_ids) if wall_ids is not None else [f"W{i}" for i in range(len(self.walls))]
        if len(self.wall_ids) != len(self.walls):
            raise ValueError(f"wall_ids names {len(self.wall_ids)} walls, but there are {len(self.walls)}")
        check_beam(beam)
        if rule not in ("euler", "midpoint", "arc"):
            raise ValueError(f"rule must be 'euler', 'midpoint' or 'arc', got {rule!r}")
        self.beam, self.rule = beam, rule
        self.odometry_noise = odometry_noise or OdometryNoise()
        default_std = float(np.mean([rangers[n].noise_std for n in rangers.names])) if rangers is not None else 0.003
        self.range_std = require_positive("range_std", default_std if range_std is None else range_std)
        self._P0 = np.diag([1e-3, 1e-3, 1e-3]) ** 2 if initial_covariance is None else initial_covariance
        self.history: list[Calibration] = []
        self.reset(pose, t)

    @property
    def n_dropped(self) -> dict[str, int]:
        """Inputs dropped as implausible (``strict=False``), per reason."""
        return dict(self.drops.by_reason)

    def _refuse(self, t: float, reason: str, message: str) -> None:
        """ValueError with ``message`` (strict), else count the dropped reading under ``reason``."""
        if self.strict:
            raise ValueError(message)
        self.drops.drop(t, reason)

    @property
    def gain(self) -> float:
        """Blend of each correction (``params.calibration_gain``)."""
        return self.params.calibration_gain

    def reset(self, pose: ArrayLike, t: float = 0.0) -> None:
        """Restart from a known pose (m, m, rad) at time ``t`` (s): history, readings and covariance reset."""
        self.pose = require_finite("pose", pose).reshape(3).copy()
        self.covariance = require_finite("initial_covariance", self._P0).reshape(3, 3).copy()
        self.t, self.status = float(t), "dead_reckoning"
        self._t_odometry: float | None = None  # the latest odometry message (s); None: the next is the first
        self.history.clear()
        names = self.rangers.names if self.rangers is not None else ()
        self._last = {name: _Reading() for name in names}
        self._predicted: ConeEcho | None = None

    # ------------------------------------------------------------------ odometry
    def predict(self, t: float, delta_d: float, delta_theta: float, delta_lateral: float = 0.0) -> None:
        """Dead reckoning by an odometry increment (m, rad, m) up to time ``t`` (s).

        [seed004 eq3] [seed004 eq4] [seed004 eq5] with ``rule="euler"``;
        ``delta_lateral`` (body-frame y, holonomic vehicles) is added at the old heading.
        """
        t = float(t)
        if not (math.isfinite(t) and t >= self.t):
            self._refuse(self.t, "out_of_order" if math.isfinite(t) else "non_finite",
                         f"odometry at t={t!r} s comes before the latest input at t={self.t!r} s")
            return
        # the first message's span is unknown (the start time may be a placeholder): judged over max_gap_s
        span = None if self._t_odometry is None else t - self._t_odometry
        increment = (float(delta_d), float(delta_theta), float(delta_lateral))
        if not all(math.isfinite(v) for v in increment):
            reason: str | None = "non_finite"
            message = "delta_d, delta_theta and delta_lateral must be finite"
        else:
            reason = implausible_increment(self.plausibility, span, *increment)
            message = f"odometry increment {increment} over {span!r} s at t={t!r} s is implausible ({reason})"
        if reason is not None:
            self._refuse(t, reason, message)
            self._t_odometry = t
            self._blow_up(0.0 if span is None else span)
            self.t, self.status = t, "dead_reckoning"
            return
        self._t_odometry = t
        pose, P = self.pose, self.covariance
        psi = float(self.pose[2])
        self.pose = integrate_pose(self.pose, delta_d, delta_theta, rule=self.rule)
        if delta_lateral != 0.0:
            self.pose[:2] += delta_lateral * np.array([-math.sin(psi), math.cos(psi)])
        self._grow_covariance(psi, delta_d, delta_theta, delta_lateral)
        self.t, self.status = t, "dead_reckoning"
        self._keep_sound(t, pose, P)

    def _blow_up(self, span: float) -> None:
        """Grow the position and heading variances by what the vehicle could do in ``span`` s (capped)."""
        lim = self.plausibility
        d = min(lim.max_speed_m_s * span, MAX_DEPARTURE)
        a = min(lim.max_yaw_rate_rad_s * span, MAX_DEPARTURE)
        self.covariance = self.covariance + np.diag([d * d, d * d, a * a])

    def _keep_sound(self, t: float, pose: NDArray[np.float64], P: NDArray[np.float64]) -> None:
        """Put back ``pose``, ``P`` (the state before the step) when the step broke the state; counted."""
        if sound_state(tuple(self.pose.tolist()), tuple(self.covariance.reshape(9).tolist())):
            return
        self.pose, self.covariance = pose, P
        self.drops.drop(t, "broken_state")

    def _grow_covariance(self, psi: float, dd: float, dth: float, dl: float) -> None:
        """``P' = F P F^T + Q`` of the Euler step (Crowley's ``Q``; lateral variance ``k_d |dl|``)."""
        k = self.odometry_noise
        Q = process_noise(psi, dd, dth, k.k_d, k.k_dtheta, k.k_theta)
        c, s = math.cos(psi), math.sin(psi)
        f02, f12 = -dd * s - dl * c, dd * c - dl * s
        P = predict_covariance(tuple(self.covariance.reshape(9).tolist()), f02, f12, Q)
        self.covariance = np.array(P).reshape(3, 3)
        if dl != 0.0:
            n = np.array([-s, c, 0.0])
            self.covariance += k.k_d * abs(dl) * np.outer(n, n)

    # ------------------------------------------------------------------ ranges
    def update_ranges(self, t: float, ranges: Mapping[str, float]) -> int:
        """Ultrasonic readings made at time ``t`` (s); returns the number of corrections applied.

        ``ranges`` maps ranger names to ranges (m; nan for a ping without a valid echo).
        Call it once the pose has been predicted up to ``t``, so a calibration corrects
        the pose of the instant of the ping. Readings are kept per sensor: a side pair
        pairs each new reading with its partner's latest one (see the class doc).
        """
        if self.rangers is None:
            raise ValueError("this localizer was built without rangers: give rangers= to use update_ranges")
        t = float(t)
        unknown = set(ranges) - set(self._last)
        if unknown:
            raise ValueError(f"unknown rangers {sorted(unknown)}; the array has {list(self.rangers.names)}")
        if not math.isfinite(t) or t < self.t - 1e-12:
            self._refuse(self.t, "out_of_order" if math.isfinite(t) else "non_finite",
                         f"ranges at t={t!r} s come before the latest input at t={self.t!r} s")
            return 0
        for name, value in ranges.items():
            r = float(value)
            self._last[name] = _Reading(t, r if 0.0 <= r < math.inf else math.nan)  # else no echo
        n_before = len(self.history)
        if ranges and self.walls.shape[0]:
            self._landmark_updates(t, set(ranges))
        return len(self.history) - n_before

    def _landmark_updates(self, t: float, fresh: set[str]) -> None:
        """Side pairs first (heading, then lateral offset), then the front sensor (offset along the wall normal)."""
        p = self.params
        self._predicted = None
        for side, front, rear in p.side_pairs:
            if not fresh & {front, rear}:
                continue
            if max(t - self._last[front].t, t - self._last[rear].t) > p.pair_max_age:
                continue
            wall = self._associate(front, p.gate)
            if wall < 0 or self._associate(rear, p.gate) != wall or not self._is_parallel(wall):
                continue
            if not (self._abreast(front, wall) and self._abreast(rear, wall)):
                continue
            self._calibrate_side(t, side, front, rear, wall)
            self._predicted = None
        if p.front_sensor in fresh:
            wall = self._associate(p.front_sensor, p.front_gate)
            if wall >= 0 and not self._is_parallel(wall):
                sensor = self._ranger(p.front_sensor)
                self.calibrate_offset(t, [self._last[p.front_sensor].range], [sensor.mount], self.walls[wall],
                                      kind="front_offset", wall_index=wall, side="front")

    def _ranger(self, name: str) -> UltrasonicSensor:
        assert self.rangers is not None  # update_ranges checked it
        return self.rangers[name]

    def _associate(self, name: str, gate: float) -> int:
        """Wall index that explains the latest reading of ``name`` (within ``gate`` m of its prediction), or -1."""
        reading = self._last[name]
        if not (math.isfinite(reading.range) and reading.range <= self.params.detect_range):
            return -1
        if self._predicted is None:  # one batched prediction for all sensors per pose
            assert self.rangers is not None
            self._predicted = self.rangers.echo(self.pose, self.walls)
        assert self.rangers is not None
        i = self.rangers.names.index(name)
        segment, predicted = int(self._predicted.segment[i]), float(self._predicted.range[i])
        if segment < 0 or abs(predicted - reading.range) > gate:
            return -1
        return segment

    def _calibrate_side(self, t: float, side: str, front: str, rear: str, wall: int) -> None:
        m_front, m_rear = self._ranger(front).mount, self._ranger(rear).mount
        r_front, r_rear = self._last[front].range, self._last[rear].range
        spacing = m_front[0] - m_rear[0]
        self.calibrate_heading(t, r_front, r_rear, spacing, side, self.walls[wall], wall)
        if self.params.lateral_calibration:
            self.calibrate_offset(t, [r_front, r_rear], [m_front, m_rear], self.walls[wall], kind="side_offset",
                                  wall_index=wall, side=side)

    def _abreast(self, name: str, wall: int) -> bool:
        """True if the sensor's estimated position projects onto the wall ``end_margin`` inside its ends."""
        a, b = self.walls[wall]
        u = (b - a) / np.hypot(*(b - a))
        along = float(u @ (self._ranger(name).sensor_pose(self.pose)[:2] - a))
        return self.params.end_margin <= along <= float(np.hypot(*(b - a))) - self.params.end_margin

    def _is_parallel(self, wall: int) -> bool:
        """True if the wall runs within ``parallel_tolerance`` of the estimated heading (either way)."""
        d = self.walls[wall, 1] - self.walls[wall, 0]
        across = abs(math.sin(math.atan2(d[1], d[0]) - float(self.pose[2])))
        return across <= math.sin(self.params.parallel_tolerance)

    # ------------------------------------------------------------------ the seed's corrections
    def calibrate_heading(
        self,
        t: float,
        us_front: float,
        us_rear: float,
        spacing: float,
        side: str,
        wall: ArrayLike,
        wall_index: int = -1,
    ) -> float:
        """Correct the heading from a side pair beside ``wall (2, 2)`` [seed004 eq6] [seed004 eq7]; return it (rad).

        The wall direction is taken along the current heading estimate (the
        wall is parallel to the route leg), so it is unambiguous.
        """
        seg = require_finite("wall", wall).reshape(2, 2)
        d = seg[1] - seg[0]
        wall_heading = math.atan2(d[1], d[0])
        if abs(float(angle_diff(wall_heading, self.pose[2]))) > math.pi / 2:
            wall_heading = float(wrap_angle(wall_heading + math.pi))
        measured = float(heading_from_side_pair(us_front, us_rear, spacing, side, wall_heading, self.beam))
        after = self.pose.copy()
        after[2] = wrap_angle(self.pose[2] + self.gain * angle_diff(measured, self.pose[2]))
        variance = 2.0 * self.range_std**2 / spacing**2
        self._apply(t, "heading", wall_index, after, np.array([0.0, 0.0, 1.0]), variance, side)
        return measured

    def calibrate_offset(
        self,
        t: float,
        ranges: ArrayLike,
        mounts: ArrayLike,
        wall: ArrayLike,
        kind: str = "front_offset",
        wall_index: int = -1,
        side: str = "",
    ) -> float:
        """Correct the position along ``wall``'s normal from ranges of sensors facing it [seed004 eq8].

        ``ranges (k,)`` (m) from sensors with ``mounts (k, 3)``; the implied
        signed distances are averaged. Returns the measured distance (m).
        """
        r = require_finite("ranges", ranges).reshape(-1)
        n, c = wall_line(wall, self.pose[:2])
        measured = float(np.mean(distance_from_wall(r, mounts, float(self.pose[2]), n, self.beam)))
        current = float(np.dot(n, self.pose[:2]) - c)
        after = self.pose.copy()
        after[:2] += self.gain * (measured - current) * n
        self._apply(t, kind, wall_index, after, np.array([n[0], n[1], 0.0]), self.range_std**2 / r.size, side)
        return measured

    def _apply(
        self, t: float, kind: str, wall_index: int, after: NDArray[np.float64], direction: NDArray[np.float64],
        variance: float, side: str,
    ) -> None:
        """Record and apply a correction along ``direction`` with its fixed-gain Joseph covariance update."""
        wall_id = self.wall_ids[wall_index] if 0 <= wall_index < len(self.wall_ids) else ""
        self.history.append(Calibration(float(t), kind, int(wall_index), self.pose.copy(), after.copy(), side, wall_id))
        K = self.gain * direction
        A = np.eye(3) - np.outer(K, direction)
        P = A @ self.covariance @ A.T + variance * np.outer(K, K)
        P = 0.5 * (P + P.T)
        if not sound_state(tuple(after.tolist()), tuple(P.reshape(9).tolist())):
            self.history.pop()  # not applied (an extreme covariance the update's rounding broke)
            self.drops.drop(t, "broken_state")
            return
        self.covariance = P
        self.pose, self.t, self.status = after, float(t), "tracking"
