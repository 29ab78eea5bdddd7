"""Laser goniometer sensor model (seed 000 §2.1, §4.1) against independent references."""

import math
from itertools import pairwise

import numpy as np
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats

from agvnav.sensors import Goniometer, Reflections, leading_edge_bearing, reflector_centre_bearing
from agvnav.sensors import goniometer as gmod
from agvnav.world import Reflector, Wall, WorldMap, load_builtin_map

RES = 2 * math.pi / 65535


def static(x, y, heading):
    def pose_at(t):
        t = np.asarray(t, dtype=float)
        return np.stack([np.full_like(t, x), np.full_like(t, y), np.full_like(t, heading)], axis=-1)

    return pose_at


def arc(x0, y0, psi0, v, omega):
    """Constant speed ``v`` (m/s) and yaw rate ``omega`` (rad/s): an exact circular arc."""

    def pose_at(t):
        t = np.asarray(t, dtype=float)
        psi = psi0 + omega * t
        if abs(omega) < 1e-9:
            x, y = x0 + v * t * np.cos(psi0), y0 + v * t * np.sin(psi0)
        else:
            x = x0 + v / omega * (np.sin(psi) - np.sin(psi0))
            y = y0 - v / omega * (np.cos(psi) - np.cos(psi0))
        return np.stack([x, y, psi], axis=-1)

    return pose_at


def ring_world(n=8, radius=0.04, seed=3):
    """Reflectors scattered 1.5-12 m around the origin, no walls (the brute force ignores occlusion)."""
    rng = np.random.default_rng(seed)
    ang = np.sort(rng.uniform(-np.pi, np.pi, n))
    dist = rng.uniform(1.5, 12.0, n)
    refl = [Reflector(f"R{i}", d * np.cos(a), d * np.sin(a), radius if i else 0.0) for i, (a, d) in
            enumerate(zip(ang, dist, strict=True))]
    return WorldMap(refl, [])


def brute_force(world, pose_at, mount, rate_hz, phase, direction, t0, t1, dt=2e-6):
    """Independent reference: fine time sampling of the beam-edge angle, linear interpolation of its zeros."""
    t = np.arange(t0, t1 + dt, dt)
    q = pose_at(t)
    mx, my, mth = mount
    px = q[:, 0] + np.cos(q[:, 2]) * mx - np.sin(q[:, 2]) * my
    py = q[:, 1] + np.sin(q[:, 2]) * mx + np.cos(q[:, 2]) * my
    beam = q[:, 2] + mth + phase + direction * 2 * np.pi * rate_hz * t
    times, index = [], []
    for j, (xy, r) in enumerate(zip(world.reflector_xy, world.reflector_radius, strict=True)):
        d = np.hypot(xy[0] - px, xy[1] - py)
        edge = np.arctan2(xy[1] - py, xy[0] - px) - direction * np.arcsin(r / d)
        g = np.angle(np.exp(1j * direction * (beam - edge)))  # wrapped independently of agvnav
        k = np.nonzero((g[:-1] < 0) & (g[1:] >= 0) & (g[1:] - g[:-1] < 1.0))[0]
        times.append(t[k] - g[k] * (t[k + 1] - t[k]) / (g[k + 1] - g[k]))
        index.append(np.full(k.size, j))
    times, index = np.concatenate(times), np.concatenate(index)
    order = np.argsort(times)
    return times[order], index[order]


def windows(gonio, world, pose_at, t0, t1, step, rng=None):
    edges = np.unique(np.concatenate([np.arange(t0, t1, step), [t1]]))
    return Reflections.concatenate([gonio.scan(world, pose_at, a, b, rng) for a, b in pairwise(edges)])


# --- static vehicle ------------------------------------------------------------------


