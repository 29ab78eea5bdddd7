"""Laps of the seed-004 tracked robot: run the closed loop, measure the error per lap (Tables I-II).

Seed 004 §III compares, lap by lap, the theoretical end point of the square
route (its start) with where the robot really stopped. Here a lap ends at the
automaton's transition into E4 (four turns counted); the true pose at that
instant gives two figures per lap ``n``:

* ``error_m[n]``: distance of the true end point from the route start (the
  cumulative error, which dead reckoning lets grow);
* ``per_lap_m[n]``: distance between the end points of laps ``n`` and ``n-1``
  (the start for lap 1): the drift added by that lap, the seed's "error /
  vuelta" (its no-landmark column stays near 50 cm lap after lap instead of
  growing, so it is per lap, not cumulative).

For the route start both coincide at lap 1.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.actuators import PID, DriveGeometry, MotorPair, WheelSpeedLoop
from agvnav.guidance.hybrid import HybridController, HybridParams
from agvnav.kinematics.tracked import TrackedVehicle
from agvnav.positioning.wall_landmarks import LandmarkParams, WallLandmarkLocalizer, check_route_passes_landmarks
from agvnav.sim.engine import ClosedLoop, LoopOutput
from agvnav.sim.tracked import HybridAutopilot, TrackedPlant, UltrasonicSensorRole

__all__ = ["LapErrors", "TrackedRun", "lap_errors", "run_tracked"]


@dataclass(frozen=True)
class LapErrors:
    """Per-lap errors (m), arrays ``(n_laps,)``; ``end_xy (n_laps, 2)`` true end points; ``t`` lap end times (s)."""

    t: NDArray[np.float64]
    end_xy: NDArray[np.float64]
    error_m: NDArray[np.float64]
    per_lap_m: NDArray[np.float64]

    @property
    def laps(self) -> int:
        """Number of completed laps."""
        return int(self.t.size)


def lap_errors(
    transition_times: ArrayLike, t: ArrayLike, true_xy: ArrayLike, start_xy: ArrayLike
) -> LapErrors:
    """Errors per lap from the E4 transition times ``(n,)`` (s) and the recorded truth.

    ``t (k,)`` sample times, ``true_xy (k, 2)`` true positions (m), ``start_xy
    (2,)`` the route start (the theoretical end of every lap). Each transition
    time is matched to the nearest sample (the automaton steps at sample times).
    """
    tt = np.asarray(transition_times, dtype=np.float64).reshape(-1)
    ts = np.asarray(t, dtype=np.float64).reshape(-1)
    xy = np.asarray(true_xy, dtype=np.float64).reshape(-1, 2)
    start = np.asarray(start_xy, dtype=np.float64).reshape(2)
    if ts.size != xy.shape[0]:
        raise ValueError(f"t has {ts.size} samples but true_xy has {xy.shape[0]}")
    if tt.size and ts.size == 0:
        raise ValueError("no samples to read the lap ends from")
    k = np.clip(np.searchsorted(ts, tt - 1e-9), 0, max(ts.size - 1, 0))
    ends = xy[k] if tt.size else np.zeros((0, 2))
    error = np.hypot(*(ends - start).T) if tt.size else np.zeros(0)
    previous = np.vstack([start[None, :], ends[:-1]]) if tt.size else np.zeros((0, 2))
    per_lap = np.hypot(*(ends - previous).T) if tt.size else np.zeros(0)
    return LapErrors(tt, ends, error, per_lap)


@dataclass(kw_only=True)
class TrackedRun(LoopOutput):
    """One closed-loop run of the tracked robot: the loop's output, the automaton, its estimator, lap errors."""

    controller: Any
    estimator: Any
    laps: LapErrors
    use_landmarks: bool

    @property
    def true_xy(self) -> NDArray[np.float64]:
        """Driven path ``(k, 2)`` (m)."""
        return np.column_stack([self.series["x"], self.series["y"]])


