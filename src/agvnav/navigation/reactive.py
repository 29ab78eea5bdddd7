"""The reaction to obstacles and their avoidance, as the vehicle runs them (issue 18).

The parts live in :mod:`agvnav.reactive` (fields, the slow/stop/resume reaction, detours);
:mod:`agvnav.sim.reactive` wires them into a run (the scanner and ranger roles fill a
:class:`ReactiveInputs`):

* :class:`ReactiveWatch`: the positioning guard's watch with the reaction's speed scale composed
  in (``min`` of the two);
* :class:`ReactiveAutopilot`: the :class:`~agvnav.navigation.path.PathAutopilot` of the route
  whose speed scale is the smaller of the positioning guard's and the reaction's;
  field sets are chosen by ``max(|v|, v_intended)`` (the speed it would drive at, so a stop is
  not released by the field shrinking at standstill), on a detour at the slow fraction the
  configuration's creep set (``detour_fields``); an emergency stop brakes at the
  emergency deceleration; on a segment that allows it, a stop for a static obstacle that lasts
  ``avoid_after_s`` plans a detour (:func:`agvnav.reactive.plan_detour`) driven at the slow
  fraction, then the route resumes. A detour is planned for a *static* obstacle: one in a field
  whose echoes (off the map's walls) have not moved over ``avoid_after_s``, so a person
  crossing is waited for and a pallet is driven round, planned while the vehicle slows down
  (a long warning field leaves room for the S-curve) or once it stands.

The autopilot decides from the estimate and the sensors' inputs only. It also records, for the
run's figures, the clearance to each true obstacle and the body's excursion beyond the corridor
at the true pose (``plant.pose``); those columns are the simulator's instrumentation, never read
back by the decisions.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from shapely.geometry.base import BaseGeometry

from agvnav.geometry import segment_distances
from agvnav.navigation.guard import SpeedWatch
from agvnav.navigation.path import PathAutopilot
from agvnav.reactive import (
    Detour,
    FieldConfig,
    FieldSet,
    Reaction,
    field_demand,
    intrusions,
    plan_detour,
    scanned_obstacle,
)
from agvnav.roles import Estimator, Plant
from agvnav.world.obstacles import ObstacleSet

__all__ = [
    "ASSUMED_DEPTH_M",
    "REACTIVE_SIGNALS",
    "STATIC_TOLERANCE_M",
    "WALL_TOLERANCE_M",
    "AvoidParams",
    "ReactiveAutopilot",
    "ReactiveInputs",
    "ReactiveWatch",
]

#: Signals the reaction adds to the recorded series (then one ``clearance__<id>`` per obstacle, m).
REACTIVE_SIGNALS = (
    "reaction_level",      # 0 clear, 1 slow, 2 stop
    "field_v_max",         # top speed of the selected field set (m/s)
    "protective_length",   # its protective field's reach beyond the body (m)
    "field_trigger",       # obstacle index in the most severe intruded field; -2 a wall; -1 none
    "ranger_stop_range",   # reading of the stopping ultrasonic ranger (m; NaN none)
    "avoiding",            # 1 on a detour
    "detour_target",       # obstacle index the detour passes (-1 none / unknown)
    "corridor_excess",     # how far the body reaches beyond the corridor (m; 0 inside; NaN no corridor)
)


#: Depth (m) an obstacle is assumed to have beyond the faces the scanner sees, when planning a detour.
ASSUMED_DEPTH_M = 1.5


#: An obstacle whose echoes' centroid moved less than this (m) over ``avoid_after_s`` is static.
STATIC_TOLERANCE_M = 0.15


#: Echoes closer than this (m) to a map wall are the wall (the vehicle knows its map).
WALL_TOLERANCE_M = 0.1


@dataclass(frozen=True)
class AvoidParams:
    """Where and how the vehicle may drive round a static obstacle (m, s).

    ``segments``: indices of the route's segments a detour may leave from (None: never avoid);
    ``left``/``right``: the corridor either side of the route; ``clearance`` kept from the
    obstacle; ``min_radius`` of the detour's arcs; ``after_s`` the stop that triggers a detour;
    ``ranger_stop`` the stopping ranger's range (None: the rangers do not stop the vehicle).
    """

    segments: list[int] | None
    left: float
    right: float
    clearance: float
    min_radius: float
    after_s: float
    ranger_stop: float | None


@dataclass
class ReactiveInputs:
    """What the sensors last saw, for the autopilot: scan echoes in base_link and their owner, ranger reading."""

    t: float = -math.inf
    points: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    owner: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    ranger: float = math.nan


class ReactiveWatch:
    """The positioning guard's watch with the reaction's scale composed in: ``min`` of the scales.

    Its signals are the guard's followed by :data:`REACTIVE_SIGNALS` and the clearances, which
    the :class:`ReactiveAutopilot` fills in.
    """

    def __init__(self, inner: SpeedWatch, obstacle_ids: Sequence[str]) -> None:
        self.inner = inner
        self.signal_names = (*inner.signal_names, *REACTIVE_SIGNALS, *(f"clearance__{i}" for i in obstacle_ids))
        self.reactive_scale = 1.0
        self.last_guard_scale = 1.0
        nan = math.nan
        self.reactive_sig: tuple[float, ...] = (0.0, nan, nan, -1.0, nan, 0.0, -1.0, nan,
                                                *([nan] * len(obstacle_ids)))

    def scale(self, t: float, estimator: Estimator) -> float:
        """``min(guard scale, reaction scale)``."""
        self.last_guard_scale = float(self.inner.scale(t, estimator))
        return min(self.last_guard_scale, self.reactive_scale)

    def signals(self) -> tuple[float, ...]:
        """The guard's signals then the reaction's."""
        return (*self.inner.signals(), *self.reactive_sig)


class ReactiveAutopilot(PathAutopilot):
    """The route's :class:`PathAutopilot` with the reaction and avoidance (see the module docstring).

    ``base`` is the route's autopilot (its follower, path, profile and vehicle are taken over),
    ``watch`` wraps its positioning guard; ``obstacles`` (the true ones) and ``walls`` (the map's, m)
    serve the recorded clearances and the echoes' wall test; ``emergency_decel`` (m/s^2) brakes an
    emergency stop; ``avoid`` None never plans a detour.
    """

    def __init__(
        self,
        base: PathAutopilot,
        watch: ReactiveWatch,
        fields: FieldConfig | None,
        reaction: Reaction,
        inputs: ReactiveInputs,
        obstacles: ObstacleSet,
        walls: NDArray[np.float64],
        emergency_decel: float,
        avoid: AvoidParams | None,
    ) -> None:
        plant = base.plant
        super().__init__(base.follower, base.path, base.profile, plant, base.offset, base.progress_window,
                         base.end_tolerance, watch)
        self.rwatch = watch
        self.fields = fields
        self.reaction = reaction
        self.inputs = inputs
        self.obstacles = obstacles
        self.walls = np.asarray(walls, dtype=np.float64).reshape(-1, 2, 2)
        self.emergency_decel = float(emergency_decel)
        self.normal_decel = float(base.profile.max_decel)
        self.avoid = avoid
        self.detour: Detour | None = None
        self.detour_pilot: PathAutopilot | None = None
        self.detours = 0
        self.plant_ref = plant
        self._stopped_since: float | None = None
        self._seen: NDArray[np.float64] | None = None
        self._last_try = -math.inf
        self._footprint = np.asarray(plant.footprint, dtype=np.float64)
        self._trigger = -1
        self._field: FieldSet | None = None

    # ------------------------------------------------------------------ reaction
    def _demand(self, speed: float, direction: int, creep: bool = False) -> tuple[int, float, float]:
        """Demanded level from the latest scan and ranger reading; the selected set's v_max and length.

        ``creep``: on a detour at the slow fraction (the field configuration's creep set, if it has one)."""
        demand, v_max, p_len = 0, math.nan, math.nan
        self._trigger = -1
        self._field = None
        if self.fields is not None and self.inputs.points.shape[0]:
            fs = self.fields.select(speed, direction, creep)
            self._field = fs
            v_max, p_len = fs.v_max, fs.protective_length
            prot = self._inside(self.inputs.points, fs.protective)
            warn = self._inside(self.inputs.points, fs.warning)
            demand = field_demand(bool(prot.any()), bool(warn.any()))
            if demand:
                sel = prot if demand == 2 else warn
                owners = self.inputs.owner[sel]
                obs = owners[owners >= 0]
                self._trigger = int(obs[0]) if obs.size else -2
        elif self.fields is not None:
            fs = self.fields.select(speed, direction, creep)
            v_max, p_len = fs.v_max, fs.protective_length
        stop_at = None if self.avoid is None else self.avoid.ranger_stop
        if stop_at is not None and math.isfinite(self.inputs.ranger) and self.inputs.ranger < stop_at:
            demand = 2
            self._trigger = self._trigger if self._trigger != -1 else -3
        return demand, v_max, p_len

    def _inside(self, points: NDArray[np.float64], polygon: NDArray[np.float64]) -> NDArray[np.bool_]:
        """:func:`agvnav.reactive.intrusions` (one compiled call)."""
        return intrusions(points, polygon)

    def command(self, t: float, estimator: Estimator, plant: Plant, dt: float) -> tuple[float, ...]:
        """Reaction, then avoidance, then the route's (or the detour's) autopilot; records the signals."""
        pilot: PathAutopilot = self.detour_pilot if self.detour_pilot is not None else self
        s_est = self._route_s()
        pose = estimator.pose
        direction = int(self.path.direction_at(min(max(s_est, 0.0), self.path.length)))
        cap = self._detour_cap()
        remaining = max(float(pilot.signals()[6]), 0.0)
        intended = abs(self.profile.cruise_speed) * min(self.rwatch.last_guard_scale, cap)
        intended = min(intended, math.sqrt(2.0 * self.normal_decel * remaining))
        speed = max(abs(self.profile.v), intended)
        demand, v_max, p_len = self._demand(speed, direction, creep=cap < 1.0)
        scale = self.reaction.update(t, demand)
        self.rwatch.reactive_scale = min(scale, cap)
        self.profile.max_decel = self.emergency_decel if self.reaction.level == 2 else self.normal_decel
        self._maybe_avoid(t, pose, s_est)
        pilot = self.detour_pilot if self.detour_pilot is not None else self
        out = PathAutopilot.command(self, t, estimator, plant, dt) if pilot is self else pilot.command(
            t, estimator, plant, dt)
        if pilot is not self:
            self.finished = pilot.finished
            self.failure = pilot.failure
        self._record(t, plant, v_max, p_len)
        return out

    def _detour_cap(self) -> float:
        """Speed fraction on a detour (the slow fraction until it rejoins the route), else 1."""
        if self.detour_pilot is None or self.detour is None:
            return 1.0
        if float(self.detour_pilot.signals()[3]) >= self.detour.length:
            return 1.0
        return float(self.reaction.limits.slow_speed_fraction)

    def _route_s(self) -> float:
        if self.detour_pilot is None:
            return float(self._sig[3])
        assert self.detour is not None
        return float(self.detour.route_s(float(self.detour_pilot.signals()[3])))

    def _maybe_avoid(self, t: float, pose: NDArray[np.float64], s_est: float) -> None:
        """Plan a detour around a *static* obstacle in a field (see the module docstring).

        Static: the centroid of the echoes off the map's walls (map frame, via the estimated pose)
        moved less than :data:`STATIC_TOLERANCE_M` over ``avoid_after_s`` while a field stayed intruded.
        """
        if self.avoid is None or self.avoid.segments is None or self.detour_pilot is not None:
            return
        if self.reaction.level == 0 or self._trigger == -2 or not all(math.isfinite(float(v)) for v in pose[:3]):
            self._stopped_since, self._seen = None, None
            return
        pts = self._obstacle_points(pose)
        if pts.shape[0] == 0:
            return
        centroid = pts.mean(axis=0)
        if self._stopped_since is None or self._seen is None:
            self._stopped_since, self._seen = t, centroid
            return
        wait = float(self.avoid.after_s)
        if t - self._stopped_since < wait - 1e-9 or t - self._last_try < wait - 1e-9:
            return
        moved = float(np.hypot(*(centroid - self._seen)))
        self._stopped_since, self._seen = t, centroid  # the next check compares with now
        if moved > STATIC_TOLERANCE_M:
            return
        self._last_try = t
        shape = scanned_obstacle(pts, float(pose[2]), ASSUMED_DEPTH_M)
        if shape is None:
            return
        a = self.avoid
        detour = plan_detour(
            self.path, s_est, [shape], self._footprint, a.left, a.right, a.clearance, a.min_radius,
            self.offset, allowed=a.segments,
        )
        if detour is None:
            return
        self.detour = detour
        self.detours += 1
        self.follower.set_path(detour.path)
        self.follower.reset()
        self.detour_pilot = PathAutopilot(self.follower, detour.path, self.profile, self.plant_ref, self.offset,
                                          self.progress_window, self.end_tolerance, self.rwatch)
        self._detour_target = self._nearest_obstacle(shape)

    def _obstacle_points(self, pose: NDArray[np.float64]) -> NDArray[np.float64]:
        """Latest echoes (map frame, via the estimated pose) away from the map's walls, ahead of base_link and
        inside the selected warning field (the field that was intruded)."""
        pts = self.inputs.points
        if pts.shape[0] == 0:
            return pts
        ahead = pts[:, 0] > 0.0
        if self._field is not None:
            ahead &= self._inside(pts, self._field.warning)
        pts = pts[ahead]
        c, s = math.cos(float(pose[2])), math.sin(float(pose[2]))
        world = np.column_stack([pose[0] + c * pts[:, 0] - s * pts[:, 1], pose[1] + s * pts[:, 0] + c * pts[:, 1]])
        if self.walls.shape[0] and world.shape[0]:
            near_wall = np.array([segment_distances(p, self.walls).min() < WALL_TOLERANCE_M for p in world])
            world = world[~near_wall]
        return world

    def _nearest_obstacle(self, shape: BaseGeometry) -> int:
        """Index of the true obstacle nearest the planned shape (for the metrics only), -1 none."""
        if not len(self.obstacles):
            return -1
        d = self.obstacles.distances(shape, self.rwatch_time)
        return int(np.argmin(d)) if d.min() < 0.5 else -1

    @property
    def rwatch_time(self) -> float:
        """Time of the latest scan (s)."""
        return self.inputs.t

    def _record(self, t: float, plant: Plant, v_max: float, p_len: float) -> None:
        pose = np.asarray(plant.pose, dtype=np.float64)
        clear = self.obstacles.clearances(pose, self._footprint, t) if len(self.obstacles) else np.zeros(0)
        excess = self._corridor_excess(pose)
        target = float(getattr(self, "_detour_target", -1)) if self.detour_pilot is not None else -1.0
        self.rwatch.reactive_sig = (
            float(self.reaction.level), v_max, p_len, float(self._trigger), self.inputs.ranger,
            1.0 if self.detour_pilot is not None else 0.0, target, excess, *clear.tolist(),
        )
        if self.detour_pilot is not None:  # the series' s_est stays a route abscissa
            sig = list(self.detour_pilot.signals()[:7])
            sig[3] = self._route_s()
            self._sig = tuple(sig)

    def _corridor_excess(self, pose: NDArray[np.float64]) -> float:
        """How far (m) the body's corners reach beyond the corridor about the route (NaN without one)."""
        if self.avoid is None or (self.avoid.left <= 0.0 and self.avoid.right <= 0.0):
            return math.nan
        c, s = math.cos(pose[2]), math.sin(pose[2])
        fp = self._footprint
        corners = np.column_stack([pose[0] + c * fp[:, 0] - s * fp[:, 1], pose[1] + s * fp[:, 0] + c * fp[:, 1]])
        pr = self.path.project(corners, s_hint=np.full(len(corners), self._route_s()), window=3.0)
        lat = np.asarray(pr.lateral, dtype=np.float64)
        return float(max(0.0, float(lat.max()) - self.avoid.left, -float(lat.min()) - self.avoid.right))

    def signals(self) -> tuple[float, ...]:
        """The route autopilot's signals (``s_est`` a route abscissa on a detour), the guard's, the reaction's."""
        return (*self._sig, *self.rwatch.signals())