def _lab_visible(world, head_xy):
    """Shapely reference: reflectors whose line of sight to the cylinder is clear."""
    walls = [shapely.LineString(np.vstack([w.points, w.points[:1]]) if w.closed else w.points) for w in world.walls]
    discs = [
        shapely.Point(*xy).buffer(r, quad_segs=64)
        for xy, r in zip(world.reflector_xy, world.reflector_radius, strict=True)
    ]
    visible = set()
    for j, (xy, r) in enumerate(zip(world.reflector_xy, world.reflector_radius, strict=True)):
        d = np.hypot(*(xy - head_xy))
        end = head_xy + (xy - head_xy) * (d - r - 1e-6) / d
        sight = shapely.LineString([head_xy, end])
        if any(sight.intersects(w) for w in walls):
            continue
        if any(sight.intersects(disc) for k, disc in enumerate(discs) if k != j):
            continue
        visible.add(j)
    return visible


def _free_poses(world, n, seed):
    rng = np.random.default_rng(seed)
    obstacles = shapely.unary_union([shapely.Polygon(w.points).buffer(0.6) for w in world.walls[1:]])
    poses = []
    while len(poses) < n:
        x, y, h = rng.uniform(1, 19), rng.uniform(1, 11), rng.uniform(-np.pi, np.pi)
        if not obstacles.contains(shapely.Point(x, y)):
            poses.append((x, y, h))
    return poses


@pytest.mark.parametrize("pose", _free_poses(load_builtin_map("lab"), 6, seed=1) + [(10.0, 7.0, 0.3)])
def test_static_vehicle_sees_each_visible_reflector_once_at_its_true_bearing(pose):
    world = load_builtin_map("lab")
    mount = (0.6, -0.05, 0.1)
    gonio = Goniometer(mount=mount, phase=0.4)
    period = 1.0 / gonio.rate_hz
    out = gonio.scan(world, static(*pose), 5.0, 5.0 + period)
    head = gonio.head_pose(np.array(pose))
    assert set(out.reflector_index.tolist()) == _lab_visible(world, head[:2])
    assert len(np.unique(out.reflector_index)) == len(out)  # once per revolution
    if pose == (10.0, 7.0, 0.3):  # behind pillar P2: its reflector R8 is hidden
        assert 7 not in out.reflector_index
    rel = world.reflector_xy[out.reflector_index] - head[:2]
    true_edge = np.arctan2(rel[:, 1], rel[:, 0]) - np.arcsin(0.04 / np.hypot(*rel.T)) - head[2]
    lag = np.mod(true_edge - out.bearing, 2 * np.pi)  # floor: reported <= true < reported + RES
    lag = np.where(lag > np.pi, lag - 2 * np.pi, lag)
    assert np.all(lag >= -1e-9) and np.all(lag < RES + 1e-9)
    # the instant is when the head angle equals the true edge bearing
    head_angle = np.mod(gonio.phase + 2 * np.pi * gonio.rate_hz * out.t, 2 * np.pi)
    np.testing.assert_allclose(np.angle(np.exp(1j * (head_angle - true_edge))), 0.0, atol=1e-9)
    assert np.all(np.diff(out.t) >= 0)


def test_cw_head_reports_the_other_edge():
    world = WorldMap([Reflector("A", 10.0, 0.0, 0.04)])
    ccw = Goniometer(pulses_per_rev=2**30).scan(world, static(0, 0, 0), 0.0, 0.125)
    cw = Goniometer(pulses_per_rev=2**30, direction=-1).scan(world, static(0, 0, 0), 0.0, 0.125)
    half = math.asin(0.004)
    np.testing.assert_allclose(ccw.bearing, [-half], atol=1e-8)
    np.testing.assert_allclose(cw.bearing, [half], atol=1e-8)


# --- moving vehicle: exact instants vs. an independent fine-step simulation --------


