"""Reflector and wall maps of the workspace, and their YAML form.

The laser positioning system of seed 000 (§2.1, §4.1, Fig. 6b) needs the
surveyed positions of its cylindrical reflectors; walls, pillars and racks
block the beam. A map is a list of :class:`Reflector` and a list of
:class:`Wall` (open polylines or closed polygons), all in the ``map`` frame
(REP-105), metres. YAML form (see docs/ARCHITECTURE.md)::

    reflectors:
      - {id: R1, x: 0.0, y: 5.0, radius: 0.04}
      - {id: R2, x: 8.0, y: 5.0, radius: 0.04, survey_std_m: 0.005}
    walls:
      - {id: W1, points: [[0, 0], [10, 0]]}
      - {id: pillar, points: [[2, 2], [2.4, 2], [2.4, 2.4], [2, 2.4]], closed: true}

Every validation error names the offending entry, e.g.
``reflectors[3] (id 'R4'): radius must be >= 0, got -0.1``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import ArrayLike, NDArray

from agvnav.world.strict import check_document_size, read_document_text, resolve_document
from agvnav.world.yaml_strict import safe_load_unique, yaml_error_line

__all__ = ["Reflector", "Wall", "WorldMap", "load_map", "save_map"]

_REFLECTOR_KEYS = ("id", "x", "y", "radius", "survey_std_m", "covariance_m2")
_WALL_KEYS = ("id", "points", "closed")
_MAP_KEYS = ("reflectors", "walls", "docking_targets")  # docking targets: agvnav.world.docking


def _check_id(value: Any) -> str:
    """Ids are non-empty strings; YAML integers (``id: 3``) are accepted as ``"3"``."""
    if isinstance(value, bool) or not isinstance(value, (str, int)):
        raise ValueError(f"id must be a string, got {value!r}")
    text = str(value)
    if not text.strip():
        raise ValueError("id must be a non-empty string")
    return text


def _check_coordinate(name: str, value: Any) -> float:
    """A finite real number (bool and strings are refused: they are YAML typos)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v


