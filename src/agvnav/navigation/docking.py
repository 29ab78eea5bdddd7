"""Docking at a station relative to its target (issue 32): the estimates side by side and the docking autopilot.

* :class:`DockingEstimate` - the estimator role during a docking: the global EKF positions the
  vehicle in ``map`` (and is what the run records), the station estimator
  (:class:`agvnav.positioning.station.StationEstimator`) positions it relative to the station;
  every odometry increment and reflection goes to both. The target reflectors are not in the
  global map, so the global EKF gates them out: a wrongly mapped station cannot corrupt it.
* :class:`DockingAutopilot` - recognise the target standing at the approach start, then follow
  the straight approach to the docking pose guided on the *station-relative* pose carried into
  ``map`` by the station's map pose (so the path drawn on the map lands on the station as it
  really stands), a fine positioning at standstill for a vehicle that turns on the spot
  (:class:`agvnav.guidance.FinePositioner`), settle, and judge: the docking is ``finished`` only
  when the station estimate is trusted (target recognised and consistent), its 3 sigma and its
  estimated error lie within the tolerances and the measured station offset within the station's
  allowed one; otherwise ``failure`` names the reason (VDA 5050: a failed ``finePositioning``).

The guided point is base_link: point O of the tricycle stacker (between the fork wheels, seed 000
§3.1 [seed000 eq11]; it enters backwards) and of the differential AGV.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import wrap_angle_scalar
from agvnav.guidance import FinePositioner
from agvnav.navigation.path import PathAutopilot
from agvnav.positioning.station import StationEstimator, prior_in_station, station_offset
from agvnav.roles import BearingEstimator, Estimator, Plant
from agvnav.world.docking import DockingTarget

__all__ = ["DockingAutopilot", "DockingEstimate", "DockingTolerances", "StationView"]

#: Phase codes recorded in ``dock_phase``.
PHASES = {"recognise": 0.0, "approach": 1.0, "fine": 2.0, "settle": 3.0, "finished": 4.0, "failed": -1.0}


class DockingEstimate:
    """The global estimator and the station estimator fed together (module doc).

    ``pose``, ``covariance``, ``status`` and ``t`` are the global estimator's (``map``);
    ``station`` the station-relative one.
    """

    def __init__(self, global_estimator: BearingEstimator, station: StationEstimator) -> None:
        self.global_estimator = global_estimator
        self.station = station

    def predict(self, t: float, delta_d: float, delta_theta: float, delta_lateral: float = 0.0) -> None:
        """One odometry increment (m, rad, m) to both estimators."""
        self.global_estimator.predict(t, delta_d, delta_theta, delta_lateral)
        self.station.predict(t, delta_d, delta_theta, delta_lateral)

    def update(self, t: float, bearing: float) -> bool:
        """One reflection (s, rad) to both; True when the global estimator used it."""
        used = self.global_estimator.update(t, bearing)
        self.station.update(t, bearing)
        return bool(used)

    @property
    def pose(self) -> NDArray[np.float64]:
        """The global pose (3,) in ``map`` (m, m, rad)."""
        return self.global_estimator.pose

    @property
    def covariance(self) -> NDArray[np.float64]:
        """The global covariance (3, 3)."""
        return self.global_estimator.covariance

    @property
    def status(self) -> str:
        """The global estimator's status."""
        return str(self.global_estimator.status)

    @property
    def t(self) -> float:
        """Time of the latest input (s)."""
        return float(self.global_estimator.t)