@pytest.mark.parametrize(
    ("motion", "mount", "direction"),
    [
        ((0.5, -0.3, 0.2, 2.0, 0.0), (0.0, 0.0, 0.0), 1),
        ((0.0, 0.5, -1.0, 2.0, 0.8), (0.9, 0.15, 0.3), 1),
        ((-0.5, 0.0, 2.5, 1.0, -1.5), (0.5, -0.2, -0.4), -1),
    ],
)
def test_moving_vehicle_matches_fine_step_reference(motion, mount, direction):
    world = ring_world()
    pose_at = arc(*motion)
    gonio = Goniometer(mount=mount, phase=1.1, direction=direction)
    out = windows(gonio, world, pose_at, 0.0, 0.4, 0.01)
    t_ref, idx_ref = brute_force(world, pose_at, mount, gonio.rate_hz, gonio.phase, direction, 0.0, 0.4)
    assert len(t_ref) >= 3 * len(world.reflectors)
    np.testing.assert_array_equal(out.reflector_index, idx_ref)
    np.testing.assert_allclose(out.t, t_ref, rtol=0, atol=1e-10)
    # bearing = encoder reading of the head angle at the reference instant (floor to whole pulses)
    angle_ref = np.mod(gonio.phase + direction * 2 * np.pi * gonio.rate_hz * t_ref, 2 * np.pi)
    lag = np.mod(angle_ref - out.bearing, 2 * np.pi)
    lag = np.where(lag > np.pi, lag - 2 * np.pi, lag)
    assert np.all(lag > -1e-8) and np.all(lag < RES + 1e-8)
    # motion matters: the bearings differ from those seen from the window-start pose
    start = gonio.head_pose(pose_at(np.zeros(1)))[0]
    static_b, _, _ = leading_edge_bearing(start, world.reflector_xy[out.reflector_index],
                                          world.reflector_radius[out.reflector_index], direction)
    assert np.max(np.abs(np.angle(np.exp(1j * (static_b - out.bearing))))) > 100 * RES


def test_split_windows_give_the_same_reflections_as_one_window():
    world = load_builtin_map("lab")
    pose_at = arc(3.0, 2.0, 0.3, 1.5, 0.2)
    gonio = Goniometer(mount=(0.7, 0.0, 0.0))
    whole = gonio.scan(world, pose_at, 0.0, 1.0)
    split = windows(gonio, world, pose_at, 0.0, 1.0, 0.01)
    odd = windows(gonio, world, pose_at, 0.0, 1.0, 0.0371)
    for part in (split, odd):
        np.testing.assert_array_equal(part.reflector_index, whole.reflector_index)
        np.testing.assert_allclose(part.t, whole.t, rtol=0, atol=1e-11)
        assert np.max(np.abs(part.bearing - whole.bearing)) <= RES * 1.0001


def test_bracketed_fallback_solver_agrees_with_the_fast_path(monkeypatch):
    world = ring_world()
    pose_at = arc(0.0, 0.5, -1.0, 2.0, 0.8)
    gonio = Goniometer(mount=(0.9, 0.15, 0.3), phase=1.1)
    fast = windows(gonio, world, pose_at, 0.0, 0.4, 0.01)
    monkeypatch.setattr(gmod, "_CHORD_ITER", 0)  # go straight to the Illinois iteration
    slow = windows(gonio, world, pose_at, 0.0, 0.4, 0.01)
    np.testing.assert_array_equal(slow.reflector_index, fast.reflector_index)
    np.testing.assert_allclose(slow.t, fast.t, rtol=0, atol=1e-11)


def test_an_hour_into_the_drive_bearings_keep_encoder_accuracy():
    world = load_builtin_map("lab")
    gonio = Goniometer(phase=0.4)
    pose = (6.0, 3.0, 0.7)
    t0 = 3600.0 + 1.0 / 3.0
    out = windows(gonio, world, static(*pose), t0, t0 + 0.125, 0.01)
    rel = world.reflector_xy[out.reflector_index] - np.array(pose[:2])
    true_edge = np.arctan2(rel[:, 1], rel[:, 0]) - np.arcsin(0.04 / np.hypot(*rel.T)) - pose[2]
    lag = np.mod(true_edge - out.bearing, 2 * np.pi)
    lag = np.where(lag > np.pi, lag - 2 * np.pi, lag)
    assert len(out) >= 5 and len(np.unique(out.reflector_index)) == len(out)
    assert np.all(lag >= -1e-9) and np.all(lag < RES + 1e-9)


