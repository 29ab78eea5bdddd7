"""Identification of anonymous reflections: bearing model, gate, sweep labelling, start-up search."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.geometry import angle_diff, bearing_to, compose
from agvnav.positioning.bearing_gate import associate_sweep, gate_reflection
from agvnav.positioning.edge_bearing import bearing_model
from agvnav.positioning.identification import initial_pose_search
from agvnav.positioning.resection import resect_three
from agvnav.sensors.goniometer import leading_edge_bearing
from agvnav.world import Reflector, WorldMap, load_builtin_map

MOUNT = np.array([0.35, -0.05, 0.1])
SIGMA = 2 * np.pi / 65535 / np.sqrt(12)

coord = st.floats(-8.0, 8.0)
heading = st.floats(-np.pi, np.pi)


@pytest.fixture(scope="module")
def lab() -> WorldMap:
    return load_builtin_map("lab")


@given(coord, coord, heading)
def test_bearing_model_jacobian_matches_numerical(x: float, y: float, psi: float) -> None:
    xy = np.array([[10.0, 1.0], [-12.0, 3.0], [0.5, 11.0]])
    radius = np.array([0.04, 0.1, 0.0])
    pose = np.array([x, y, psi])
    _, H, _ = bearing_model(pose, MOUNT, xy, radius)
    eps = 1e-6
    for k in range(3):
        dp = np.zeros(3)
        dp[k] = eps
        num = angle_diff(bearing_model(pose + dp, MOUNT, xy, radius)[0], bearing_model(pose - dp, MOUNT, xy, radius)[0])
        np.testing.assert_allclose(num / (2 * eps), H[:, k], atol=1e-7)


def test_bearing_model_agrees_with_goniometer_edge(lab: WorldMap) -> None:
    poses = np.array([[5.0, 4.0, 0.3], [12.0, 8.0, -2.0], [17.0, 2.0, 3.0]])
    h, _, d = bearing_model(poses[:, None, :], MOUNT, lab.reflector_xy, lab.reflector_radius)
    head = compose(poses, MOUNT)
    edge, dist, _ = leading_edge_bearing(head[:, None, :], lab.reflector_xy, lab.reflector_radius)
    np.testing.assert_allclose(angle_diff(h, edge), 0.0, atol=1e-12)
    np.testing.assert_allclose(d, dist, rtol=1e-12)
    centre = bearing_to(head[:, None, :], lab.reflector_xy)
    assert np.all(angle_diff(centre, h) > 0.0)  # CCW head: the edge comes before the centre


@given(coord, coord, heading)
def test_resect_three_recovers_pose(x: float, y: float, psi: float) -> None:
    R = np.array([[12.0, 0.0], [-6.0, 11.0], [-7.0, -10.0]])
    head = np.array([x, y, psi])
    pose, valid = resect_three(R, bearing_to(head, R))
    assert valid
    np.testing.assert_allclose(pose[:2], head[:2], atol=1e-7)
    assert abs(angle_diff(pose[2], psi)) < 1e-8


def test_resect_three_flags_critical_circle() -> None:
    R = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])
    head = np.array([0.0, -1.0, 0.4])  # on the circle through the three reflectors
    _, valid = resect_three(R, bearing_to(head, R))
    assert not valid


def test_gate_accepts_true_reflector_and_rejects_spurious(lab: WorldMap) -> None:
    pose = np.array([8.0, 3.0, 0.5])
    P = np.diag([0.02, 0.02, 0.005]) ** 2
    h, _, _ = bearing_model(pose, MOUNT, lab.reflector_xy, lab.reflector_radius)
    for j in range(len(h)):
        a = gate_reflection(h[j] + 1e-4, pose, P, MOUNT, lab.reflector_xy, lab.reflector_radius, SIGMA**2)
        assert a.index == j
    spurious = float(np.mean(np.sort(h)[:2]))  # half-way between two reflectors
    assert gate_reflection(spurious, pose, P, MOUNT, lab.reflector_xy, lab.reflector_radius, SIGMA**2).index == -1
    excluded = np.zeros(len(h), dtype=bool)
    excluded[2] = True
    a = gate_reflection(h[2], pose, P, MOUNT, lab.reflector_xy, lab.reflector_radius, SIGMA**2, excluded=excluded)
    assert a.index == -1


def test_gate_rejects_when_two_reflectors_fit() -> None:
    world = WorldMap((Reflector("A", 10.0, 0.0), Reflector("B", 10.0, 0.05)))
    pose = np.zeros(3)
    P = np.diag([0.1, 0.1, 0.05]) ** 2
    a = gate_reflection(0.0025, pose, P, np.zeros(3), world.reflector_xy, world.reflector_radius, SIGMA**2)
    assert a.index == -1 and a.n_in_gate == 2


def test_sweep_labels_correct_under_spurious_and_unique(lab: WorldMap) -> None:
    rng = np.random.default_rng(3)
    pose = np.array([6.0, 5.0, -1.0])
    P = np.diag([0.03, 0.03, 0.01]) ** 2
    h, _, _ = bearing_model(pose, MOUNT, lab.reflector_xy, lab.reflector_radius)
    true = rng.permutation(len(h))
    z = h[true] + rng.normal(0.0, SIGMA, len(h))
    spurious = rng.uniform(-np.pi, np.pi, 30)
    zs = np.concatenate([z, spurious, [h[4] + 3e-4]])  # last: a second reflection at reflector 4
    labels = associate_sweep(zs, pose, P, MOUNT, lab.reflector_xy, lab.reflector_radius, SIGMA**2)
    np.testing.assert_array_equal(labels[: len(h)], true)
    claimed = labels[labels >= 0]
    assert len(claimed) == len(set(claimed.tolist()))  # no reflector claimed twice
    # a spurious bearing only gets a label if it lands in a free gate: none is free here
    assert np.all(labels[len(h) :] == -1)


def test_initial_search_finds_pose_despite_spurious(lab: WorldMap) -> None:
    rng = np.random.default_rng(7)
    pose = np.array([13.0, 3.5, 2.2])
    h, _, _ = bearing_model(pose, MOUNT, lab.reflector_xy, lab.reflector_radius)
    z = h + rng.normal(0.0, SIGMA, h.shape)
    spurious = rng.uniform(-np.pi, np.pi, 4)
    res = initial_pose_search(np.concatenate([z, spurious]), lab.reflector_xy, lab.reflector_radius, MOUNT, SIGMA)
    assert res.found and not res.ambiguous
    assert np.hypot(*(res.pose[:2] - pose[:2])) < 2e-3
    assert abs(angle_diff(res.pose[2], pose[2])) < 1e-3
    np.testing.assert_array_equal(res.labels[: len(h)], np.arange(len(h)))
    assert np.all(res.labels[len(h) :] == -1)
    assert res.n_explained == len(h)


def test_initial_search_reports_ambiguity_on_symmetric_layout() -> None:
    square = WorldMap(
        tuple(Reflector(f"S{i}", 5 * np.cos(a), 5 * np.sin(a), 0.04) for i, a in enumerate(np.arange(4) * np.pi / 2))
    )
    pose = np.array([1.0, 0.5, 0.3])
    h, _, _ = bearing_model(pose, MOUNT, square.reflector_xy, square.reflector_radius)
    res = initial_pose_search(h, square.reflector_xy, square.reflector_radius, MOUNT, SIGMA)
    assert res.ambiguous and not res.found
    assert len(res.alternatives) == 4
    # the four poses are the true one rotated by multiples of 90 degrees about the centre
    dist = np.hypot(res.alternatives[:, 0], res.alternatives[:, 1])
    np.testing.assert_allclose(dist, np.hypot(1.0, 0.5), atol=1e-6)
    assert np.any(np.hypot(*(res.alternatives[:, :2] - pose[:2]).T) < 1e-6)


def test_initial_search_without_enough_reflections(lab: WorldMap) -> None:
    res = initial_pose_search([0.1, 1.0], lab.reflector_xy, lab.reflector_radius, MOUNT, SIGMA)
    assert not res.found and res.n_explained == 0 and np.all(np.isnan(res.pose))