class StationView:
    """The station-relative estimate carried into ``map`` by the station's *map* pose: what docking guides on.

    ``pose = S_map x_station``: following a path drawn relative to the map's station on this pose
    puts the vehicle where the path lies relative to the station as it really stands.
    """

    def __init__(self, station: StationEstimator, station_map_pose: tuple[float, float, float]) -> None:
        self.station = station
        self.s = station_map_pose

    @property
    def pose(self) -> NDArray[np.float64]:
        """The pose (3,) (m, m, rad)."""
        x = self.station.pose
        c, si = math.cos(self.s[2]), math.sin(self.s[2])
        return np.array([self.s[0] + c * x[0] - si * x[1], self.s[1] + si * x[0] + c * x[1],
                         wrap_angle_scalar(float(self.s[2] + x[2]))])

    @property
    def covariance(self) -> NDArray[np.float64]:
        """The covariance (3, 3), rotated into ``map``."""
        c, si = math.cos(self.s[2]), math.sin(self.s[2])
        rot = np.array([[c, -si, 0.0], [si, c, 0.0], [0.0, 0.0, 1.0]])
        return rot @ self.station.covariance @ rot.T

    @property
    def status(self) -> str:
        """``tracking`` while the station estimator tracks, else ``lost``."""
        return "tracking" if self.station.status == "tracking" else "lost"

    @property
    def t(self) -> float:
        """Time of the station estimator's latest input (s)."""
        return float(self.station.t)

    def predict(self, t: float, delta_d: float, delta_theta: float, delta_lateral: float = 0.0) -> None:
        """Refused (TypeError): a read-only view; the loop feeds :class:`DockingEstimate`."""
        raise TypeError("StationView is read-only: odometry goes to DockingEstimate")


@dataclass(frozen=True)
class DockingTolerances:
    """What a finished docking must meet: ``position`` (m) and ``heading`` (rad) of the guided point,
    both for the estimated error and for 3 sigma of the estimate; ``settle_s`` (s) the standstill
    before judging (the estimate converges at rest); ``recognise_s`` (s) how long recognition may take."""

    position: float = 0.003
    heading: float = math.radians(0.1)
    settle_s: float = 1.0
    recognise_s: float = 3.0


