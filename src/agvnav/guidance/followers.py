"""Path followers created by name for a vehicle family, and the path feasibility check.

:data:`FOLLOWERS` says which follower names fit which family (docs/ARCHITECTURE.md,
"One closed loop for every vehicle"); :func:`make_follower` builds one from a
name, the family, the path and the plant's nominal ``geometry`` (duck-typed:
steered ``wheelbase``, ``drive_point``, ``max_steer``; unicycle ``track``,
``wheel_radius``; holonomic ``wheel_radius``, ``half_length``,
``half_width``: the records of :mod:`agvnav.vehicles`, which guidance does
not import). :func:`check_path_feasible` refuses, before a run, a path the
vehicle cannot follow, naming the segment.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from agvnav.geometry.angles import wrap_angle_scalar
from agvnav.guidance.follower import FAMILIES, GuidanceError, InfeasiblePathError, PathFollower
from agvnav.guidance.holonomic import HolonomicFollower
from agvnav.guidance.paths import ArcSegment, Path
from agvnav.guidance.steered import SteeredFollower
from agvnav.guidance.unicycle import KanayamaPathFollower, UnicyclePurePursuit, UnicycleStanley

__all__ = ["FOLLOWERS", "GEOMETRY_FIELDS", "check_path_feasible", "make_follower"]

FOLLOWERS: dict[str, tuple[str, ...]] = {
    "steered": ("seed_general", "seed_simple", "pure_pursuit", "stanley"),
    "unicycle": ("kanayama", "pure_pursuit", "stanley"),
    "holonomic": ("holonomic",),
}
"""Follower names that fit each vehicle family (the first is the family's default)."""

GEOMETRY_FIELDS: dict[str, tuple[str, ...]] = {
    "steered": ("wheelbase", "drive_point", "max_steer"),
    "unicycle": ("track", "wheel_radius"),
    "holonomic": ("wheel_radius", "half_length", "half_width"),
}
"""Nominal geometry attributes each family's followers read."""

_UNICYCLE: dict[str, Callable[..., PathFollower]] = {
    "kanayama": KanayamaPathFollower,
    "pure_pursuit": UnicyclePurePursuit,
    "stanley": UnicycleStanley,
}


def _check_family(family: str) -> str:
    if family not in FAMILIES:
        raise GuidanceError(f"unknown vehicle family {family!r}; choose from: {', '.join(FAMILIES)}")
    return family


def _geometry(family: str, geometry: Any) -> dict[str, Any]:
    missing = [f for f in GEOMETRY_FIELDS[family] if not hasattr(geometry, f)]
    if missing:
        raise GuidanceError(f"a {family} vehicle's geometry needs {', '.join(missing)} ({type(geometry).__name__})")
    return {f: getattr(geometry, f) for f in GEOMETRY_FIELDS[family]}


def make_follower(name: str, family: str, path: Path, geometry: Any, **params: Any) -> PathFollower:
    """Create the path follower ``name`` for a vehicle of ``family`` ("steered", "unicycle", "holonomic").

    ``geometry`` is the plant's nominal geometry (module doc); ``params`` go
    to the follower (every follower takes ``convergence_distance``, m). A
    name that does not fit the family, or an unknown parameter, raises
    :class:`~agvnav.guidance.follower.GuidanceError` naming the valid choices.
    """
    names = FOLLOWERS[_check_family(family)]
    if name not in names:
        raise GuidanceError(f"{name} does not fit a {family} vehicle; choose from: {', '.join(names)}")
    geo = _geometry(family, geometry)
    try:
        if family == "steered":
            return SteeredFollower(name, path, geo["wheelbase"], geo["drive_point"], geo["max_steer"], **params)
        if family == "unicycle":
            return _UNICYCLE[name](path, **params)
        return HolonomicFollower(path, **params)
    except TypeError as exc:
        raise GuidanceError(f"follower {name!r} for a {family} vehicle: {exc}") from None
    except GuidanceError:
        raise
    except ValueError as exc:
        raise GuidanceError(f"follower {name!r} for a {family} vehicle: {exc}") from exc


def min_turning_radius(wheelbase: float, max_steer: float, point: str = "O") -> float:
    """Smallest radius (m) of the path of ``point`` a steered vehicle can follow.

    From ``psi' = v_O tan(gamma) / L = v_C sin(gamma) / L`` [seed000 eq8]
    [seed003 §3.2.5]: O turns on ``L / tan(gamma)``, C on ``L / sin(gamma)``;
    ``max_steer`` in rad, ``wheelbase`` in m.
    """
    if point not in ("O", "C"):
        raise GuidanceError(f"point must be 'O' or 'C', got {point!r}")
    if not (math.isfinite(max_steer) and 0.0 < max_steer <= 0.5 * math.pi):
        raise GuidanceError(f"max_steer must be in (0, pi/2] rad, got {max_steer!r}")
    return wheelbase / math.tan(max_steer) if point == "O" else wheelbase / math.sin(max_steer)


def _body_heading_jump(path: Path, i: int) -> float:
    """Body-heading jump (rad) at the start of segment ``i`` (tangent + pi on reverse segments)."""
    a, b = path.segments[i - 1], path.segments[i]
    before = a.end_heading + (math.pi if a.direction < 0 else 0.0)
    after = b.heading + (math.pi if b.direction < 0 else 0.0)
    return wrap_angle_scalar(after - before)


def _check_steered(path: Path, i: int, geo: dict[str, Any], point: str, tol: float) -> None:
    seg = path.segments[i]
    if isinstance(seg, ArcSegment):
        r_min = min_turning_radius(geo["wheelbase"], geo["max_steer"], point)
        if seg.radius < r_min * (1.0 - 1e-9):
            raise InfeasiblePathError(
                i,
                f"arc radius {seg.radius:.4g} m is below the minimum turning radius {r_min:.4g} m of point "
                f"{point} (wheelbase {geo['wheelbase']:.4g} m, max steer {math.degrees(geo['max_steer']):.4g} deg)",
            )
    if i > 0 and abs(_body_heading_jump(path, i)) > tol:
        jump = math.degrees(_body_heading_jump(path, i))
        reason = f"the body heading jumps by {jump:.4g} deg at its start: a steered vehicle needs a smooth path"
        raise InfeasiblePathError(i, reason)


def check_path_feasible(
    path: Path, family: str, geometry: Any, reverse_allowed: bool, point: str = "O", corner_tol: float = 1e-6
) -> None:
    """Raise :class:`~agvnav.guidance.follower.InfeasiblePathError` naming the first segment the vehicle cannot follow.

    * any family: a reverse segment when ``reverse_allowed`` is False;
    * steered: an arc tighter than :func:`min_turning_radius` for the tracked
      ``point`` ("O": ``wheelbase / tan(max_steer)``, "C": ``wheelbase /
      sin(max_steer)``), and a jump of the body heading (tangent, + pi when
      reversing) above ``corner_tol`` rad between segments: a steered vehicle
      cannot turn on the spot, while a cusp (reversing on the same line) keeps
      the body heading and is allowed.

    Unicycle and holonomic vehicles turn on the spot, so curvature and
    corners do not limit them. ``geometry`` as for :func:`make_follower`.
    """
    if not isinstance(path, Path):
        raise GuidanceError(f"path must be an agvnav.guidance.Path, got {type(path).__name__}")
    geo = _geometry(_check_family(family), geometry)
    for i, seg in enumerate(path.segments):
        if seg.direction < 0 and not reverse_allowed:
            raise InfeasiblePathError(i, f"reverse segment, but this {family} vehicle cannot reverse")
        if family == "steered":
            _check_steered(path, i, geo, point, corner_tol)