@given(
    st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(-3.2, 3.2), st.floats(-2, 2), st.floats(-1.5, 1.5)),
    st.lists(st.floats(0.0, 0.3), min_size=1, max_size=6),
    st.floats(0, 6.3),
)
def test_any_split_of_the_time_axis_gives_the_same_reflections(motion, cuts, phase):
    world = ring_world(n=5)
    pose_at = arc(*motion)
    gonio = Goniometer(phase=phase, mount=(0.3, 0.1, 0.0))
    whole = gonio.scan(world, pose_at, 0.0, 0.3)
    edges = np.unique(np.concatenate([[0.0, 0.3], cuts]))
    parts = Reflections.concatenate([gonio.scan(world, pose_at, a, b) for a, b in pairwise(edges)])
    np.testing.assert_array_equal(parts.reflector_index, whole.reflector_index)
    np.testing.assert_allclose(parts.t, whole.t, rtol=0, atol=1e-11)
    # each reflector at most once per revolution (0.125 s) plus one: 0.3 s spans < 3 revolutions
    assert np.all(np.bincount(whole.reflector_index, minlength=5) <= 3)


# --- occlusion and range ------------------------------------------------------------


def test_wall_blocks_the_beam():
    far = Reflector("far", 10.0, 0.0, 0.04)
    blocked = WorldMap([far], [Wall("W", [[5.0, -1.0], [5.0, 1.0]])])
    clear = WorldMap([far], [Wall("W", [[5.0, 2.0], [5.0, 3.0]])])
    g = Goniometer()
    assert len(g.scan(blocked, static(0, 0, 0), 0, 0.125)) == 0
    assert g.scan(clear, static(0, 0, 0), 0, 0.125).reflector_index.tolist() == [0]


def test_nearer_reflector_hides_a_farther_one_and_point_reflectors_do_not():
    g = Goniometer()
    world = WorldMap([Reflector("far", 10.0, 0.0, 0.05), Reflector("near", 5.0, 0.0, 0.05)])
    assert g.scan(world, static(0, 0, 0), 0, 0.125).reflector_index.tolist() == [1]
    world = WorldMap([Reflector("far", 10.0, 0.0, 0.05), Reflector("near", 5.0, 0.0, 0.0)])
    assert sorted(g.scan(world, static(0, 0, 0), 0, 0.125).reflector_index.tolist()) == [0, 1]


def test_range_limits():
    world = WorldMap([Reflector("a", 5.0, 0.0, 0.04), Reflector("b", 0.0, 15.0, 0.04), Reflector("c", -35.0, 0.0)])
    assert sorted(Goniometer().scan(world, static(0, 0, 0), 0, 0.125).reflector_index.tolist()) == [0, 1]
    g = Goniometer(min_range=10.0, max_range=30.0)
    assert g.scan(world, static(0, 0, 0), 0, 0.125).reflector_index.tolist() == [1]
    assert len(Goniometer(max_range=60.0).scan(world, static(0, 0, 0), 0, 0.125)) == 3


def test_vehicle_inside_a_reflector_cylinder_sees_nothing_of_it():
    world = WorldMap([Reflector("big", 0.1, 0.0, 0.5), Reflector("b", 5.0, 0.0, 0.04)])
    out = Goniometer().scan(world, static(0, 0, 0), 0, 0.25)
    assert 0 not in out.reflector_index


# --- noise: misses, spurious reflections, jitter, determinism -------------------------


def square_world():
    angles = [0.3, 1.9, 3.4, 5.0]
    return WorldMap([Reflector(f"R{i}", 6 * np.cos(a), 6 * np.sin(a), 0.04) for i, a in enumerate(angles)])


