"""New reflectors from unassociated reflections: triangulate rays seen from several poses.

Each unassociated reflection is a ray from the head along its absolute bearing. The
leading edge is tangent to the cylinder, whose centre lies ``r`` to the side the head
turns towards ([seed000 §2.1]: ``centre = edge + dir·asin(r/d)``), so the ray shifted
sideways by ``r`` passes exactly through the centre: triangulating the shifted rays needs
no range. Candidates are the pairwise intersections of rays from head positions at
least ``min_pair_baseline`` apart and crossing at ``min_angle`` or more, voted on a grid;
the best-voted cell's median is refined by least squares over the rays passing within
``tolerance`` of it. A cell needs ``min_votes`` pair intersections: the rays of one reflector
cross in one cell pairwise (``n(n−1)/2`` votes), rays of different reflectors crossing there by
chance (a "ghost") give only a few. A reflector is created only with at least ``min_sightings``
supporting rays whose head positions span ``min_baseline`` metres and whose directions
span ``min_angle_spread`` (rays along nearly one line cross anywhere on it): a spurious
reflection (a shiny surface, clutter) does not repeat along a consistent line, so it
never gathers that support and never becomes a reflector.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import wrap_angle, wrap_angle_scalar

__all__ = [
    "InitialiseOptions",
    "NewReflector",
    "initialise_from_tracks",
    "initialise_reflectors",
    "ray_distances",
    "ray_misfit",
    "track_reflections",
    "triangulate_rays",
]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


@dataclass(frozen=True)
class InitialiseOptions:
    """Thresholds of :func:`initialise_reflectors` (m, rad, counts)."""

    min_sightings: int = 8
    min_baseline: float = 0.5
    min_pair_baseline: float = 0.15
    min_angle: float = math.radians(1.0)
    min_angle_spread: float = math.radians(3.0)
    tolerance: float = 0.03
    cell: float = 0.1
    min_range: float = 0.3
    max_range: float = 30.0
    max_candidates: int = 20
    min_votes: int = 12
    max_gap_s: float = 0.5

    def __post_init__(self) -> None:
        if self.min_sightings < 2:
            raise ValueError(f"min_sightings must be at least 2, got {self.min_sightings}")
        for name in ("min_baseline", "tolerance", "cell", "max_range"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)!r}")


@dataclass(frozen=True)
class NewReflector:
    """A triangulated reflector: centre ``xy (2,)`` (m) and the pool rows of its supporting rays."""

    xy: F64
    support: I64


def _centre_rays(heads: F64, bearings: F64, radius: float, direction: int) -> tuple[F64, F64]:
    """Origins ``(P, 2)`` of the rays shifted by ``r`` towards the centre, and unit directions ``(P, 2)``."""
    phi = heads[:, 2] + bearings
    e = np.column_stack([np.cos(phi), np.sin(phi)])
    normal = direction * np.column_stack([-e[:, 1], e[:, 0]])  # left of the ray for a CCW head
    return heads[:, :2] + radius * normal, e


def ray_distances(point: F64, origins: F64, dirs: F64) -> tuple[F64, F64]:
    """Perpendicular distance ``(P,)`` (m) of ``point`` from each ray, and its distance along the ray ``(P,)``."""
    v = point[None, :] - origins
    along = v[:, 0] * dirs[:, 0] + v[:, 1] * dirs[:, 1]
    perp = np.abs(v[:, 0] * dirs[:, 1] - v[:, 1] * dirs[:, 0])
    return perp, along


def ray_misfit(heads: F64, bearings: F64, radius: float, points: F64, direction: int = 1) -> F64:
    """``(M,)`` the median perpendicular distance (m) of the reflections' centre rays from each of ``points (M, 2)``.

    ``heads (P, 3)`` head poses, ``bearings (P,)`` leading-edge bearings (rad), ``radius`` (m); a point behind a
    ray's origin counts as infinitely far from it. The track of a reflector lies along the rays; a second
    reflector on nearly the same line of sight fits them too (a short track's triangulated centre slides along
    the line towards it, :func:`agvnav.mapping.slam.front_end`).
    """
    origins, dirs = _centre_rays(heads, bearings, radius, direction)
    out = np.full(points.shape[0], np.inf)
    for m, p in enumerate(np.asarray(points, dtype=np.float64)):
        perp, along = ray_distances(p, origins, dirs)
        out[m] = float(np.median(np.where(along > 0.0, perp, np.inf)))
    return out


def triangulate_rays(origins: F64, dirs: F64) -> F64:
    """Least-squares intersection ``(2,)`` of rays: minimises the sum of squared perpendicular distances."""
    n = np.column_stack([-dirs[:, 1], dirs[:, 0]])
    A = n.T @ n
    b = n.T @ np.einsum("pi,pi->p", n, origins)
    return np.asarray(np.linalg.solve(A, b))


def _spread(points: F64) -> float:
    """Largest distance between two of ``points`` (m)."""
    if points.shape[0] < 2:
        return 0.0
    d = points[:, None, :] - points[None, :, :]
    return float(np.sqrt(np.max(np.einsum("abi,abi->ab", d, d))))


def _longest_run_spread(heads: F64, times: F64, max_gap: float) -> float:
    """Largest head-position spread (m) of a run of sightings without a gap longer than ``max_gap`` (s)."""
    order = np.argsort(times, kind="stable")
    t, h = times[order], heads[order, :2]
    cuts = np.flatnonzero(np.diff(t) > max_gap) + 1
    return max(_spread(part) for part in np.split(h, cuts))


def initialise_reflectors(heads: F64, bearings: F64, radius: float, options: InitialiseOptions | None = None,
                          direction: int = 1, times: F64 | None = None) -> list[NewReflector]:
    """Reflectors triangulated from unassociated reflections (module docstring).

    Parameters
    ----------
    heads : (P, 3) head poses in map (m, m, rad) of the pool's reflections.
    bearings : (P,) their bearings (rad, head frame).
    radius : reflector radius (m).
    times : (P,) measurement instants (s). With them the ``min_baseline`` must be covered by one
        continuous track (no gap over ``max_gap_s``): rays of several reflectors that happen to cross
        near one point (a ghost) do so in short bursts, one reflector's track stays on its centre.

    Returns the new reflectors, each with the pool rows that support it (disjoint).
    """
    opt = options or InitialiseOptions()
    P = bearings.shape[0]
    if opt.min_sightings > P:
        return []
    origins, dirs = _centre_rays(heads, bearings, radius, direction)
    iu, ju = np.triu_indices(P, k=1)
    base = heads[ju, :2] - heads[iu, :2]
    far = np.hypot(base[:, 0], base[:, 1]) >= opt.min_pair_baseline
    iu, ju = iu[far], ju[far]
    cross = dirs[iu, 0] * dirs[ju, 1] - dirs[iu, 1] * dirs[ju, 0]
    ok = np.abs(cross) >= math.sin(opt.min_angle)
    iu, ju, cross = iu[ok], ju[ok], cross[ok]
    w = origins[ju] - origins[iu]
    a = (w[:, 0] * dirs[ju, 1] - w[:, 1] * dirs[ju, 0]) / cross
    bb = (w[:, 0] * dirs[iu, 1] - w[:, 1] * dirs[iu, 0]) / cross
    ok = (a > opt.min_range) & (a < opt.max_range) & (bb > opt.min_range) & (bb < opt.max_range)
    pts = origins[iu[ok]] + a[ok, None] * dirs[iu[ok]]
    used = np.zeros(P, dtype=bool)
    out: list[NewReflector] = []
    if pts.shape[0] == 0:
        return out
    cells = np.floor(pts / opt.cell).astype(np.int64)
    _, inverse, counts = np.unique(cells[:, 0] * 1_000_003 + cells[:, 1], return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    order = np.argsort(-counts, kind="stable")
    tried = 0
    for c in order:
        if counts[c] < opt.min_votes or tried >= opt.max_candidates:
            break
        tried += 1
        centre = np.median(pts[inverse == c], axis=0)
        free = np.flatnonzero(~used)
        for _ in range(3):  # refine: support -> least squares -> support
            perp, along = ray_distances(centre, origins[free], dirs[free])
            sup = free[(perp <= opt.tolerance) & (along > opt.min_range) & (along < opt.max_range)]
            if sup.size < 2:
                break
            centre = triangulate_rays(origins[sup], dirs[sup])
        perp, along = ray_distances(centre, origins[free], dirs[free])
        sup = free[(perp <= opt.tolerance) & (along > opt.min_range) & (along < opt.max_range)]
        if sup.size < opt.min_sightings or _spread(heads[sup, :2]) < opt.min_baseline:
            continue
        if times is not None and _longest_run_spread(heads[sup], times[sup], opt.max_gap_s) < opt.min_baseline:
            continue
        phi = np.arctan2(dirs[sup, 1], dirs[sup, 0])
        ref = phi[0]
        rel = wrap_angle(phi - ref)
        if float(rel.max() - rel.min()) < opt.min_angle_spread:  # rays along one line: a ghost, no fix
            continue
        if any(float(np.hypot(*(centre - r.xy))) < 2.0 * opt.tolerance for r in out):
            continue
        used[sup] = True
        out.append(NewReflector(centre, sup.astype(np.int64)))
    return out


def track_reflections(directions: F64, times: F64, gate: float = 0.02, max_gap: float = 0.5) -> I64:
    """Tracks of reflections ``(P,)`` (track id per reflection): one reflector seen revolution after revolution.

    ``directions`` (rad) are absolute ray directions (dead-reckoned head heading plus bearing) at
    ``times`` (s, non-decreasing). A reflection joins the track whose direction, extrapolated
    linearly from its last two members, is nearest within ``gate`` (rad) and which was last seen
    at most ``max_gap`` s before; else it starts a track. A track is one reflector by
    construction, which rays crossing by chance (ghosts) are not.
    """
    P = directions.shape[0]
    track = np.full(P, -1, dtype=np.int64)
    last_t: list[float] = []
    last_d: list[float] = []
    rate: list[float] = []
    active: list[int] = []
    for k in range(P):
        t, d = float(times[k]), float(directions[k])
        active = [j for j in active if t - last_t[j] <= max_gap]
        best, best_err = -1, gate
        for j in active:
            if last_t[j] == t:
                continue
            pred = last_d[j] + rate[j] * (t - last_t[j])
            err = abs(wrap_angle_scalar(d - pred))
            if err < best_err:
                best, best_err = j, err
        if best < 0:
            best = len(last_t)
            last_t.append(t)
            last_d.append(d)
            rate.append(0.0)
            active.append(best)
        else:
            dt = t - last_t[best]
            if dt > 0.0:  # smoothed: one revolution's heading noise must not swing the extrapolation
                rate[best] = 0.5 * rate[best] + 0.5 * wrap_angle_scalar(d - last_d[best]) / dt
            last_t[best], last_d[best] = t, d
        track[k] = best
    return track


def initialise_from_tracks(heads: F64, bearings: F64, times: F64, radius: float,
                           options: InitialiseOptions | None = None, direction: int = 1,
                           gate: float = 0.03, tolerance: float = 0.1) -> list[NewReflector]:
    """Reflectors triangulated from tracks (:func:`track_reflections`) of at least ``min_sightings``
    reflections spanning ``min_baseline`` m of head travel and ``min_angle_spread`` of direction; the
    rays of each are intersected by least squares and the support is the track's rays within
    ``tolerance`` (m; dead-reckoned headings drift along a track) of the point (spurious reflections
    form no such track)."""
    opt = options or InitialiseOptions()
    out: list[NewReflector] = []
    if bearings.shape[0] < opt.min_sightings:
        return out
    origins, dirs = _centre_rays(heads, bearings, radius, direction)
    phi = heads[:, 2] + bearings
    tracks = track_reflections(phi, times, gate, opt.max_gap_s)
    ids, counts = np.unique(tracks, return_counts=True)
    for tid in ids[np.argsort(-counts, kind="stable")]:
        sup = np.flatnonzero(tracks == tid)
        if sup.size < opt.min_sightings or _spread(heads[sup, :2]) < opt.min_baseline:
            continue
        rel = wrap_angle(phi[sup] - phi[sup[0]])
        if float(rel.max() - rel.min()) < opt.min_angle_spread:
            continue
        centre = triangulate_rays(origins[sup], dirs[sup])
        perp, along = ray_distances(centre, origins[sup], dirs[sup])
        sup = sup[(perp <= tolerance) & (along > opt.min_range) & (along < opt.max_range)]
        if sup.size < opt.min_sightings:
            continue
        centre = triangulate_rays(origins[sup], dirs[sup])
        out.append(NewReflector(centre, sup.astype(np.int64)))
    return out
