"""World map: construction, arrays, YAML round trip, validation messages, shipped maps."""

import re
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st

from agvnav.world import (
    Reflector,
    Wall,
    WorldMap,
    builtin_map,
    builtin_map_names,
    load_builtin_map,
    load_map,
    save_map,
)

ARCH_YAML = """\
reflectors:
  - {id: R1, x: 0.0, y: 5.0, radius: 0.04}
walls:
  - {id: W1, points: [[0, 0], [10, 0]]}
  - {id: pillar, points: [[2, 2], [2.4, 2], [2.4, 2.4], [2, 2.4]], closed: true}
"""


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "map.yaml"
    path.write_text(text)
    return path


def test_architecture_example_loads_with_expected_arrays(tmp_path):
    world = load_map(_write(tmp_path, ARCH_YAML))
    assert world.reflector_ids == ("R1",)
    np.testing.assert_array_equal(world.reflector_xy, [[0.0, 5.0]])
    np.testing.assert_array_equal(world.reflector_radius, [0.04])
    assert world.wall_segments.shape == (1 + 4, 2, 2)
    np.testing.assert_array_equal(world.wall_segments[0], [[0, 0], [10, 0]])
    # the closed pillar ends with the segment back to its first point
    np.testing.assert_array_equal(world.wall_segments[-1], [[2, 2.4], [2, 2]])
    assert world.reflector_index("R1") == 0


def test_arrays_are_read_only_and_empty_map_has_right_shapes():
    world = WorldMap()
    assert world.reflector_xy.shape == (0, 2)
    assert world.reflector_radius.shape == (0,)
    assert world.wall_segments.shape == (0, 2, 2)
    world = WorldMap([Reflector("A", 1, 2)], [Wall("w", [[0, 0], [1, 0]])])
    with pytest.raises(ValueError):
        world.reflector_xy[0, 0] = 5.0
    with pytest.raises(ValueError):
        world.wall_segments[0, 0, 0] = 5.0


def test_save_load_round_trip_is_exact(tmp_path):
    world = WorldMap(
        [Reflector("R1", 0.1 + 0.2, -3.0, 0.04), Reflector("7", 1e-9, 1e6)],
        [Wall("W", [[0, 0], [1 / 3, 0], [1 / 3, 2]]), Wall("P", [[5, 5], [6, 5], [6, 6]], closed=True)],
    )
    path = tmp_path / "out.yaml"
    save_map(world, path)
    again = load_map(path)
    assert again == world
    np.testing.assert_array_equal(again.reflector_xy, world.reflector_xy)
    np.testing.assert_array_equal(again.wall_segments, world.wall_segments)


finite = st.floats(-1e4, 1e4, allow_nan=False)


@st.composite
def maps(draw):
    n = draw(st.integers(0, 6))
    reflectors = [
        Reflector(f"R{i}", draw(finite), draw(finite), draw(st.floats(0, 1))) for i in range(n)
    ]
    walls = []
    for j in range(draw(st.integers(0, 3))):
        closed = draw(st.booleans())
        k = draw(st.integers(3 if closed else 2, 5))
        steps = [[abs(draw(finite)) + 0.1, draw(finite)] for _ in range(k)]  # x strictly increases
        pts = np.cumsum(steps, axis=0)
        walls.append(Wall(f"W{j}", pts, closed=closed))
    return WorldMap(reflectors, walls)