@dataclass(frozen=True)
class Reflector:
    """A cylindrical reflector (seed 000 §2.1): centre ``(x, y)`` in ``map`` (m), ``radius`` (m).

    ``radius = 0`` is a point reflector. The goniometer reports the start of the
    reflection, i.e. the tangent edge of the cylinder, not its centre.
    ``survey_std_m`` (m, per axis) is the uncertainty of the surveyed centre (issue 12);
    0 means "not stated" (the estimator's global ``map_std`` applies).
    ``covariance_m2`` (m², optional): the full 2x2 covariance ``((xx, xy), (xy, yy))`` of the
    centre, as a mapping drive estimates it (issue 17, :mod:`agvnav.mapping`); None when not stated.
    """

    id: str
    x: float
    y: float
    radius: float = 0.0
    survey_std_m: float = 0.0
    covariance_m2: tuple[tuple[float, float], tuple[float, float]] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "id", _check_id(self.id))
        if self.covariance_m2 is not None:
            object.__setattr__(self, "covariance_m2", _check_covariance(self.covariance_m2))
        std = _check_coordinate("survey_std_m", self.survey_std_m)
        if std < 0.0:
            raise ValueError(f"survey_std_m must be >= 0, got {self.survey_std_m!r}")
        object.__setattr__(self, "survey_std_m", std)
        object.__setattr__(self, "x", _check_coordinate("x", self.x))
        object.__setattr__(self, "y", _check_coordinate("y", self.y))
        r = _check_coordinate("radius", self.radius)
        if r < 0.0:
            raise ValueError(f"radius must be >= 0, got {self.radius!r}")
        object.__setattr__(self, "radius", r)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict in the YAML form ``{id, x, y, radius}`` (and ``survey_std_m`` when stated)."""
        out: dict[str, Any] = {"id": self.id, "x": self.x, "y": self.y, "radius": self.radius}
        if self.survey_std_m > 0.0:
            out["survey_std_m"] = self.survey_std_m
        if self.covariance_m2 is not None:
            out["covariance_m2"] = [list(row) for row in self.covariance_m2]
        return out


def _check_covariance(value: Any) -> tuple[tuple[float, float], tuple[float, float]]:
    """A symmetric positive semi-definite 2x2 covariance (m²) as nested tuples, else ValueError."""
    try:
        c = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"covariance_m2 must be [[xx, xy], [xy, yy]], got {value!r}") from None
    if c.shape != (2, 2) or not np.all(np.isfinite(c)):
        raise ValueError(f"covariance_m2 must be a finite [[xx, xy], [xy, yy]], got {value!r}")
    if c[0, 1] != c[1, 0] or c[0, 0] < 0.0 or c[1, 1] < 0.0 or c[0, 0] * c[1, 1] < c[0, 1] ** 2:
        raise ValueError(f"covariance_m2 must be symmetric positive semi-definite, got {value!r}")
    return ((float(c[0, 0]), float(c[0, 1])), (float(c[1, 0]), float(c[1, 1])))


@dataclass(frozen=True, eq=False)
class Wall:
    """An obstacle that blocks the beam: a polyline through ``points (k, 2)`` (m, ``map``).

    ``closed=True`` joins the last point back to the first (a polygon such as a
    pillar; at least 3 points). Every segment must have non-zero length.
    """

    id: str
    points: NDArray[np.float64]
    closed: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "id", _check_id(self.id))
        if not isinstance(self.closed, (bool, np.bool_)):
            raise ValueError(f"closed must be true or false, got {self.closed!r}")
        object.__setattr__(self, "closed", bool(self.closed))
        pts = _as_points(self.points)
        need = 3 if self.closed else 2
        if pts.shape[0] < need:
            kind = "a closed wall" if self.closed else "a wall"
            raise ValueError(f"points: {kind} needs at least {need} points, got {pts.shape[0]}")
        pts.setflags(write=False)
        object.__setattr__(self, "points", pts)
        seg = self.segments
        lengths = np.hypot(*(seg[:, 1] - seg[:, 0]).T)
        if np.any(lengths <= 0.0):
            i = int(np.argmax(lengths <= 0.0))
            raise ValueError(f"points: segment {i} has zero length (repeated point {seg[i, 0].tolist()})")

    @property
    def segments(self) -> NDArray[np.float64]:
        """Line segments ``(m, 2, 2)``: ``[[x0, y0], [x1, y1]]`` per segment."""
        pts = self.points
        ends = np.roll(pts, -1, axis=0) if self.closed else pts[1:]
        starts = pts if self.closed else pts[:-1]
        return np.stack([starts, ends], axis=1)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict in the YAML form ``{id, points, closed}``."""
        out: dict[str, Any] = {"id": self.id, "points": self.points.tolist()}
        if self.closed:
            out["closed"] = True
        return out

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Wall):
            return NotImplemented
        return (
            self.id == other.id
            and self.closed == other.closed
            and self.points.shape == other.points.shape
            and bool(np.all(self.points == other.points))
        )

    __hash__ = None  # type: ignore[assignment]


