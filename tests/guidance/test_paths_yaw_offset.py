"""Per-segment yaw_offset of paths (heading minus tangent for holonomic vehicles)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.guidance import ArcSegment, LineSegment, Path, load_path, path_from_moves, save_path


def test_yaw_offset_defaults_to_zero_and_is_not_written():
    path = path_from_moves((0.0, 0.0, 0.0), [("line", 1.0), ("arc", 1.0, 1.0)])
    np.testing.assert_array_equal(path.yaw_offset_at([0.0, 0.5, 1.5, 99.0]), 0.0)
    assert all("yaw_offset_deg" not in seg for seg in path.to_dict()["segments"])


def test_yaw_offset_per_segment_round_trips_through_dict_and_yaml(tmp_path):
    moves = [("line", 1.0, 1, math.pi / 2), ("arc", 2.0, -0.5, -1, -0.25), ("line", 1.0)]
    path = path_from_moves((1.0, 2.0, 0.3), moves)
    np.testing.assert_allclose(path.yaw_offset_at([0.5, 1.5, 2.5]), [math.pi / 2, -0.25, 0.0])
    assert path.yaw_offset_at(1.0) == pytest.approx(-0.25)  # a joint belongs to the next segment
    d = path.to_dict()
    assert d["segments"][0]["yaw_offset_deg"] == pytest.approx(90.0)
    assert "yaw_offset_deg" not in d["segments"][2]
    again = Path.from_dict(d)
    yaw = [s.yaw_offset for s in path.segments]
    np.testing.assert_allclose([s.yaw_offset for s in again.segments], yaw, atol=1e-15)
    save_path(path, tmp_path / "p.yaml")
    loaded = load_path(tmp_path / "p.yaml")
    np.testing.assert_allclose(loaded.yaw_offset_at([0.5, 1.5, 2.5]), path.yaw_offset_at([0.5, 1.5, 2.5]), atol=1e-15)


def test_yaw_offset_is_wrapped_and_must_be_finite():
    assert LineSegment(np.zeros(2), 0.0, 1.0, 1, 3 * math.pi / 2).yaw_offset == pytest.approx(-math.pi / 2)
    assert ArcSegment(np.zeros(2), 0.0, 1.0, 1.0, 1, math.pi).yaw_offset == pytest.approx(-math.pi)  # [-pi, pi)
    with pytest.raises(ValueError, match="yaw_offset"):
        LineSegment(np.zeros(2), 0.0, 1.0, 1, math.nan)


def test_bad_yaw_offset_deg_names_the_key():
    segment = {"type": "line", "length": 1, "yaw_offset_deg": "left"}
    data = {"start": {"x": 0, "y": 0, "heading_deg": 0}, "segments": [segment]}
    with pytest.raises(ValueError, match=r"path\.segments\[0\]\.yaw_offset_deg: expected a number"):
        Path.from_dict(data)


def test_path_from_moves_refuses_extra_values():
    with pytest.raises(ValueError, match="move 0: too many values"):
        path_from_moves((0.0, 0.0, 0.0), [("line", 1.0, 1, 0.0, 5)])
    with pytest.raises(ValueError, match="move 0: unknown move kind 'spiral'"):
        path_from_moves((0.0, 0.0, 0.0), [("spiral", 1.0, 1, 0.0, 5, 6)])