@given(maps())
def test_dict_round_trip_property(world):
    assert WorldMap.from_dict(world.to_dict()) == world


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            ("reflectors:\n  - {id: R1, x: 0, y: 0}\n  - {id: R2, x: 1, y: 0}\n  - {id: R3, x: 2, y: 0}\n"
            "  - {id: R4, x: 3, y: 0, radius: -0.1}\n"),
            "reflectors[3] (id 'R4'): radius must be >= 0",
        ),
        ("reflectors:\n  - {id: A, x: 0, y: 0}\n  - {id: A, x: 1, y: 0}\n", "reflectors[1] (id 'A'): duplicate id"),
        ("reflectors:\n  - {id: A, x: .nan, y: 0}\n", "reflectors[0] (id 'A'): x must be finite"),
        ("reflectors:\n  - {id: A, x: 0, y: .inf}\n", "reflectors[0] (id 'A'): y must be finite"),
        ("reflectors:\n  - {id: A, x: '3', y: 0}\n", "reflectors[0] (id 'A'): x must be a number"),
        ("reflectors:\n  - {id: A, x: 0}\n", "reflectors[0] (id 'A'): missing key(s) ['y']"),
        ("reflectors:\n  - {id: A, x: 0, y: 0, colour: red}\n", "reflectors[0] (id 'A'): unknown key(s) ['colour']"),
        ("reflectors:\n  - {x: 0, y: 0}\n", "reflectors[0]: missing key(s) ['id']"),
        ("reflectors:\n  - {id: '', x: 0, y: 0}\n", "id must be a non-empty string"),
        ("walls:\n  - {id: W, points: [[0, 0]]}\n", "walls[0] (id 'W'): points: a wall needs at least 2 points"),
        ("walls:\n  - {id: W, points: [[0, 0], [1, 0]], closed: true}\n", "walls[0] (id 'W'): points: a closed wall"),
        ("walls:\n  - {id: W, points: [[0, 0], [0, 0]]}\n", "walls[0] (id 'W'): points: segment 0 has zero length"),
        ("walls:\n  - {id: W, points: [[0, 0], [1, .nan]]}\n", "walls[0] (id 'W'): points[1].y must be finite"),
        ("walls:\n  - {id: W, points: [[0, 0], [1, 2, 3]]}\n", "walls[0] (id 'W'): points[1] must be a pair"),
        ("walls:\n  - {id: W, points: [[0, 0], [1, 0]]}\n  - {id: W, points: [[0, 1], [1, 1]]}\n",
         "walls[1] (id 'W'): duplicate id"),
        ("walls:\n  - {id: W, points: [[0, 0], [1, 0]], closed: maybe}\n", "closed must be true or false"),
        ("reflectors: []\nlandmarks: []\n", "map: unknown key(s) ['landmarks']"),
        ("reflectors: {id: A}\n", "reflectors must be a list"),
        ("reflectors: 0\n", "reflectors must be a list"),
        ("- 1\n- 2\n", "a map must be a mapping"),
    ],
)
def test_validation_errors_name_the_offending_entry(tmp_path, text, message):
    path = _write(tmp_path, text)
    with pytest.raises(ValueError, match=re.escape(message)) as info:
        load_map(path)
    assert str(path) in str(info.value)


def test_bad_yaml_empty_file_and_missing_file(tmp_path):
    with pytest.raises(ValueError, match="not valid YAML"):
        load_map(_write(tmp_path, "reflectors: [\n"))
    with pytest.raises(ValueError, match="empty"):
        load_map(_write(tmp_path, ""))
    with pytest.raises(OSError):
        load_map(tmp_path / "nope.yaml")


def test_constructor_validation():
    with pytest.raises(ValueError, match="radius must be >= 0"):
        Reflector("A", 0, 0, -1)
    with pytest.raises(ValueError, match="x must be finite"):
        Reflector("A", np.inf, 0)
    with pytest.raises(ValueError, match="shape"):
        Wall("W", [0, 1, 2])
    with pytest.raises(ValueError, match=r"reflectors\[1\] \(id 'A'\): duplicate id"):
        WorldMap([Reflector("A", 0, 0), Reflector("A", 1, 1)])
    with pytest.raises(ValueError, match=r"walls\[0\] must be a Wall"):
        WorldMap([], [[[0, 0], [1, 1]]])
    with pytest.raises(ValueError, match="unknown reflector id 'Z'"):
        WorldMap([Reflector("A", 0, 0)]).reflector_index("Z")
    with pytest.raises(ValueError, match="must be a WorldMap"):
        save_map({"reflectors": []}, "x.yaml")


def test_empty_sections_are_empty_lists():
    world = WorldMap.from_dict({"reflectors": None, "walls": []})
    assert len(world.reflectors) == 0 and len(world.walls) == 0


def test_integer_ids_are_accepted_as_strings():
    world = WorldMap.from_dict({"reflectors": [{"id": 3, "x": 0, "y": 0}]})
    assert world.reflector_ids == ("3",)


def test_shipped_lab_map_is_plausible():
    assert "lab" in builtin_map_names()
    path = builtin_map("lab")
    assert path.is_file()
    assert "illustrative" in path.read_text().lower()
    world = load_builtin_map("lab")
    assert 6 <= len(world.reflectors) <= 10
    assert np.all(world.reflector_radius > 0.0)
    seg = world.wall_segments.reshape(-1, 2)
    size = seg.max(axis=0) - seg.min(axis=0)
    np.testing.assert_allclose(size, [20.0, 12.0], atol=1.0)
    # every reflector cylinder is inside the lab and clear of every wall and pillar
    outer = shapely.Polygon(world.walls[0].points)
    obstacles = shapely.unary_union([shapely.Polygon(w.points) for w in world.walls[1:] if w.closed])
    for (x, y), r in zip(world.reflector_xy, world.reflector_radius, strict=True):
        disc = shapely.Point(x, y).buffer(r)
        assert outer.contains(disc)
        assert not disc.intersects(obstacles)
        assert disc.distance(obstacles.union(outer.exterior)) < 0.1  # mounted on a wall or pillar


def test_unknown_builtin_map():
    with pytest.raises(ValueError, match=r"unknown built-in map 'moon'.*lab"):
        builtin_map("moon")