def _as_points(points: ArrayLike) -> NDArray[np.float64]:
    """``points`` as a finite float ``(k, 2)`` array, else ValueError naming the problem."""
    if isinstance(points, (str, bytes)):
        raise ValueError(f"points must be a list of [x, y] pairs, got {points!r}")
    try:
        pts = np.array(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"points must be a list of [x, y] pairs, got {points!r}") from None
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ValueError(f"points must be a list of [x, y] pairs, got shape {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise ValueError("points must be finite (NaN or inf found)")
    return pts


@dataclass(frozen=True)
class WorldMap:
    """Reflectors and walls of one workspace, with array views for the vectorised kernels.

    Attributes
    ----------
    reflectors, walls:
        Tuples of :class:`Reflector` / :class:`Wall`; ids are unique within each list.
    reflector_xy:
        ``(N, 2)`` reflector centres (m), read-only.
    reflector_radius:
        ``(N,)`` reflector radii (m), read-only.
    reflector_ids:
        ``(N,)`` tuple of ids, in the same order.
    reflector_survey_std:
        ``(N,)`` survey std of each reflector centre (m, per axis; 0: not stated), read-only.
    wall_segments:
        ``(M, 2, 2)`` every wall segment, read-only.
    """

    reflectors: tuple[Reflector, ...] = ()
    walls: tuple[Wall, ...] = ()
    reflector_xy: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    reflector_radius: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    reflector_ids: tuple[str, ...] = field(init=False, repr=False, compare=False)
    reflector_survey_std: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    wall_segments: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        refl = tuple(self.reflectors)
        walls = tuple(self.walls)
        for kind, items, cls in (("reflectors", refl, Reflector), ("walls", walls, Wall)):
            for i, item in enumerate(items):
                if not isinstance(item, cls):
                    raise ValueError(f"{kind}[{i}] must be a {cls.__name__}, got {type(item).__name__}")
            _check_unique(kind, [item.id for item in items])
        object.__setattr__(self, "reflectors", refl)
        object.__setattr__(self, "walls", walls)
        xy = np.array([[r.x, r.y] for r in refl], dtype=np.float64).reshape(-1, 2)
        radius = np.array([r.radius for r in refl], dtype=np.float64)
        survey = np.array([r.survey_std_m for r in refl], dtype=np.float64)
        survey.setflags(write=False)
        object.__setattr__(self, "reflector_survey_std", survey)
        segs = [w.segments for w in walls]
        wall_segments = np.concatenate(segs, axis=0) if segs else np.zeros((0, 2, 2))
        for arr in (xy, radius, wall_segments):
            arr.setflags(write=False)
        object.__setattr__(self, "reflector_xy", xy)
        object.__setattr__(self, "reflector_radius", radius)
        object.__setattr__(self, "reflector_ids", tuple(r.id for r in refl))
        object.__setattr__(self, "wall_segments", wall_segments)

    def reflector_index(self, reflector_id: str) -> int:
        """Row of reflector ``reflector_id`` in :attr:`reflector_xy`; ValueError if unknown."""
        try:
            return self.reflector_ids.index(str(reflector_id))
        except ValueError:
            raise ValueError(f"unknown reflector id {reflector_id!r}") from None

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> WorldMap:
        """Build and validate a map from its YAML-shaped dict (``reflectors``, ``walls``)."""
        if not isinstance(data, Mapping):
            raise ValueError(f"a map must be a mapping with keys {list(_MAP_KEYS)}, got {type(data).__name__}")
        _check_keys(data, _MAP_KEYS, "map")
        reflectors = _entries(data, "reflectors", _reflector_from_dict)
        walls = _entries(data, "walls", _wall_from_dict)
        return cls(tuple(reflectors), tuple(walls))

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (YAML form); ``WorldMap.from_dict(m.to_dict()) == m``."""
        return {
            "reflectors": [r.to_dict() for r in self.reflectors],
            "walls": [w.to_dict() for w in self.walls],
        }


def _check_unique(kind: str, ids: Sequence[str]) -> None:
    seen: dict[str, int] = {}
    for i, ident in enumerate(ids):
        if ident in seen:
            raise ValueError(f"{kind}[{i}] (id {ident!r}): duplicate id, first used by {kind}[{seen[ident]}]")
        seen[ident] = i


def _check_keys(entry: Mapping[str, Any], allowed: Sequence[str], where: str = "") -> None:
    unknown = [str(k) for k in entry if k not in allowed]
    if unknown:
        prefix = f"{where}: " if where else ""
        raise ValueError(f"{prefix}unknown key(s) {unknown}; allowed keys are {list(allowed)}")


def _entries(data: Mapping[str, Any], kind: str, build: Any) -> list[Any]:
    """Build every entry of list ``data[kind]``, prefixing errors with ``kind[i] (id ...)``."""
    items = data.get(kind)
    items = [] if items is None else items  # `walls:` with nothing after it is an empty list
    if not isinstance(items, list):
        raise ValueError(f"{kind} must be a list, got {type(items).__name__}")
    out = []
    for i, entry in enumerate(items):
        where = f"{kind}[{i}]"
        if isinstance(entry, Mapping) and "id" in entry:
            where += f" (id {entry['id']!r})"
        try:
            out.append(build(entry))
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
    return out


def _reflector_from_dict(entry: Any) -> Reflector:
    if not isinstance(entry, Mapping):
        raise ValueError(f"must be a mapping {{id, x, y, radius}}, got {entry!r}")
    _check_keys(entry, _REFLECTOR_KEYS)
    missing = [k for k in ("id", "x", "y") if k not in entry]
    if missing:
        raise ValueError(f"missing key(s) {missing}")
    return Reflector(entry["id"], entry["x"], entry["y"], entry.get("radius", 0.0), entry.get("survey_std_m", 0.0),
                     entry.get("covariance_m2"))


def _wall_from_dict(entry: Any) -> Wall:
    if not isinstance(entry, Mapping):
        raise ValueError(f"must be a mapping {{id, points, closed}}, got {entry!r}")
    _check_keys(entry, _WALL_KEYS)
    missing = [k for k in ("id", "points") if k not in entry]
    if missing:
        raise ValueError(f"missing key(s) {missing}")
    points = entry["points"]
    if isinstance(points, list):
        for j, p in enumerate(points):
            if not isinstance(p, list) or len(p) != 2:
                raise ValueError(f"points[{j}] must be a pair [x, y], got {p!r}")
            for axis, v in zip("xy", p, strict=True):
                _check_coordinate(f"points[{j}].{axis}", v)
    return Wall(entry["id"], points, entry.get("closed", False))


def load_map(path: str | Path) -> WorldMap:
    """Read and validate a YAML map file, or a shipped map by name (``"lab"``, ``"hall"``).

    A bare name that is not a local file is looked up in ``agvnav/data/maps``. Every
    problem is a ValueError naming the file (a missing, unreadable or binary file
    too) and, for a bad entry, the entry.
    """
    path = resolve_document(path, _maps_dir(), "map")
    text = read_document_text(path, "map")
    check_document_size(text, str(path), "map")
    try:
        data = safe_load_unique(text)
    except yaml.YAMLError as exc:
        line = yaml_error_line(exc)
        where = f"line {line}: " if line is not None else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise ValueError(" ".join(f"{path}: {where}not valid YAML: {problem}".split())) from None
    if data is None:
        raise ValueError(f"{path}: the map file is empty")
    try:
        return WorldMap.from_dict(data)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def _maps_dir() -> Path:
    """The folder of the shipped maps (``agvnav/data/maps``)."""
    return Path(str(resources.files("agvnav") / "data" / "maps"))


def save_map(world: WorldMap, path: str | Path) -> None:
    """Write ``world`` as YAML (one flow-style line per entry); floats round-trip exactly."""
    if not isinstance(world, WorldMap):
        raise ValueError(f"world must be a WorldMap, got {type(world).__name__}")
    lines = ["reflectors:"] if world.reflectors else ["reflectors: []"]
    lines += [f"  - {_flow(r.to_dict())}" for r in world.reflectors]
    lines += ["walls:"] if world.walls else ["walls: []"]
    lines += [f"  - {_flow(w.to_dict())}" for w in world.walls]
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def _flow(entry: dict[str, Any]) -> str:
    text = yaml.safe_dump(entry, default_flow_style=True, sort_keys=False, width=math.inf)
    return text.strip()
