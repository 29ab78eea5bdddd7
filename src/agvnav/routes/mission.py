"""Missions: jobs become planned legs, one path of the tracked point, and a speed limit along it.

Jobs (seed 003 §3.4, §3.5): ``goto`` a station, ``reverse_into`` a station (the
last edge backed up), ``pick``/``drop`` (go to a station, then stop
``duration_s``), ``wait`` (stop ``duration_s`` where the vehicle stands). Each
job that names a station is one **leg**, planned from where the previous leg
ended, with the heading it ended with (:class:`agvnav.routes.planning.Planner`).

All legs are chained into one :class:`agvnav.guidance.Path`: each edge's
segments start where the previous ones ended (no gap), with the previous end
heading when the two differ by less than the network's heading tolerance
(exactly G1; a larger difference is a turn on the spot, which only the
planner's spot-turning vehicles are given).

The speed limit along a leg (:func:`speed_limits`) caps the cruise speed by
the edge's limit and by the curvature, ``v <= sqrt(a_lat / |kappa|)``, lowers
it backwards at the deceleration limit (``v(s)^2 <= v(s')^2 + 2 a_dec (s' - s)``)
and to a creep speed over the last ``creep_distance`` metres before the
station, so the final stop starts slowly and ends precisely.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry.angles import wrap_angle
from agvnav.guidance.paths import Path, Segment
from agvnav.routes.network import EDGE_KINDS
from agvnav.routes.planning import NoRouteError, Planner, Route

__all__ = [
    "JOB_ACTIONS",
    "Job",
    "Leg",
    "MissionError",
    "MissionPlan",
    "chain_mission",
    "plan_legs",
    "speed_limits",
]

#: Job actions; all but ``wait`` name a station.
JOB_ACTIONS = ("goto", "reverse_into", "pick", "drop", "wait")


class MissionError(ValueError):
    """A job that cannot be planned; ``job`` is its index in the mission."""

    def __init__(self, job: int, message: str) -> None:
        self.job = job
        super().__init__(message)


@dataclass(frozen=True)
class Job:
    """One job: ``action`` (:data:`JOB_ACTIONS`), ``station`` id (None for wait), stop ``duration_s`` (s)."""

    action: str
    station: str | None = None
    duration_s: float = 0.0

    def __post_init__(self) -> None:
        if self.action not in JOB_ACTIONS:
            raise ValueError(f"unknown job action {self.action!r}; valid: {', '.join(JOB_ACTIONS)}")
        if (self.station is None) != (self.action == "wait"):
            raise ValueError("wait takes no station; every other job names one")
        if not (math.isfinite(self.duration_s) and self.duration_s >= 0.0):
            raise ValueError(f"duration_s must be >= 0, got {self.duration_s!r}")


@dataclass(frozen=True)
class Leg:
    """One job after planning: its route (None when the vehicle does not move) and stop time (s)."""

    job: int
    action: str
    station: str | None
    route: Route | None
    dwell_s: float


def plan_legs(planner: Planner, start: str, jobs: list[Job], start_heading: float | None = None) -> list[Leg]:
    """Plan every job in turn from station ``start``; :class:`MissionError` names the job and station."""
    if start not in planner.network.nodes:
        raise MissionError(-1, f"unknown start station {start!r}")
    node, heading = start, start_heading
    legs: list[Leg] = []
    for i, job in enumerate(jobs):
        if job.station is None:
            legs.append(Leg(i, job.action, None, None, job.duration_s))
            continue
        if job.station not in planner.network.nodes:
            raise MissionError(i, f"unknown station {job.station!r}")
        mode = -1 if job.action == "reverse_into" else None
        try:
            route = planner.plan(node, job.station, heading, mode)
        except NoRouteError as exc:
            raise MissionError(i, str(exc)) from None
        legs.append(Leg(i, job.action, job.station, route, job.duration_s))
        if route.traversals:
            node, heading = job.station, route.traversals[-1].end_heading
    return legs


@dataclass(frozen=True)
class MissionPlan:
    """The chained mission: one path, and per segment its leg, edge, kind and speed limit.

    ``leg_bounds`` (n_legs, 2): path arclength (m) where each leg starts and ends;
    ``node_s``: arclength of every node passed, with its id; ``approx_error_m``: the
    largest deviation of the followed segments from the exact edges.
    """

    legs: tuple[Leg, ...]
    path: Path
    seg_leg: NDArray[np.int64]
    seg_kind: NDArray[np.int64]
    seg_speed: NDArray[np.float64]
    seg_edge: tuple[str, ...]
    leg_bounds: NDArray[np.float64]
    node_s: tuple[tuple[float, str], ...]
    approx_error_m: float


def chain_mission(legs: list[Leg], start_xy: NDArray[np.float64], heading_tol: float) -> MissionPlan:
    """Chain the legs' edges into one path (module doc); heading_tol (rad) snaps near-G1 joints."""
    pos = np.asarray(start_xy, dtype=np.float64).copy()
    body: float | None = None  # vehicle heading at the end of the chain so far
    segs: list[Segment] = []
    info: list[tuple[int, int, float, str]] = []
    bounds: list[tuple[float, float]] = []
    nodes: list[tuple[float, str]] = []
    s, err = 0.0, 0.0
    for k, leg in enumerate(legs):
        s_start = s
        for t in leg.route.traversals if leg.route is not None else ():
            flip = math.pi if t.mode < 0 else 0.0
            tangent = t.edge.curve.start_heading
            if body is not None and abs(float(wrap_angle(body - t.start_heading))) <= heading_tol:
                tangent = float(wrap_angle(body - flip))  # snap: exactly G1 in the body heading
            chain = t.edge.curve.chain(pos, t.mode, tangent)
            err = max(err, chain.max_error_m)
            for seg in chain.segments:
                segs.append(seg)
                info.append((k, EDGE_KINDS.index(t.edge.curve.kind), t.edge.speed, t.edge.id))
                s += seg.length
            pos, body = np.asarray(segs[-1].end), float(wrap_angle(segs[-1].end_heading + flip))
            nodes.append((s, t.edge.target))
        bounds.append((s_start, s))
    if not segs:
        raise MissionError(0, "the mission never moves the vehicle")
    path = Path(segs)
    return MissionPlan(
        tuple(legs), path, np.array([i[0] for i in info]), np.array([i[1] for i in info]),
        np.array([i[2] for i in info]), tuple(i[3] for i in info), np.array(bounds), tuple(nodes), err,
    )


