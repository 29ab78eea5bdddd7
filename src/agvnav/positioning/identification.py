"""Start-up and relocalisation: the pose of a standing vehicle from one revolution of anonymous bearings.

The goniometer reports only ``(t, bearing)`` (seed 000 §2.1): which map reflector
produced a reflection must be decided by the positioning side. While tracking, a chi-square
gate does it (:mod:`agvnav.positioning.bearing_gate`). At start-up without any prior
(standstill, as commercial sensors do), reflector triples are tried against observed
bearing triples, each hypothesis is resected (:func:`agvnav.positioning.resection.resect_three`)
and scored by how many reflections it explains, and an ambiguity (several distinct poses
explaining equally many, e.g. a rotationally symmetric layout) is reported rather than
guessed (:func:`initial_pose_search`). Small maps try every ordered reflector triple; a
large map (above :data:`FULL_SEARCH_MAX_CELLS`) is searched locally, in memory linear in
its size: consecutive bearings on neighbouring reflectors (:mod:`agvnav.positioning.spatial`),
chunked and with early rejection. That assumes reflections next to each other come from
reflectors next to each other (walls, racks); on a map of scattered, isolated reflectors it
may find nothing. Not having tried every triple, it reports a pose ``found`` only when the
pose explains at least :data:`LOCAL_MIN_FRACTION` of the bearings. The bearings are the
leading tangent edges of :func:`agvnav.positioning.edge_bearing.bearing_model`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import angle_diff, compose, inverse, wrap_angle
from agvnav.positioning.bearing_gate import CHI2_1DOF_999, associate_sweep
from agvnav.positioning.edge_bearing import bearing_model, edge_offset, measurement_variance
from agvnav.positioning.resection import resect_three
from agvnav.positioning.spatial import count_explained, nearest_neighbours

__all__ = ["InitialPoseResult", "initial_pose_search"]

#: The start-up search tries every (bearing triple, ordered reflector triple) pair while
#: its score table (hypotheses x bearings x reflectors) stays at or below this many cells
#: (about 160 MB of float64; the shipped maps of up to 14 reflectors); beyond it, the
#: local search of :func:`_local_hypotheses` (memory linear in the map size).
FULL_SEARCH_MAX_CELLS = 20_000_000
#: Nearest map neighbours of a reflector tried around it by the local search.
LOCAL_NEIGHBOURS = 2
#: Triples of consecutive bearings the local search resects, spread around the revolution.
LOCAL_CENTRES = 3
#: The local search reports a pose found only when it explains at least this fraction of the bearings.
LOCAL_MIN_FRACTION = 0.5
#: Distinct best-scoring hypotheses the local search refines by Gauss-Newton.
LOCAL_SEEDS = 16
#: Hypotheses per bearing triple kept for scoring on every bearing (most early hits first).
LOCAL_MAX_SCORED = 2048
#: Hypotheses scored at once against every reflector by the local search.
LOCAL_CHUNK = 2048


@dataclass(frozen=True)
class InitialPoseResult:
    """Outcome of :func:`initial_pose_search`.

    Attributes
    ----------
    pose:
        ``(3,)`` base_link pose in ``map`` (NaN when ``found`` is False).
    covariance:
        ``(3, 3)`` Gauss-Newton covariance of the refined pose (NaN when not found).
    labels:
        ``(k,)`` reflector row per observed bearing, -1 for unexplained (spurious) ones.
    n_explained:
        Reflections explained by the best pose.
    found:
        True when one pose explains at least ``min_explained`` reflections and no other does
        equally well (on a large map searched locally, also at least half of them).
    ambiguous:
        True when two or more distinct poses explain the same, maximal number of
        reflections (e.g. a rotationally symmetric layout); ``alternatives`` lists them.
    alternatives:
        ``(m, 3)`` every distinct pose with the maximal score (the best first).
    """

    pose: NDArray[np.float64]
    covariance: NDArray[np.float64]
    labels: NDArray[np.int64]
    n_explained: int
    found: bool
    ambiguous: bool
    alternatives: NDArray[np.float64]


def initial_pose_search(
    bearings: ArrayLike,
    reflector_xy: ArrayLike,
    radius: ArrayLike,
    mount: ArrayLike,
    bearing_std: float,
    *,
    max_range: float = np.inf,
    min_explained: int = 4,
    max_observation_triples: int = 24,
    position_tol: float = 0.05,
    heading_tol: float = 0.01,
    gate: float = CHI2_1DOF_999,
    map_std: float = 0.0,
) -> InitialPoseResult:
    """Pose of a standing vehicle from one revolution of anonymous bearings, without prior.

    1. Pick bearing triples spread around the revolution (all triples when few).
    2. For each, try every ordered triple of map reflectors, resect the head pose
       (:func:`~agvnav.positioning.resection.resect_three`, then once more with the edge correction of seed 000 §2.1 at
       the resected distances), drop hypotheses out of range.
    3. Score each hypothesis by the number of bearings it explains within a coarse
       tolerance; refine the best distinct hypotheses by Gauss-Newton on all the bearings
       they explain (labels by :func:`~agvnav.positioning.bearing_gate.associate_sweep`, chi-square gate).
    4. Keep the pose explaining the most; if another distinct pose (farther than
       ``position_tol`` m or ``heading_tol`` rad) explains as many, report ``ambiguous``.

    ``bearings (k,)`` head-frame edge bearings (rad); the map arrays as in
    :func:`~agvnav.positioning.edge_bearing.bearing_model`; ``map_std`` as in
    :func:`~agvnav.positioning.bearing_gate.gate_reflection`. Needs at least three
    reflections and three reflectors.
    """
    raw = wrap_angle(np.atleast_1d(np.asarray(bearings, dtype=np.float64)))
    order = np.argsort(raw, kind="stable")
    z = raw[order]  # sorted around the sweep, so bearing triples can be spread
    xy = np.asarray(reflector_xy, dtype=np.float64)
    rad = np.broadcast_to(np.asarray(radius, dtype=np.float64), xy.shape[:1])
    if z.size < 3 or xy.shape[0] < 3:
        return _not_found(z.size)
    coarse_tol = max(30.0 * bearing_std, 2e-3)
    n = xy.shape[0]
    n_full = len(_observation_triples(z.size, max_observation_triples)) * n * (n - 1) * (n - 2)
    local = n_full * max(n, z.size) > FULL_SEARCH_MAX_CELLS
    if not local:
        hyps = _hypotheses(z, xy, rad, mount, max_observation_triples, max_range)
        if hyps.shape[0] == 0:
            return _not_found(z.size)
        explained = count_explained(z, _predicted(hyps, np.arange(n), xy, rad, mount, max_range), coarse_tol)
    else:
        hyps, explained = _local_hypotheses(z, xy, rad, mount, max_range, coarse_tol)
        if hyps.shape[0] == 0:
            return _not_found(z.size)
    refined = _refine_distinct(
        hyps, explained, z, xy, rad, mount, bearing_std, max_range, gate, position_tol, heading_tol, map_std,
        local=local,
    )
    if not refined:
        return _not_found(z.size)
    best_n = max(r[1] for r in refined)
    top = [r for r in refined if r[1] == best_n]
    top.sort(key=lambda r: r[2])
    top = _distinct(top, position_tol, heading_tol)
    pose, n, _, labels_sorted, cov = top[0]
    labels = np.empty_like(labels_sorted)
    labels[order] = labels_sorted
    alternatives = np.array([r[0] for r in top])
    ambiguous = len(top) > 1
    found = (not ambiguous) and n >= min_explained
    if local:  # not every triple was tried: a pose explaining few of the bearings is no proof
        found = found and n >= LOCAL_MIN_FRACTION * z.size
    return InitialPoseResult(pose, cov, labels, int(n), found, ambiguous, alternatives)


def _predicted(
    hyps: NDArray[np.float64], rows: NDArray[np.int64], xy: NDArray[np.float64], rad: NDArray[np.float64],
    mount: ArrayLike, max_range: float,
) -> NDArray[np.float64]:
    """Bearings ``(H, m)`` that hypotheses ``(H, 3)`` predict for reflector ``rows`` (``(m,)`` or ``(H, m)``).

    NaN where the reflector is beyond ``max_range``.
    """
    h, _, d = bearing_model(hyps[:, None, :], mount, xy[rows], rad[rows])
    return np.where(d <= max_range, h, np.nan)


def _local_hypotheses(
    z: NDArray[np.float64],
    xy: NDArray[np.float64],
    rad: NDArray[np.float64],
    mount: ArrayLike,
    max_range: float,
    tol: float,
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Start-up hypotheses of a large map and their coarse scores, in memory linear in its size.

    Bearing order and a spatial index replace the exhaustive search (which forms every
    ordered reflector triple, ``N^3``): reflections consecutive around the revolution
    mostly come from reflectors next to each other in the map, so each of
    :data:`LOCAL_CENTRES` triples of consecutive bearings ``(z[c-1], z[c], z[c+1])`` is
    resected on the reflector triples ``(i, j, k)`` with ``i`` and ``k`` two of the
    :data:`LOCAL_NEIGHBOURS` nearest neighbours of ``j`` (:func:`~agvnav.positioning.spatial.nearest_neighbours`).
    Early rejection: a hypothesis is kept only when at least two of the four next bearings
    outside the triple (``z[c-3], z[c-2], z[c+2], z[c+3]``) fall within ``tol`` of a
    neighbour of ``i`` or ``k``. The survivors are scored on every bearing by bearing order
    (:func:`~agvnav.positioning.spatial.count_explained`), :data:`LOCAL_CHUNK` at a time.
    Returns ``(hyps (H, 3), explained (H,))``.
    """
    k, n = z.size, xy.shape[0]
    nb = nearest_neighbours(xy, LOCAL_NEIGHBOURS)
    K = nb.shape[1]
    # reflector triples (i, i', l): i' one of the neighbours of i, l any other reflector
    first = np.repeat(np.arange(n), K)
    second = nb.reshape(-1)
    third = np.tile(np.arange(n), first.size)
    ri = np.stack([np.repeat(first, n), np.repeat(second, n), third], axis=-1)
    ri = ri[(ri[:, 2] != ri[:, 0]) & (ri[:, 2] != ri[:, 1])]
    outer = np.concatenate([nb[ri[:, 0]], nb[ri[:, 1]], nb[ri[:, 2]]], axis=1)  # where the next bearings should fall
    far = max(k // 3, 2)
    kept = []
    for c in np.unique(np.linspace(0, k, min(LOCAL_CENTRES, k), endpoint=False).astype(np.int64)):
        zi = np.broadcast_to(z[np.array([c, c + 1, c + far]) % k], ri.shape)
        hyps, valid = _resect_hypotheses(zi, ri, xy, rad, mount, max_range)
        if hyps.shape[0] == 0:
            continue
        test = z[np.array([c - 1, c + 2, c + far - 1, c + far + 1]) % k]
        hits = count_explained(test, _predicted(hyps, outer[valid], xy, rad, mount, max_range), tol)
        keep = np.flatnonzero(hits >= 2)
        kept.append(hyps[keep[np.argsort(-hits[keep], kind="stable")[:LOCAL_MAX_SCORED]]])
    hyps = np.concatenate(kept) if kept else np.zeros((0, 3))
    explained = np.zeros(hyps.shape[0], dtype=np.int64)
    every = np.arange(n)
    for start in range(0, hyps.shape[0], LOCAL_CHUNK):
        part = hyps[start : start + LOCAL_CHUNK]
        predicted = _predicted(part, every, xy, rad, mount, max_range)
        explained[start : start + part.shape[0]] = count_explained(z, predicted, tol)
    return hyps, explained


def _not_found(k: int) -> InitialPoseResult:
    nan3 = np.full(3, np.nan)
    labels = np.full(k, -1, dtype=np.int64)
    return InitialPoseResult(nan3, np.full((3, 3), np.nan), labels, 0, False, False, np.zeros((0, 3)))


def _observation_triples(k: int, limit: int) -> list[tuple[int, int, int]]:
    """Bearing triples to try: all of them when few, else triples spread around the sweep."""
    if k * (k - 1) * (k - 2) // 6 <= limit:
        return list(itertools.combinations(range(k), 3))
    triples: list[tuple[int, int, int]] = []
    for a, b in ((k // 3, 2 * k // 3), (1, k // 2), (k // 4, k // 2)):
        for i in range(k):
            tri = tuple(sorted({i, (i + a) % k, (i + b) % k}))
            if len(tri) == 3 and tri not in triples:
                triples.append(tri)
            if len(triples) >= limit:
                return triples
    return triples


def _hypotheses(
    z: NDArray[np.float64],
    xy: NDArray[np.float64],
    rad: NDArray[np.float64],
    mount: ArrayLike,
    limit: int,
    max_range: float,
) -> NDArray[np.float64]:
    """base_link poses resected from every (bearing triple, ordered reflector triple) pair."""
    obs = np.array(_observation_triples(z.size, limit))
    refl = np.array(list(itertools.permutations(range(xy.shape[0]), 3)))
    zi = np.repeat(z[obs], refl.shape[0], axis=0)
    ri = np.tile(refl, (obs.shape[0], 1))
    return _resect_hypotheses(zi, ri, xy, rad, mount, max_range)[0]


def _resect_hypotheses(
    zi: NDArray[np.float64],
    ri: NDArray[np.int64],
    xy: NDArray[np.float64],
    rad: NDArray[np.float64],
    mount: ArrayLike,
    max_range: float,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Resect bearing triples ``zi (H, 3)`` on reflector rows ``ri (H, 3)``: ``(poses (V, 3), valid (H,))``.

    ``poses`` are the base_link poses of the ``valid`` resections only: finite, every
    reflector within ``max_range`` and outside its own radius.
    """
    R = xy[ri]
    head, valid = resect_three(R, zi)
    for _ in range(2):  # the reported bearings are edges: move them to the centres and resect again
        dist = np.linalg.norm(R - head[:, None, :2], axis=-1)
        head, valid = resect_three(R, zi - edge_offset(dist, rad[ri]))
    dist = np.linalg.norm(R - head[:, None, :2], axis=-1)
    valid &= np.all(dist <= max_range, axis=-1) & np.all(dist > rad[ri], axis=-1)
    return compose(head[valid], inverse(np.asarray(mount, dtype=np.float64))), valid


def _refine_distinct(
    hyps: NDArray[np.float64],
    explained: NDArray[np.int64],
    z: NDArray[np.float64],
    xy: NDArray[np.float64],
    rad: NDArray[np.float64],
    mount: ArrayLike,
    bearing_std: float,
    max_range: float,
    gate: float,
    position_tol: float,
    heading_tol: float,
    map_std: float,
    local: bool = False,
) -> list[tuple]:
    """Gauss-Newton refinement of the best-scoring distinct hypotheses.

    The exhaustive search refines those within one bearing of the best score. The local
    search of a large, dense map (``local``) refines the :data:`LOCAL_SEEDS` best distinct
    ones whatever their score: there a coarse hypothesis a few centimetres off (the map's
    survey error at short range) can score below wrong ones that meet many reflectors by
    chance.
    """
    best = int(explained.max())
    pick = explained >= (3 if local else max(best - 1, 3))
    cand = hyps[pick][np.argsort(-explained[pick], kind="stable")]
    seeds = [r[0] for r in _distinct([(p, 0, 0.0) for p in cand[:400]], position_tol, heading_tol)]
    seeds = seeds[:LOCAL_SEEDS] if local else seeds[:32]
    out = []
    var = bearing_std**2

    def label(pose: NDArray[np.float64], cov: NDArray[np.float64]) -> NDArray[np.int64]:
        return associate_sweep(z, pose, cov, mount, xy, rad, var, max_range=max_range, gate=gate, map_std=map_std)

    def fit(
        pose: NDArray[np.float64], labels: NDArray[np.int64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        seen = labels >= 0
        return _gauss_newton(pose, z[seen], xy[labels[seen]], rad[labels[seen]], mount, var, map_std)

    for pose in seeds:
        labels = label(pose, np.diag([0.05, 0.05, 0.01]) ** 2)  # loose: the hypothesis is only a start
        for _ in range(3):
            if np.count_nonzero(labels >= 0) < 3:
                break
            pose, cov, ssr = fit(pose, labels)
            labels = label(pose, cov)
        n = int(np.count_nonzero(labels >= 0))
        if n >= 3:
            pose, cov, ssr = fit(pose, labels)
            out.append((pose, n, ssr, labels, cov))
    return out


def _gauss_newton(
    pose: NDArray[np.float64],
    z: NDArray[np.float64],
    xy: NDArray[np.float64],
    rad: NDArray[np.float64],
    mount: ArrayLike,
    var: float,
    map_std: float = 0.0,
    iterations: int = 8,
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Static weighted least-squares pose from labelled bearings: ``(pose, covariance, chi-square)``."""
    x = np.array(pose, dtype=np.float64)
    for _ in range(iterations):
        h, H, d = bearing_model(x, mount, xy, rad)
        r = angle_diff(z, h)
        w = 1.0 / np.sqrt(measurement_variance(var, map_std, d))
        step, *_ = np.linalg.lstsq(H * w[:, None], r * w, rcond=None)
        x = x + step
        x[2] = wrap_angle(x[2])
        if np.max(np.abs(step)) < 1e-12:
            break
    h, H, d = bearing_model(x, mount, xy, rad)
    r = angle_diff(z, h)
    R = measurement_variance(var, map_std, d)
    cov = np.asarray(np.linalg.pinv(H.T @ (H / R[:, None])), dtype=np.float64)
    return x, cov, float(np.sum(r * r / R))


def _distinct(items: list[tuple], position_tol: float, heading_tol: float) -> list[tuple]:
    """Keep the first item of every cluster of poses closer than the tolerances.

    One vectorised comparison of each item with the poses kept so far (same decisions as
    comparing them one by one: the same element-wise ``hypot`` and ``angle_diff``).
    """
    kept: list[tuple] = []
    poses = np.empty((len(items), 3))
    for it in items:
        p = it[0]
        k = poses[: len(kept)]
        if np.all((np.hypot(p[0] - k[:, 0], p[1] - k[:, 1]) > position_tol)
                  | (np.abs(angle_diff(p[2], k[:, 2])) > heading_tol)):
            poses[len(kept)] = p
            kept.append(it)
    return kept