def test_missed_detection_rate():
    g = Goniometer(p_miss=0.3)
    out = windows(g, square_world(), static(0, 0, 0), 0.0, 25.0, 0.5, np.random.default_rng(11))
    expected = 4 * 200
    seen = len(out) / expected
    assert abs(seen - 0.7) < 3 * math.sqrt(0.21 / expected)
    assert np.all(out.reflector_index >= 0)


def test_spurious_reflections_poisson_count_uniform_bearing_and_consistent_encoder():
    g = Goniometer(spurious_rate=3.0)
    out = windows(g, WorldMap(), static(0, 0, 0), 0.0, 25.0, 0.01, np.random.default_rng(5))
    assert np.all(out.reflector_index == -1)
    expected = 3.0 * 200
    assert abs(len(out) - expected) < 4 * math.sqrt(expected)
    assert stats.kstest((out.bearing + np.pi) / (2 * np.pi), "uniform").pvalue > 1e-3
    np.testing.assert_array_equal(out.bearing, g.encoder_bearing(out.t))  # a real encoder reading


def test_timestamp_jitter_leaves_bearings_and_has_the_stated_std():
    world, pose_at = square_world(), static(0, 0, 0)
    clean = Goniometer().scan(world, pose_at, 0.0, 50.0)
    noisy = Goniometer(jitter_std=1e-4).scan(world, pose_at, 0.0, 50.0, np.random.default_rng(2))
    order = np.lexsort((clean.t, clean.reflector_index))
    order_n = np.lexsort((noisy.t, noisy.reflector_index))
    np.testing.assert_array_equal(noisy.bearing[order_n], clean.bearing[order])
    err = noisy.t[order_n] - clean.t[order]
    assert abs(np.std(err) / 1e-4 - 1.0) < 0.1 and abs(np.mean(err)) < 2e-5
    assert np.all(np.diff(noisy.t) >= 0)


def test_same_seed_same_output_bit_for_bit():
    g = Goniometer(p_miss=0.2, spurious_rate=1.0, jitter_std=1e-5)
    pose_at = arc(3.0, 2.0, 0.3, 1.0, 0.3)
    world = load_builtin_map("lab")
    a = windows(g, world, pose_at, 0.0, 2.0, 0.01, np.random.default_rng(42))
    b = windows(g, world, pose_at, 0.0, 2.0, 0.01, np.random.default_rng(42))
    c = windows(g, world, pose_at, 0.0, 2.0, 0.01, np.random.default_rng(43))
    for field in ("t", "bearing", "reflector_index"):
        assert np.array_equal(getattr(a, field), getattr(b, field))
    assert a == b
    assert a != c  # another seed draws other misses, spurious reflections and jitter
    assert len(a) > 0 and np.all(np.diff(a.t) >= 0)


# --- the positioning-side edge -> centre correction ----------------------------------


def test_centre_correction_removes_the_edge_bias():
    world = WorldMap([Reflector("A", 10.0, 0.0, 0.04)])
    out = Goniometer().scan(world, static(0, 0, 0), 0.0, 0.125)
    bias = math.asin(0.04 / 10.0)
    assert bias == pytest.approx(4.0e-3, rel=1e-3)  # 4 mrad at 10 m for r = 4 cm
    assert out.bearing[0] == pytest.approx(-bias, abs=RES)  # raw: biased by asin(r/d)
    corrected = reflector_centre_bearing(out.bearing, 10.0, 0.04)
    assert abs(corrected[0]) <= RES  # only the encoder quantisation is left
    np.testing.assert_allclose(reflector_centre_bearing(bias, 10.0, 0.04, direction=-1), 0.0, atol=1e-15)


@given(
    st.tuples(st.floats(-20, 20), st.floats(-20, 20), st.floats(-4, 4)),
    st.tuples(st.floats(-20, 20), st.floats(-20, 20)),
    st.floats(0, 0.2),
    st.sampled_from([1, -1]),
)
def test_edge_and_centre_bearing_are_inverse(head, xy, r, direction):
    edge, d, valid = leading_edge_bearing(np.array(head), np.array(xy), r, direction)
    centre = reflector_centre_bearing(edge, d, r, direction)
    if d > r:
        assert valid
        true = np.arctan2(xy[1] - head[1], xy[0] - head[0]) - head[2]
        assert abs(np.angle(np.exp(1j * (centre - true)))) < 1e-9
    else:
        assert not valid and np.isnan(edge) and np.isnan(centre)


