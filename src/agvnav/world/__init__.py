"""The world: reflector and wall maps (seed 000 §2.1, Fig. 6b), and the maps shipped with agvnav."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from agvnav.world.map import Reflector, Wall, WorldMap, load_map, save_map

__all__ = [
    "Reflector",
    "Wall",
    "WorldMap",
    "builtin_map",
    "builtin_map_names",
    "load_builtin_map",
    "load_map",
    "save_map",
]


def _maps_dir() -> Path:
    return Path(str(resources.files("agvnav") / "data" / "maps"))


def builtin_map_names() -> list[str]:
    """Names of the maps shipped in ``agvnav/data/maps`` (e.g. ``["lab"]``), sorted."""
    return sorted(p.stem for p in _maps_dir().glob("*.yaml"))


def builtin_map(name: str) -> Path:
    """Path of the shipped map ``name`` (e.g. ``"lab"``, the seed-000 Fig. 6b style lab).

    Raises ValueError listing the available names if ``name`` is unknown.
    """
    path = _maps_dir() / f"{name}.yaml"
    if not path.is_file():
        raise ValueError(f"unknown built-in map {name!r}; available: {builtin_map_names()}")
    return path


def load_builtin_map(name: str) -> WorldMap:
    """Load the shipped map ``name`` (see :func:`builtin_map`)."""
    return load_map(builtin_map(name))
