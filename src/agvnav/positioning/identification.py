"""Identifying anonymous reflections: the bearing model, a tracking gate, and the start-up search.

The goniometer reports only ``(t, bearing)`` (seed 000 §2.1): which map reflector
produced a reflection must be decided by the positioning side. Two situations:

* tracking -- a predicted pose and its covariance exist: each reflection is matched
  to the reflector whose predicted bearing lies inside a chi-square gate on the
  innovation, and a reflector already claimed in the current sweep cannot be claimed
  again (:func:`gate_reflection`, :func:`associate_sweep`);
* start-up without any prior (standstill, as commercial sensors do): reflector
  triples are tried against observed bearing triples, each hypothesis is resected and
  scored by how many reflections it explains, and an ambiguity (several distinct
  poses explaining equally many, e.g. a rotationally symmetric layout) is reported
  rather than guessed (:func:`initial_pose_search`). Small maps try every ordered
  reflector triple; a large map (above :data:`FULL_SEARCH_MAX_CELLS`) is searched
  locally, in memory linear in its size: consecutive bearings on neighbouring
  reflectors (:mod:`agvnav.positioning.spatial`), chunked and with early rejection.
  That assumes reflections next to each other come from reflectors next to each other
  (walls, racks); on a map of scattered, isolated reflectors it may find nothing. Not
  having tried every triple, it reports a pose ``found`` only when the pose explains at
  least :data:`LOCAL_MIN_FRACTION` of the bearings.

The measurement model (:func:`bearing_model`) is the bearing, in the head frame, of
the leading tangent edge of a cylindrical reflector of radius r seen from the head
centre P: the head turns counter-clockwise, so the beam meets the edge at
``centre - asin(r / d)`` (seed 000 §2.1: the angle is read "at the start of the
reflection").
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import angle_diff, compose, inverse, wrap_angle
from agvnav.positioning.spatial import count_explained, nearest_neighbours

__all__ = [
    "Association",
    "InitialPoseResult",
    "associate_sweep",
    "bearing_model",
    "edge_offset",
    "gate_reflection",
    "initial_pose_search",
    "measurement_variance",
    "resect_three",
]

#: chi-square quantile, 1 degree of freedom, probability 0.999 (gate on one bearing innovation).
CHI2_1DOF_999 = 10.827566170662733

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


def edge_offset(distance: ArrayLike, radius: ArrayLike) -> NDArray[np.float64]:
    """Angle (rad) from a reflector's centre to its leading tangent edge, ``-asin(r / d)``.

    The head turns counter-clockwise, so the reflection starts on the clockwise side of
    the cylinder (seed 000 §2.1). ``distance`` (m) and ``radius`` (m) broadcast; a head
    inside a reflector (``d <= r``) is clipped to ``-pi/2``.
    """
    d = np.asarray(distance, dtype=np.float64)
    r = np.asarray(radius, dtype=np.float64)
    ratio = np.clip(r / np.where(d > 0.0, d, np.inf), 0.0, 1.0)
    return -np.arcsin(np.where(d > 0.0, ratio, 1.0))


def bearing_model(
    pose: ArrayLike, mount: ArrayLike, reflector_xy: ArrayLike, radius: ArrayLike = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Predicted leading-edge bearing of reflectors from the head, and its Jacobian.

    Parameters
    ----------
    pose:
        ``(..., 3)`` base_link pose ``[x, y, psi]`` in ``map`` (m, rad).
    mount:
        ``(3,)`` pose of the head centre P in base_link (m, rad).
    reflector_xy, radius:
        ``(..., 2)`` reflector centres (m) and ``(...)`` radii (m); all broadcast.

    Returns
    -------
    h:
        ``(...)`` bearing in the head frame (rad, wrapped), ``atan2(R - P) - psi_P - asin(r/d)``
        (seed 000 §2.1: the angle theta_i of the beam relative to the frame at the start of
        the reflection).
    H:
        ``(..., 3)`` derivative of ``h`` with respect to ``[x, y, psi]`` of base_link.
    distance:
        ``(...)`` distance (m) from P to the reflector centre.
    """
    pose = np.asarray(pose, dtype=np.float64)
    m = np.asarray(mount, dtype=np.float64)
    xy = np.asarray(reflector_xy, dtype=np.float64)
    r = np.asarray(radius, dtype=np.float64)
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    px = pose[..., 0] + c * m[0] - s * m[1]
    py = pose[..., 1] + s * m[0] + c * m[1]
    dx, dy = xy[..., 0] - px, xy[..., 1] - py
    d2 = dx * dx + dy * dy
    d = np.sqrt(d2)
    h = wrap_angle(np.arctan2(dy, dx) - pose[..., 2] - m[2] + edge_offset(d, r))
    safe_d = np.where(d > 0.0, d, np.inf)
    ratio = np.clip(r / safe_d, 0.0, 1.0 - 1e-12)
    edge_gain = r / (safe_d**3 * np.sqrt(1.0 - ratio**2))  # d/dd of asin(r/d), sign folded below
    dh_dpx = dy / np.where(d2 > 0.0, d2, np.inf) - edge_gain * dx
    dh_dpy = -dx / np.where(d2 > 0.0, d2, np.inf) - edge_gain * dy
    dpx_dpsi = -s * m[0] - c * m[1]
    dpy_dpsi = c * m[0] - s * m[1]
    dh_dpsi = dh_dpx * dpx_dpsi + dh_dpy * dpy_dpsi - 1.0
    H = np.stack(np.broadcast_arrays(dh_dpx, dh_dpy, dh_dpsi), axis=-1)
    return h, H, d


