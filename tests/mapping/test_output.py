"""mapping.output: the map's survey_std_m is each reflector's frame-free error; the frame's is stated apart."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from agvnav.mapping import frame_free_covariance, result_to_map, write_map
from agvnav.mapping.anchors import apply_similarity
from agvnav.mapping.output import frame_std
from agvnav.mapping.slam import MappingResult
from agvnav.world import load_map

XY = np.array([[0.0, 0.0], [10.0, -1.0], [11.0, 8.0], [4.0, 10.0], [-2.0, 6.0], [6.0, 4.5]])


def _shared_frame_covariance(own: float, shift: float, rot: float, scale: float) -> np.ndarray:
    """Joint covariance of reflectors with independent errors ``own`` (m per axis) plus one frame error shared
    by all: a shift (m per axis), a rotation (rad) and a scale (relative) about the centroid."""
    G = _similarity_basis()
    return np.eye(G.shape[0]) * own ** 2 + G @ np.diag([shift ** 2, shift ** 2, rot ** 2, scale ** 2]) @ G.T


def _similarity_basis() -> np.ndarray:
    """``(2N, 4)``: the map's displacement per unit shift (x, y), rotation and scale about the centroid."""
    n = XY.shape[0]
    c = XY - XY.mean(axis=0)
    G = np.zeros((2 * n, 4))
    G[0::2, 0], G[1::2, 1] = 1.0, 1.0
    G[0::2, 2], G[1::2, 2] = -c[:, 1], c[:, 0]
    G[0::2, 3], G[1::2, 3] = c[:, 0], c[:, 1]
    return G


def _result(joint: np.ndarray) -> MappingResult:
    n = XY.shape[0]
    cov = np.array([joint[2 * j:2 * j + 2, 2 * j:2 * j + 2] for j in range(n)])
    return MappingResult(tuple(f"M{j + 1}" for j in range(n)), XY.copy(), cov, np.full(n, 50), np.zeros((1, 3)),
                         np.zeros(1), 1.0, 1e-4, "surveyed2", 300, 300, 1.0, 0.1, joint_covariance=joint)


def test_a_frame_error_shared_by_all_reflectors_is_not_their_survey_std() -> None:
    """A 2 mm shift and 0.1 mrad rotation shared by every reflector, 0.2 mm each of their own: survey_std_m is the
    own error (less the share the frame fit absorbs), not the 2-3 mm of the marginal covariance, which
    covariance_m2 keeps; a map without the shared error gives the same survey_std_m."""
    joint = _shared_frame_covariance(2e-4, 2e-3, 1e-4, 1e-4)
    world = result_to_map(_result(joint))
    own_only = result_to_map(_result(_shared_frame_covariance(2e-4, 0.0, 0.0, 0.0)))
    marginal = np.sqrt([0.5 * np.trace(joint[2 * j:2 * j + 2, 2 * j:2 * j + 2]) for j in range(XY.shape[0])])
    assert np.all(marginal > 2e-3)
    # the frame fit takes 4 of the 12 dof: each reflector keeps sqrt(1 - leverage) of its own std
    assert np.all(world.reflector_survey_std < 2e-4) and np.all(world.reflector_survey_std > 0.5 * 2e-4)
    np.testing.assert_allclose(world.reflector_survey_std, own_only.reflector_survey_std, rtol=1e-9)
    for r, j in zip(world.reflectors, range(XY.shape[0]), strict=True):
        assert r.covariance_m2 is not None
        np.testing.assert_allclose(np.array(r.covariance_m2), joint[2 * j:2 * j + 2, 2 * j:2 * j + 2], rtol=1e-12,
                                   atol=1e-18)


def test_frame_free_covariance_is_invariant_to_the_frame_and_matches_a_monte_carlo() -> None:
    """Draws of the joint covariance, each moved back by the similarity fitted onto the mean map: their
    scatter is the frame-free covariance (Baarda's S-transform); frame_std recovers the shared frame."""
    joint = _shared_frame_covariance(3e-4, 1e-3, 2e-4, 5e-5)
    free = frame_free_covariance(XY, joint)
    rng = np.random.default_rng(3)
    L = np.linalg.cholesky(joint)
    n = XY.shape[0]
    c = XY - XY.mean(axis=0)
    G = _similarity_basis()
    e = (L @ rng.normal(size=(2 * n, 20000))).T
    resid = e - (G @ np.linalg.lstsq(G, e.T, rcond=None)[0]).T
    mc = resid.T @ resid / e.shape[0]
    np.testing.assert_allclose(np.diag(free), np.diag(mc), rtol=0.05)
    f = frame_std(XY, joint)
    assert f["shift_m"] == pytest.approx(math.hypot(1e-3, 3e-4 / math.sqrt(n)), rel=1e-6)
    assert f["rotation_rad"] == pytest.approx(math.hypot(2e-4, 3e-4 / math.sqrt(np.sum(c ** 2))), rel=1e-6)
    # an exactly moved map has the same frame-free covariance (the S-transform is about the map's own shape)
    moved = apply_similarity(np.array([math.cos(0.3), math.sin(0.3), 5.0, -2.0]), XY)
    R = np.kron(np.eye(n), np.array([[math.cos(0.3), -math.sin(0.3)], [math.sin(0.3), math.cos(0.3)]]))
    np.testing.assert_allclose(frame_free_covariance(moved, R @ joint @ R.T), R @ free @ R.T, atol=1e-15)
    with pytest.raises(ValueError, match="joint covariance"):
        frame_free_covariance(XY, joint[:4, :4])
    # two reflectors: the frame takes every dof, the covariance is returned as it is
    np.testing.assert_array_equal(frame_free_covariance(XY[:2], joint[:4, :4]), joint[:4, :4])


def test_written_map_states_the_frame_std(tmp_path: Path) -> None:
    joint = _shared_frame_covariance(2e-4, 2e-3, 1e-4, 1e-4)
    path = tmp_path / "m.yaml"
    write_map(_result(joint), path)
    text = path.read_text(encoding="utf-8")
    assert "frame std" in text and "shift 2.0" in text
    loaded = load_map(path)
    np.testing.assert_allclose(loaded.reflector_survey_std, result_to_map(_result(joint)).reflector_survey_std,
                               rtol=1e-6)