def test_centre_bearing_flags_invalid_elements():
    out = reflector_centre_bearing([0.1, 0.1, np.nan], [1.0, 0.01, 1.0], [0.04, 0.04, 0.04])
    assert np.isfinite(out[0]) and np.isnan(out[1]) and np.isnan(out[2])


# --- encoder, Reflections, bad input ---------------------------------------------------


def test_encoder_floors_to_whole_pulses():
    g = Goniometer(pulses_per_rev=1000)
    res = 2 * np.pi / 1000
    t = (np.array([3, 250, 999]) + 0.7) * res / (2 * np.pi * g.rate_hz)
    np.testing.assert_allclose(g.encoder_bearing(t), np.angle(np.exp(1j * np.array([3, 250, 999]) * res)), atol=1e-12)
    assert g.resolution == pytest.approx(res)
    assert Goniometer().resolution == pytest.approx(0.0959e-3, rel=1e-3)  # seed 000 §4.1: 0.095 mrad


def test_reflections_container():
    r = Reflections([0.0, 0.1], [0.2, 0.3], [1, -1])
    assert len(r) == 2 and r.t.dtype == np.float64 and r.reflector_index.dtype == np.int64
    with pytest.raises(ValueError, match="equal lengths"):
        Reflections([0.0, 0.1], [0.2], [1, 1])
    with pytest.raises(ValueError, match="non-decreasing"):
        Reflections([0.1, 0.0], [0.2, 0.3], [1, 1])
    assert r == Reflections([0.0, 0.1], [0.2, 0.3], [1, -1]) and r != Reflections([0.0, 0.1], [0.2, 0.3], [1, 1])
    assert len(Reflections.concatenate([])) == 0
    assert len(Reflections.concatenate([r, Reflections([0.2], [0.0], [0])])) == 3


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"rate_hz": -8.0}, "rate_hz"),
        ({"rate_hz": 0.0}, "rate_hz"),
        ({"pulses_per_rev": 0}, "pulses_per_rev"),
        ({"pulses_per_rev": 100.5}, "pulses_per_rev"),
        ({"min_range": 5.0, "max_range": 1.0}, "min_range"),
        ({"min_range": -1.0}, "min_range"),
        ({"p_miss": 1.5}, "p_miss"),
        ({"spurious_rate": -1.0}, "spurious_rate"),
        ({"jitter_std": float("nan")}, "jitter_std"),
        ({"mount": (0.0, 0.0)}, "mount"),
        ({"direction": 0}, "direction"),
    ],
)
def test_bad_parameters(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Goniometer(**kwargs)


def test_bad_scan_input():
    g, world = Goniometer(), square_world()
    with pytest.raises(ValueError, match="t1"):
        g.scan(world, static(0, 0, 0), 1.0, 0.5)
    with pytest.raises(ValueError, match="finite"):
        g.scan(world, static(0, 0, 0), 0.0, float("nan"))
    with pytest.raises(ValueError, match="shape"):
        g.scan(world, lambda t: np.zeros((len(t), 2)), 0.0, 0.1)
    with pytest.raises(ValueError, match="NaN"):
        g.scan(world, lambda t: np.full((len(t), 3), np.nan), 0.0, 0.1)
    with pytest.raises(ValueError, match="WorldMap"):
        g.scan({"reflectors": []}, static(0, 0, 0), 0.0, 0.1)
    with pytest.raises(ValueError, match="rng"):
        Goniometer(p_miss=0.1).scan(world, static(0, 0, 0), 0.0, 0.1)
    assert len(g.scan(world, static(0, 0, 0), 0.3, 0.3)) == 0