@dataclass(frozen=True)
class Association:
    """Outcome of gating one reflection (see :func:`gate_reflection`).

    ``index`` is the map reflector row (-1 when rejected); ``nis`` the normalised innovation
    squared of the chosen reflector (inf when none); ``n_in_gate`` how many reflectors fell
    inside the gate (2 or more means the reflection was rejected as ambiguous); ``H`` the
    bearing Jacobian row, ``S`` the innovation variance and ``R`` the measurement variance.
    """

    index: int
    innovation: float
    nis: float
    n_in_gate: int
    H: NDArray[np.float64] = field(repr=False)
    S: float
    R: float


def measurement_variance(bearing_var: ArrayLike, map_std: float, distance: ArrayLike) -> NDArray[np.float64]:
    """Variance (rad²) of one bearing: encoder/bearing noise plus the map survey error seen at ``distance`` (m).

    ``R = sigma_b^2 + (map_std / d)^2``: a reflector displaced by ``map_std`` across the line
    of sight shifts its bearing by ``map_std / d`` (seed 000 §4.1: surveyed positions).
    """
    d = np.asarray(distance, dtype=np.float64)
    return np.asarray(bearing_var, dtype=np.float64) + (float(map_std) / np.where(d > 0.0, d, np.inf)) ** 2


def gate_reflection(
    bearing: float,
    pose: ArrayLike,
    covariance: ArrayLike,
    mount: ArrayLike,
    reflector_xy: ArrayLike,
    radius: ArrayLike,
    bearing_var: float,
    *,
    max_range: float = np.inf,
    excluded: ArrayLike | None = None,
    gate: float = CHI2_1DOF_999,
    map_std: float = 0.0,
) -> Association:
    """Match one anonymous bearing to a map reflector with a chi-square innovation gate.

    For every reflector within ``max_range`` of the head the innovation
    ``y = wrap(z - h(x))`` and its variance ``S = H P H^T + sigma^2`` are formed; the
    reflection is accepted when exactly one reflector has ``y^2 / S < gate`` (chi-square,
    1 dof). Two or more reflectors in the gate means the prediction cannot tell them apart:
    the reflection is rejected rather than risk a wrong label. ``excluded`` (bool ``(N,)``)
    removes reflectors already claimed in the current sweep, so one sweep never gives the
    same reflector twice. ``map_std`` (m) is the survey error of a reflector position; it
    adds ``(map_std / d)^2`` to the measurement variance (returned as ``R``).
    """
    xy = np.asarray(reflector_xy, dtype=np.float64)
    P = np.asarray(covariance, dtype=np.float64)
    h, H, d = bearing_model(pose, mount, xy, radius)
    y = angle_diff(float(bearing), h)
    R = measurement_variance(bearing_var, map_std, d)
    S = np.einsum("ni,ij,nj->n", H, P, H) + R
    nis = y * y / S
    ok = d <= max_range
    if excluded is not None:
        ok &= ~np.asarray(excluded, dtype=bool)
    in_gate = ok & (nis < gate)
    n_in = int(np.count_nonzero(in_gate))
    if n_in != 1:
        return Association(-1, float("nan"), float("inf"), n_in, np.zeros(3), float("nan"), float("nan"))
    j = int(np.flatnonzero(in_gate)[0])
    return Association(j, float(y[j]), float(nis[j]), 1, H[j], float(S[j]), float(R[j]))


