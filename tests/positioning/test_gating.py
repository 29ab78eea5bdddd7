"""The bearing index only skips reflectors the gate would reject: same association as the full loop."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agvnav.positioning import _fast, make_estimator
from agvnav.positioning import association as association_module
from agvnav.positioning.edge_bearing import bearing_model, measurement_variance
from agvnav.positioning.gating import INDEX_MIN_REFLECTORS, BearingIndex, GateSpec, grid_rows, near_rows
from agvnav.positioning.integrity import IntegrityLimits
from agvnav.world import Reflector, WorldMap


def _spd(rng: np.random.Generator, scale: float) -> np.ndarray:
    A = rng.normal(0.0, scale, (3, 3))
    return A @ A.T + 1e-9 * np.eye(3)


def _same(a: tuple, b: tuple) -> bool:
    """Equal gate results, NaN equal to NaN (the rejected case carries NaNs)."""
    return all(x == y or (isinstance(x, float) and math.isnan(x) and math.isnan(y)) for x, y in zip(a, b, strict=True))


def _case(seed: int, n: int, hit: bool) -> tuple:
    """A random map, pose, covariance, mount, claims and bearing (near a reflector when ``hit``)."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform([0.0, 0.0], [40.0, 25.0], (n, 2))
    if n > 2:
        xy[1] = xy[0] + rng.normal(0.0, 0.05, 2)  # a near-duplicate pair: an ambiguous gate
    radius = rng.choice([0.0, 0.04, 0.3, 1.0], n)
    pose = rng.uniform([0.0, 0.0, -math.pi], [40.0, 25.0, math.pi])
    if rng.random() < 0.2:
        pose[:2] = xy[int(rng.integers(n))] + rng.normal(0.0, 0.2, 2)  # the head inside or at a reflector
    mount = tuple(rng.uniform([-0.8, -0.4, -math.pi], [0.8, 0.4, math.pi]).tolist())
    P = _spd(rng, float(10.0 ** rng.uniform(-4.0, 0.0)))
    h, _, _ = bearing_model(pose, mount, xy, radius)
    near = float(_fast.wrap(h[int(rng.integers(n))] + rng.normal(0.0, 0.01)))
    z = near if hit else float(rng.uniform(-math.pi, math.pi))
    spec = GateSpec(
        bearing_var=float(10.0 ** rng.uniform(-9.0, -4.0)),
        max_range=float(rng.choice([math.inf, 30.0, 8.0])),
        gate=float(rng.choice([3.84, 10.83, 50.0])),
        map_std=float(rng.choice([0.0, 0.005])),
        sweep=0.09,
    )
    claimed = np.where(rng.random(n) < 0.15, 1.0, -math.inf).tolist()  # claimed at t = 1.0, gated at t = 1.05
    return xy, radius, tuple(pose.tolist()), tuple(P.reshape(9).tolist()), mount, z, spec, claimed


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 300), hit=st.booleans())
def test_indexed_gate_gives_the_association_of_the_full_loop(seed: int, n: int, hit: bool) -> None:
    xy, radius, pose, P, mount, z, spec, claimed = _case(seed, n, hit)
    rows = _fast.reflector_rows(xy, radius)
    full = _fast.gate_one(z, pose, P, mount, rows, spec, claimed, 1.05)
    index = BearingIndex(xy, radius, mount, spec)
    indexed = _fast.gate_one(z, pose, P, mount, rows, spec, claimed, 1.05, index.candidates(z, pose, P))
    assert _same(indexed, full)


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 120), hit=st.booleans())
def test_candidates_hold_every_reflector_inside_the_gate(seed: int, n: int, hit: bool) -> None:
    """Soundness of the bound against the vectorised reference model (bearing_model): no reflector lost."""
    xy, radius, pose, P, mount, z, spec, _ = _case(seed, n, hit)
    h, H, d = bearing_model(np.array(pose), mount, xy, radius)
    S = np.einsum("ni,ij,nj->n", H, np.reshape(P, (3, 3)), H) + measurement_variance(spec.bearing_var, spec.map_std, d)
    y = np.asarray(_fast_wrap_all(z - h))
    inside = set(np.flatnonzero((y * y / S < spec.gate) & (d <= spec.max_range)).tolist())
    candidates = BearingIndex(xy, radius, mount, spec).candidates(z, pose, P)
    assert inside <= set(candidates)
    assert candidates == sorted(candidates)


def _grid_and_plain(index: BearingIndex, hx: float, hy: float, beam: float, a4: float, b4: float,
                    max_range: float) -> tuple[list[int], list[int]]:
    g = index._grid
    args = (index._rx, index._ry, index._r2, index._half_pi_r, hx, hy, beam, a4, b4, max_range)
    grid = grid_rows(g.start, g.rows, g.x0, g.y0, g.cell, g.nx, g.ny, *args, index._r_max).tolist()
    return grid, near_rows(*args).tolist()


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 300), hit=st.booleans())
def test_the_grid_returns_exactly_the_rows_of_the_plain_pass(seed: int, n: int, hit: bool) -> None:
    """grid_rows searches a disc and a strip along the beam: the rows of near_rows, no more, no fewer."""
    xy, radius, pose, _, mount, z, spec, _ = _case(seed, n, hit)
    rng = np.random.default_rng(seed)
    index = BearingIndex(xy, radius, mount, spec)
    for _ in range(5):  # gates from a few mrad (the strip) to over a radian (the plain pass)
        a4, b4 = 10.0 ** rng.uniform(-9.0, 0.5), 10.0 ** rng.uniform(-8.0, 1.0)
        beam = z + pose[2] + mount[2] + float(rng.normal(0.0, 0.05))
        grid, plain = _grid_and_plain(index, pose[0], pose[1], beam, a4, b4, spec.max_range)
        assert grid == plain