class DockingAutopilot:
    """Recognise, approach on the station-relative pose, fine-position, settle, judge (module doc).

    ``approach`` is a :class:`~agvnav.navigation.path.PathAutopilot` on the straight approach
    drawn relative to the map's station; ``estimate`` the :class:`DockingEstimate` the loop feeds;
    ``fine`` the fine positioning of a vehicle that turns on the spot (None for the stacker: a
    tricycle cannot turn at standstill, it stops where the approach ends). ``relative`` False: the
    comparison of today's station stop, guided and fine-positioned on the global pose where the map
    places the station, reported finished without a judgement.
    """

    signal_names: tuple[str, ...] = (
        *PathAutopilot.signal_names, "dock_phase", "dock_x", "dock_y", "dock_psi", "dock_sigma3_m",
        "station_offset_x", "station_offset_y", "station_offset_psi",
    )

    def __init__(self, target: DockingTarget, approach: PathAutopilot, estimate: DockingEstimate,
                 tolerances: DockingTolerances = DockingTolerances(), fine: FinePositioner | None = None,
                 relative: bool = True) -> None:
        self.target = target
        self.approach = approach
        self.signal_names = (*approach.signal_names, *DockingAutopilot.signal_names[len(PathAutopilot.signal_names):])
        self.estimate = estimate
        self.tol = tolerances
        self.fine = fine
        self.relative = bool(relative)
        self.view: Estimator = StationView(estimate.station, target.station) if relative else estimate
        self.phase = "recognise"
        self.finished = False
        self.failure: str | None = None
        self.offset = np.full(3, math.nan)
        """the measured station offset (m, m, rad) in the map station's frame, at the judgement."""
        self._t0 = math.nan
        self._settle_t = math.nan
        self.dock_time_s = math.nan
        """time from the approach start to the judgement (s)."""

    def _hold(self) -> tuple[float, ...]:
        return (0.0, 0.0, 0.0) if self.approach.family == "holonomic" else (0.0, 0.0)

    def _fail(self, reason: str) -> tuple[float, ...]:
        self.phase, self.failure, self.finished = "failed", f"docking_failed: {reason}", True
        return self._hold()

    def command(self, t: float, estimator: Estimator, plant: Plant, dt: float) -> tuple[float, ...]:
        """The plant command for the next ``dt`` s."""
        station = self.estimate.station
        if self.phase in ("finished", "failed"):
            return self._hold()
        if self.phase == "recognise":
            return self._recognise(t, estimator) if self.relative else self._start_on_map(t, estimator)
        why = station.check(t)
        if why is not None:
            return self._fail(why)
        if self.phase == "approach":
            cmd = self.approach.command(t, self.view, plant, dt)
            if self.approach.failure is not None:
                return self._fail(f"approach {self.approach.failure}")
            if self.approach.finished:
                self._next_after_approach(t)
            return cmd
        if self.phase == "fine" and self.fine is not None:
            out = self.fine.command(self.view, dt)
            if out is not None:
                return out
            self.phase, self._settle_t = "settle", t
        if self.phase == "settle" and t - self._settle_t >= self.tol.settle_s:
            return self._judge(t)
        return self._hold()

    def _recognise(self, t: float, estimator: Estimator) -> tuple[float, ...]:
        station = self.estimate.station
        if station.status == "idle":
            if estimator.status != "tracking":
                return self._hold()
            x, P = prior_in_station(self.target.station, estimator.pose, estimator.covariance, self.target.max_offset)
            station.start(t, x, P)
            self._t0 = t
        if station.status == "failed":
            return self._fail(str(station.reason))
        if station.status == "tracking":
            self.phase = "approach"
        elif t - self._t0 > self.tol.recognise_s:
            station.last_try()
        return self._hold()

    def _start_on_map(self, t: float, estimator: Estimator) -> tuple[float, ...]:
        if estimator.status == "tracking":
            self.phase, self._t0 = "approach", t
        return self._hold()

    def _next_after_approach(self, t: float) -> None:
        if self.fine is not None:
            x, y, h = self._docking_in_map()
            self.fine.start(x, y, h)
            self.phase = "fine"
        else:
            self.phase, self._settle_t = "settle", t

    def _docking_in_map(self) -> tuple[float, float, float]:
        s, d = self.target.station, self.target.docking_pose
        c, si = math.cos(s[2]), math.sin(s[2])
        return s[0] + c * d[0] - si * d[1], s[1] + si * d[0] + c * d[1], wrap_angle_scalar(s[2] + d[2])

    def errors(self) -> tuple[float, float, float, float]:
        """Estimated docking errors: position (m), heading (rad), 3 sigma position (m), 3 sigma heading (rad)."""
        x = self.estimate.station.pose
        P = self.estimate.station.covariance
        d = self.target.docking_pose
        pos = math.hypot(x[0] - d[0], x[1] - d[1])
        head = abs(wrap_angle_scalar(float(x[2] - d[2])))
        sig = 3.0 * math.sqrt(max(float(np.linalg.eigvalsh(P[:2, :2])[-1]), 0.0))
        return pos, head, sig, 3.0 * math.sqrt(max(float(P[2, 2]), 0.0))

    def _judge(self, t: float) -> tuple[float, ...]:
        if not self.relative:
            self.dock_time_s, self.phase, self.finished = t - self._t0, "finished", True
            return self._hold()
        why = self.estimate.station.check(t)
        if why is not None:
            return self._fail(why)
        self.dock_time_s = t - self._t0
        pos, head, sig, sig_h = self.errors()
        self.offset = station_offset(self.target.station, self.estimate.pose, self.estimate.station.pose)
        tol = self.tol
        if sig > tol.position or sig_h > tol.heading:
            return self._fail(f"3 sigma {sig * 1e3:.2f} mm / {math.degrees(sig_h):.3f} deg over the tolerance "
                              f"{tol.position * 1e3:.2f} mm / {math.degrees(tol.heading):.3f} deg")
        if pos > tol.position or head > tol.heading:
            return self._fail(f"estimated error {pos * 1e3:.2f} mm / {math.degrees(head):.3f} deg over the tolerance")
        o_xy, o_psi = self.target.max_offset
        if math.hypot(self.offset[0], self.offset[1]) > o_xy or abs(self.offset[2]) > o_psi:
            return self._fail(f"station offset {math.hypot(self.offset[0], self.offset[1]) * 1e3:.1f} mm / "
                              f"{math.degrees(self.offset[2]):.2f} deg beyond the allowed {o_xy * 1e3:.0f} mm / "
                              f"{math.degrees(o_psi):.1f} deg")
        self.phase, self.finished = "finished", True
        return self._hold()

    def signals(self) -> tuple[float, ...]:
        """The approach's signals, then the phase, the station-frame estimate, its 3 sigma, the station offset."""
        x = self.estimate.station.pose
        P = self.estimate.station.covariance
        finite = bool(np.all(np.isfinite(P)))
        sig = 3.0 * math.sqrt(max(float(np.linalg.eigvalsh(P[:2, :2])[-1]), 0.0)) if finite else math.nan
        return (*self.approach.signals(), PHASES[self.phase], float(x[0]), float(x[1]), float(x[2]), sig,
                *(float(v) for v in self.offset))