def associate_sweep(
    bearings: ArrayLike,
    pose: ArrayLike,
    covariance: ArrayLike,
    mount: ArrayLike,
    reflector_xy: ArrayLike,
    radius: ArrayLike,
    bearing_var: float,
    *,
    max_range: float = np.inf,
    gate: float = CHI2_1DOF_999,
    map_std: float = 0.0,
) -> NDArray[np.int64]:
    """Label all bearings ``(k,)`` of one sweep at once: ``(k,)`` reflector rows, -1 = rejected.

    A global nearest-neighbour assignment (Hungarian algorithm on the NIS) inside the
    chi-square gate, so no two reflections of the sweep claim the same reflector and
    spurious reflections that fit no reflector are left unlabelled.

    ``scipy.optimize`` (``linear_sum_assignment``) is imported here, on the first call,
    not with the module: it is about 60 % of the start-up time of ``agvnav.cli``, and
    only the start-up pose search needs it.
    """
    from scipy.optimize import linear_sum_assignment  # noqa: PLC0415 - heavy third-party import, deferred (issue 11)

    z = np.atleast_1d(np.asarray(bearings, dtype=np.float64))
    xy = np.asarray(reflector_xy, dtype=np.float64)
    h, H, d = bearing_model(pose, mount, xy, radius)
    R = measurement_variance(bearing_var, map_std, d)
    S = np.einsum("ni,ij,nj->n", H, np.asarray(covariance, dtype=np.float64), H) + R
    nis = angle_diff(z[:, None], h[None, :]) ** 2 / S[None, :]
    allowed = (nis < gate) & (d <= max_range)[None, :]
    labels = np.full(z.shape, -1, dtype=np.int64)
    if not np.any(allowed):
        return labels
    cost = np.where(allowed, nis, 1e9)
    rows, cols = linear_sum_assignment(cost)
    keep = allowed[rows, cols]
    labels[rows[keep]] = cols[keep]
    return labels


def resect_three(
    reflector_xy: ArrayLike, bearings: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Head pose from three simultaneous centre bearings (rad) of three known reflectors.

    Geometric circle intersection on the relative angles (seed 000 §2.2, Fig. 1b, the
    "arcos capaces" method): P lies on the circle through R1, R2 that sees them under
    ``alpha = theta2 - theta1`` and on the circle through R2, R3 under ``beta``; the two
    circles meet at R2 and at P, the mirror of R2 in the line of their centres. The heading
    is then the circular mean of ``atan2(R_i - P) - theta_i``. Used here only to generate
    start-up hypotheses (no odometric heading exists yet); the fixes of a moving vehicle use
    :func:`agvnav.positioning.triangulate`.

    ``reflector_xy (..., 3, 2)``, ``bearings (..., 3)`` -> ``(pose (..., 3), valid (...))``;
    invalid on the critical circle and for collinear, coincident or inconsistent data.
    """
    R = np.asarray(reflector_xy, dtype=np.float64)
    th = np.asarray(bearings, dtype=np.float64)
    c12 = _arc_centre(R[..., 0, :], R[..., 1, :], angle_diff(th[..., 1], th[..., 0]))
    c23 = _arc_centre(R[..., 1, :], R[..., 2, :], angle_diff(th[..., 2], th[..., 1]))
    u = c23 - c12
    uu = np.sum(u * u, axis=-1)
    scale = np.maximum(np.sum((R[..., 1, :] - R[..., 0, :]) ** 2, -1), 1e-300)
    valid = np.isfinite(uu) & (uu > 1e-10 * scale)
    safe = np.where(valid, uu, 1.0)
    t = np.sum((R[..., 1, :] - c12) * u, axis=-1) / safe
    foot = c12 + t[..., None] * u
    p = 2.0 * foot - R[..., 1, :]
    absolute = np.arctan2(R[..., 1] - p[..., None, 1], R[..., 0] - p[..., None, 0])
    diff = wrap_angle(absolute - th)
    heading = wrap_angle(np.arctan2(np.mean(np.sin(diff), -1), np.mean(np.cos(diff), -1)))
    spread = np.max(np.abs(angle_diff(diff, heading[..., None])), axis=-1)
    valid &= np.all(np.isfinite(p), axis=-1) & (spread < 1e-3)
    pose = np.concatenate([p, heading[..., None]], axis=-1)
    return np.where(valid[..., None], pose, np.nan), valid


def _arc_centre(a: NDArray[np.float64], b: NDArray[np.float64], angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Centre of the circle through ``a``, ``b`` from which chord ab is seen under ``angle`` (CCW)."""
    chord = b - a
    left = np.stack([-chord[..., 1], chord[..., 0]], axis=-1)
    sin_a = np.sin(angle)
    cot = np.cos(angle) / np.where(np.abs(sin_a) > 1e-12, sin_a, np.nan)
    return 0.5 * (a + b) + 0.5 * cot[..., None] * left


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
       (:func:`resect_three`, then once more with the edge correction of seed 000 §2.1 at
       the resected distances), drop hypotheses out of range.
    3. Score each hypothesis by the number of bearings it explains within a coarse
       tolerance; refine the best distinct hypotheses by Gauss-Newton on all the bearings
       they explain (labels by :func:`associate_sweep`, chi-square gate).
    4. Keep the pose explaining the most; if another distinct pose (farther than
       ``position_tol`` m or ``heading_tol`` rad) explains as many, report ``ambiguous``.

    ``bearings (k,)`` head-frame edge bearings (rad); the map arrays as in
    :func:`bearing_model`; ``map_std`` as in :func:`gate_reflection`. Needs at least three
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