def test_the_grid_searches_few_cells_on_the_bench_map(monkeypatch: pytest.MonkeyPatch) -> None:
    """The 256 reflectors of bench speed's lab: a narrow gate takes the strip, not the plain pass, and agrees."""
    from agvnav import _jit
    from agvnav.bench.speed import reflector_map
    from agvnav.positioning import gating

    refl = reflector_map(256)["reflectors"]
    xy = np.array([[r["x"], r["y"]] for r in refl])
    spec = GateSpec(bearing_var=1e-8, max_range=30.0, gate=10.83, map_std=0.005, sweep=0.09)
    index = BearingIndex(xy, np.full(len(refl), 0.04), (0.3, 0.0, 0.0), spec)
    g = index._grid
    assert g.nx * g.ny > 16 and g.rows.tolist() != list(range(256))  # a real grid, rows sorted by cell
    rng = np.random.default_rng(1)
    cases = rng.uniform([1.0, 1.0, -4.0], [19.0, 11.0, 4.0], (200, 3))
    a4, b4 = 4.0 * 10.83 * 1e-6, 4.0 * 10.83 * 3e-4
    plain = [near_rows(index._rx, index._ry, index._r2, index._half_pi_r, hx, hy, beam, a4, b4, 30.0).tolist()
             for hx, hy, beam in cases]

    def no_plain_pass(*args: object) -> None:
        raise AssertionError("grid_rows fell back to the plain pass")

    before = _jit.compiled()
    _jit.set_compiled(False)  # interpreted, grid_rows finds its fallback in the module: patched to fail here
    monkeypatch.setattr(gating, "near_rows", no_plain_pass)
    try:
        grid = [grid_rows(g.start, g.rows, g.x0, g.y0, g.cell, g.nx, g.ny, index._rx, index._ry, index._r2,
                          index._half_pi_r, hx, hy, beam, a4, b4, 30.0, index._r_max).tolist()
                for hx, hy, beam in cases]
    finally:
        _jit.set_compiled(before)
    assert grid == plain and min(len(p) for p in plain) >= 1


def _fast_wrap_all(a: np.ndarray) -> list[float]:
    return [_fast.wrap(float(v)) for v in a]


def test_the_index_is_selective_on_a_large_map() -> None:
    """Not a vacuous superset: on 256 reflectors a bearing keeps only a handful of candidates."""
    rng = np.random.default_rng(3)
    xy = rng.uniform([0.5, 0.5], [59.5, 29.5], (256, 2))
    radius = np.full(256, 0.04)
    spec = GateSpec(bearing_var=1e-8, max_range=30.0, gate=10.83, map_std=0.005, sweep=0.09)
    pose, mount = (30.0, 15.0, 0.3), (0.3, 0.0, 0.0)
    P = (1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-5)
    h, _, _ = bearing_model(np.array(pose), mount, xy, radius)
    counts = [len(BearingIndex(xy, radius, mount, spec).candidates(float(z), pose, P)) for z in h[:50]]
    assert min(counts) >= 1 and np.mean(counts) < 8


def test_bad_radius_shape_is_refused() -> None:
    spec = GateSpec(1e-8, 30.0, 10.83, 0.0, 0.09)
    with pytest.raises(ValueError, match="radius"):
        BearingIndex(np.zeros((3, 2)), np.zeros(2), (0.0, 0.0, 0.0), spec)


def _hall(n: int, seed: int) -> WorldMap:
    rng = np.random.default_rng(seed)
    xy = rng.uniform([0.5, 0.5], [39.5, 24.5], (n, 2))
    return WorldMap(tuple(Reflector(f"R{i}", float(x), float(y), 0.04) for i, (x, y) in enumerate(xy)))


@pytest.mark.parametrize("n", [INDEX_MIN_REFLECTORS, 64])
def test_ekf_with_and_without_the_index_is_bit_identical(n: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """A whole run: identical poses, covariances and counters whether the index is used or not."""
    world = _hall(n, n)
    rng = np.random.default_rng(n)
    mount = (0.4, 0.0, 0.0)
    x0 = np.array([20.0, 12.0, 0.3])
    h_all = []
    pose = x0.copy()
    for k in range(400):  # a sideways arc; bearings of random reflectors plus spurious ones
        pose = pose + np.array([-0.004 * math.sin(pose[2]), 0.004 * math.cos(pose[2]), 0.001])
        h, _, _ = bearing_model(pose, mount, world.reflector_xy, world.reflector_radius)
        j = int(rng.integers(n))
        z = float(h[j]) + rng.normal(0.0, 3e-5) if k % 5 else float(rng.uniform(-math.pi, math.pi))
        h_all.append(z)

    def run() -> tuple:
        est = make_estimator("ekf", world, mount, initial_pose=x0, initial_covariance=np.diag([1e-3, 1e-3, 2e-4]) ** 2,
                             bearing_offset=0.0, bearing_std=5e-5, integrity=IntegrityLimits(enabled=False))
        out = []
        for k, z in enumerate(h_all):
            t = 0.01 * (k + 1)
            est.predict(t, 0.0, 0.001, 0.004)
            est.update(t, z)
            out.append((tuple(est.pose), tuple(est.covariance.reshape(9))))
        return out, est.n_accepted, est.n_rejected, est.n_inflations

    with_index = run()
    monkeypatch.setattr(association_module, "INDEX_MIN_REFLECTORS", 10**9)
    without_index = run()
    assert with_index == without_index
    assert with_index[1] > 100  # updates were accepted