def speed_limits(
    path: Path,
    seg_speed: NDArray[np.float64],
    v_max: float,
    lateral_accel: float,
    max_decel: float,
    creep_distance: float,
    creep_speed: float,
    step: float = 0.05,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Speed limit (m/s) on a grid of arclength ``s`` (m) along one leg's ``path`` (module doc).

    ``seg_speed`` (n_segments,) the edge speed limit of each segment; ``v_max`` the vehicle's
    cruise speed; ``lateral_accel``, ``max_decel`` in m/s^2; the last ``creep_distance`` m at
    ``creep_speed``. Returns ``(s, v)``.
    """
    n = max(2, math.ceil(path.length / step) + 1)
    s = np.linspace(0.0, path.length, n)
    ds = s[1] - s[0]
    starts = path.segment_starts
    kappa = np.abs([seg.curvature for seg in path.segments])
    with np.errstate(divide="ignore"):
        cap = np.minimum(np.minimum(seg_speed, v_max), np.sqrt(lateral_accel / np.maximum(kappa, 1e-12)))
    v = np.full(n, np.inf)
    for shift in (-ds, 0.0, ds):  # every segment within a grid step of the point caps it
        idx = np.clip(np.searchsorted(starts, s + shift, side="right") - 1, 0, len(cap) - 1)
        v = np.minimum(v, cap[idx])
    v = np.where(s >= path.length - creep_distance - ds, np.minimum(v, creep_speed), v)
    for i in range(n - 2, -1, -1):  # backwards: slow down in time for every lower limit ahead
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2.0 * max_decel * ds))
    return s, v