def run_tracked(
    route: Any,
    walls: ArrayLike,
    layout: Any,
    truth_terrain: Any,
    odometry_terrain: Any,
    *,
    geometry: Any = None,
    motor: dict[str, float] | None = None,
    pid: dict[str, float] | None = None,
    params: Any = None,
    laps: int = 10,
    use_landmarks: bool = True,
    step: float = 0.1,
    substep: float = 0.01,
    counts_per_rev: int = 1440,
    slip_noise_std: float = 0.0,
    seed: int = 0,
    wall_ids: Sequence[str] | None = None,
    duration: float | None = None,
    progress: Callable[[float], None] | None = None,
) -> TrackedRun:
    """Drive ``laps`` laps of ``route`` under the hybrid automaton (seed 004 Fig. 7) and measure them.

    ``walls (M, 2, 2)`` are what the rangers see and, with ``use_landmarks``, the
    landmarks; ``layout`` the :class:`~agvnav.sensors.ultrasonic.UltrasonicArray`;
    the terrains the truth and odometry :class:`~agvnav.kinematics.tracked.TrackTerrain`;
    ``motor`` / ``pid`` keyword overrides of :class:`~agvnav.actuators.MotorPair` /
    :class:`~agvnav.actuators.PID`. ``duration`` (s) defaults to 1.5 x the nominal lap time
    x laps. Deterministic for ``seed``.

    The estimator of the loop is a
    :class:`~agvnav.positioning.wall_landmarks.WallLandmarkLocalizer` fed by the
    rangers (left out when not ``use_landmarks``: pure dead reckoning); the automaton reads it.
    """
    geometry = geometry or DriveGeometry()
    params = params or HybridParams()
    segs = np.asarray(walls, dtype=np.float64).reshape(-1, 2, 2)
    landmark = LandmarkParams(**params.landmark_kwargs())
    if use_landmarks:
        legs = [route.leg(k) for k in range(route.n_legs)]
        check_route_passes_landmarks(legs, segs, layout.body_width, landmark.detect_range, landmark.parallel_tolerance)
    localizer = WallLandmarkLocalizer(segs, layout, landmark, pose=route.start_pose, wall_ids=wall_ids)
    ctrl = HybridController(route, localizer, geometry, params, laps)
    vehicle = TrackedVehicle(geometry.track_width, geometry.wheel_radius, truth_terrain)
    u_max = float((motor or {}).get("u_max", 12.0))
    loop = WheelSpeedLoop(MotorPair(**(motor or {})), PID(**{"u_min": -u_max, "u_max": u_max, **(pid or {})}))
    plant = TrackedPlant(vehicle, loop, odometry_terrain, counts_per_rev, route.start_pose, substep, slip_noise_std)
    sensors = [UltrasonicSensorRole(layout, segs)] if use_landmarks else []
    engine = ClosedLoop(plant, sensors, localizer, HybridAutopilot(ctrl), step, seed)
    if duration is None:
        duration = 1.5 * laps * nominal_lap_time(route, params) + 10.0
    out = engine.run(duration, end_hold=0.0, progress=progress)
    e4 = [tr.t for tr in ctrl.transitions if tr.target.value == "E4"]
    xy = np.column_stack([out.series["x"], out.series["y"]])
    le = lap_errors(e4, out.series["t"], xy, route.start_pose[:2])
    return TrackedRun(series=out.series, events=out.events, wall_time_s=out.wall_time_s, finished=out.finished,
                      controller=ctrl, estimator=localizer, laps=le, use_landmarks=bool(use_landmarks))


def nominal_lap_time(route: Any, params: Any) -> float:
    """Time (s) of one lap at cruise speed with turns at the turn rate and the dwell."""
    perimeter = sum(route.leg(k)[2] for k in range(route.n_legs))
    turning = route.n_legs * (math.pi / 2) / params.turn_rate
    return perimeter / params.cruise_speed + turning + params.dwell
