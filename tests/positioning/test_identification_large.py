"""Start-up search on large maps: bearing-order scoring, the spatial index, the local search (issue 11)."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from agvnav.geometry import angle_diff
from agvnav.positioning import identification as ident
from agvnav.positioning.edge_bearing import bearing_model
from agvnav.positioning.identification import initial_pose_search
from agvnav.positioning.spatial import count_explained, nearest_neighbours

MOUNT = np.array([0.3, 0.0, 0.0])
SIGMA = 2 * np.pi / 65535 / np.sqrt(12)


def test_count_explained_equals_the_full_table() -> None:
    rng = np.random.default_rng(1)
    for _ in range(300):
        c, n, k = (int(v) for v in rng.integers(1, [6, 14, 10]))
        h = rng.uniform(-np.pi, np.pi, (c, n))
        h[rng.random((c, n)) < 0.3] = np.nan
        z = rng.uniform(-np.pi, np.pi, k)
        z[: min(2, k)] = [-np.pi, np.pi - 1e-9][: min(2, k)]  # both ends of the wrap
        tol = float(rng.uniform(0.01, 1.0))
        full = np.any(np.abs(angle_diff(z[None, :, None], h[:, None, :])) < tol, axis=-1).sum(-1)
        np.testing.assert_array_equal(count_explained(z, h, tol), full)


def test_count_explained_wraps_and_ignores_invisible() -> None:
    h = np.array([[np.pi - 1e-3, np.nan, 0.0], [np.nan, np.nan, np.nan]])
    z = np.array([-np.pi + 1e-3, 0.5, 0.0])
    np.testing.assert_array_equal(count_explained(z, h, 3e-3), [2, 0])
    with pytest.raises(ValueError, match="shape"):
        count_explained(z, h[0], 1e-3)


def test_nearest_neighbours_equal_brute_force() -> None:
    rng = np.random.default_rng(2)
    xy = rng.uniform(0.0, 30.0, (700, 2))  # more than one block of rows
    nb = nearest_neighbours(xy, 5)
    d = np.linalg.norm(xy[:, None] - xy[None], axis=-1)
    np.fill_diagonal(d, np.inf)
    np.testing.assert_array_equal(nb, np.argsort(d, axis=1, kind="stable")[:, :5])
    assert nearest_neighbours(xy[:3], 10).shape == (3, 2)
    with pytest.raises(ValueError, match="k"):
        nearest_neighbours(xy, 0)


def _wall_map(n: int, rng: np.random.Generator, jitter: bool) -> np.ndarray:
    """``n`` reflectors 5 cm inside a 20 x 12 m rectangle, evenly spaced or at random."""
    w, h = 19.9, 11.9
    per = 2 * (w + h)
    s = np.sort(rng.uniform(0, per, n)) if jitter else (np.arange(n) + 0.5) * per / n
    out = []
    for v in s:
        if v < w:
            out.append((0.05 + v, 0.05))
        elif v < w + h:
            out.append((19.95, 0.05 + v - w))
        elif v < 2 * w + h:
            out.append((19.95 - (v - w - h), 11.95))
        else:
            out.append((0.05, 11.95 - (v - 2 * w - h)))
    return np.array(out)


def _sweep(xy: np.ndarray, pose: np.ndarray, rng: np.random.Generator, map_std: float) -> np.ndarray:
    h, _, d = bearing_model(pose, MOUNT, xy, 0.04)
    seen = np.flatnonzero(rng.random(xy.shape[0]) > 0.05)
    return h[seen] + rng.normal(0.0, SIGMA, seen.size) + rng.normal(0.0, map_std, seen.size) / d[seen]


@pytest.mark.parametrize(
    ("n", "pose"), [(120, (4.5, 2.1, 0.4)), pytest.param(256, (12.0, 7.0, -2.0), marks=pytest.mark.slow)]
)
def test_local_search_finds_the_pose_on_a_dense_wall_map(n: int, pose: tuple[float, float, float]) -> None:
    rng = np.random.default_rng(n)
    xy = _wall_map(n, rng, jitter=True)
    truth = np.array(pose)
    z = _sweep(xy, truth, rng, 0.005)
    cells = len(ident._observation_triples(z.size, 24)) * n * (n - 1) * (n - 2) * max(n, z.size)
    assert cells > ident.FULL_SEARCH_MAX_CELLS  # the exhaustive table would be too large: the local search runs
    tracemalloc.start()
    try:
        res = initial_pose_search(z, xy, 0.04, MOUNT, SIGMA, max_range=30.0, map_std=0.005)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert res.found and not res.ambiguous
    assert np.hypot(*(res.pose[:2] - truth[:2])) < 0.01
    assert abs(angle_diff(res.pose[2], truth[2])) < 1e-3
    assert res.n_explained >= 0.95 * z.size
    assert peak < 300 * 2**20


def test_local_search_claims_no_pose_from_scattered_reflectors() -> None:
    """Scattered reflectors break the neighbour assumption: whatever it returns, never a wrong pose as found."""
    rng = np.random.default_rng(7)
    xy = rng.uniform((0.0, 0.0), (40.0, 25.0), (150, 2))
    truth = np.array([17.0, 11.0, 0.4])
    z = _sweep(xy, truth, rng, 0.0)
    res = initial_pose_search(z, xy, 0.04, MOUNT, SIGMA, max_range=30.0)
    if res.found:
        assert np.hypot(*(res.pose[:2] - truth[:2])) < 0.01 and res.n_explained >= 0.5 * z.size


def test_local_search_reports_the_symmetry_of_an_even_rectangle() -> None:
    """Evenly spaced reflectors round a rectangle look the same after a half turn about its centre."""
    rng = np.random.default_rng(5)
    xy = _wall_map(128, rng, jitter=False)
    truth = np.array([4.5, 2.1, 0.0])
    z = _sweep(xy, truth, rng, 0.0)
    res = initial_pose_search(z, xy, 0.04, MOUNT, SIGMA, max_range=30.0)
    assert res.ambiguous and not res.found
    mirror = np.array([20.0 - truth[0], 12.0 - truth[1]])
    near = [min(np.hypot(*(a[:2] - truth[:2])), np.hypot(*(a[:2] - mirror))) for a in res.alternatives]
    assert max(near) < 0.3
