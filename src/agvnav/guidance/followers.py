"""Path followers created by name for a vehicle family, and the path feasibility check.

:data:`FOLLOWERS` says which follower names fit which family (docs/ARCHITECTURE.md,
"One closed loop for every vehicle"); :func:`make_follower` builds one from a
name, the family, the path and the plant's nominal ``geometry`` (duck-typed:
steered ``wheelbase``, ``drive_point``, ``max_steer``; unicycle ``track``,
``wheel_radius``; holonomic ``wheel_radius``, ``half_length``,
``half_width``: the records of :mod:`agvnav.vehicles`, which guidance does
not import). :func:`check_path_feasible` refuses, before a run, a path the
vehicle cannot follow, naming the segment. :func:`follower_parameters` lists the
parameters each follower takes, with unit, default and meaning, from the
constructors' signatures and :data:`PARAMETER_DOCS` (docs/scenarios.md is
generated from it); an unknown parameter is refused naming them.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from agvnav.geometry.angles import wrap_angle_scalar
from agvnav.guidance.controller import CONTROLLERS, DEFAULT_CONVERGENCE_DISTANCE_M
from agvnav.guidance.follower import FAMILIES, GuidanceError, InfeasiblePathError, PathFollower
from agvnav.guidance.holonomic import HolonomicFollower
from agvnav.guidance.paths import ArcSegment, Path
from agvnav.guidance.steered import SteeredFollower
from agvnav.guidance.unicycle import KanayamaPathFollower, UnicyclePurePursuit, UnicycleStanley

__all__ = [
    "FOLLOWERS",
    "GEOMETRY_FIELDS",
    "PARAMETER_DOCS",
    "FollowerParameter",
    "check_path_feasible",
    "follower_parameters",
    "make_follower",
]

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


#: Every follower constructor keyword: name -> (unit, meaning). The same name means the same thing
#: (and unit) in every follower; a test checks that each constructor's keywords are all here.
PARAMETER_DOCS: dict[str, tuple[str, str]] = {
    "convergence_distance": (
        "m",
        (f"distance travelled within which a small error decays to 2 %: tunes the gains (none given: "
        f"{DEFAULT_CONVERGENCE_DISTANCE_M:g} m)"),
    ),
    "poles_per_m": ("1/m", "closed-loop poles per metre travelled, instead of convergence_distance (seed 000)"),
    "gains": ("-", "explicit gains instead of poles or convergence_distance"),
    "v_max": ("m/s", "top speed the seed-000 general law's fixed gains are checked for"),
    "point": ("-", ("tracked point: C (steered wheel) or O (rear axle midpoint); in a scenario controller.point, "
                   "default C")),
    "form": ("-", "which form of the seed-000 law (eqs 11-13 general, 20-22 simple)"),
    "feedforward": ("-", "add the path curvature's steering feedforward"),
    "curvature_compensation": ("-", "correct the gains for the path curvature"),
    "exact_rotation": ("-", "rotate the errors exactly rather than to first order"),
    "window": ("m", "search window of the path projection around the last abscissa"),
    "lookahead": ("m", "look-ahead distance along the path (none: from convergence_distance)"),
    "v_nominal": ("m/s", "speed the gains are tuned for (in a scenario: traction.speed_m_s)"),
    "servo_tau": ("s", "time constant of the steering servo towards the law's angle"),
    "gain_per_m": ("1/m", "Stanley's cross-track gain (none: from convergence_distance)"),
    "front_offset": ("m", "virtual front axle ahead of base_link (none: from convergence_distance)"),
    "max_rate": ("rad/s", "yaw-rate limit of the command"),
    "lateral_gain": ("1/m", "lateral error decay per metre travelled (none: from convergence_distance)"),
    "heading_gain": ("1/m", "heading error decay per metre travelled (none: from convergence_distance)"),
}

#: Keywords the scenario sets from its own keys rather than ``controller.params`` (scenario key per name).
SCENARIO_KEYS = {"point": "controller.point", "poles_per_m": "controller.poles_per_m", "gains": "controller.gains"}


@dataclass(frozen=True)
class FollowerParameter:
    """One parameter of a follower: ``name`` (a constructor keyword), its ``unit``, ``default`` (as text)
    and ``meaning``."""

    name: str
    unit: str
    default: str
    meaning: str


def _constructor(name: str, family: str) -> Callable[..., Any]:
    if family == "steered":
        return CONTROLLERS[name]
    if family == "unicycle":
        return _UNICYCLE[name]
    return HolonomicFollower


def follower_parameters(name: str, family: str) -> tuple[FollowerParameter, ...]:
    """The parameters the follower ``name`` of ``family`` takes, in its constructor's order.

    Read from the constructor's signature (the path and the vehicle geometry, which the
    caller supplies, left out); units and meanings from :data:`PARAMETER_DOCS`. A default
    of None reads "none" (the follower designs the value, see the meaning).
    """
    names = FOLLOWERS[_check_family(family)]
    if name not in names:
        raise GuidanceError(f"{name} does not fit a {family} vehicle; choose from: {', '.join(names)}")
    out = []
    for p in inspect.signature(_constructor(name, family)).parameters.values():
        if p.name in ("self", "path", "wheelbase") or p.kind in (p.VAR_KEYWORD, p.VAR_POSITIONAL):
            continue
        unit, meaning = PARAMETER_DOCS.get(p.name, ("?", "not documented"))
        default = "none" if p.default is None else "required" if p.default is p.empty else repr(p.default)
        out.append(FollowerParameter(p.name, unit, default.replace("inf", "no limit"), meaning))
    return tuple(out)


def _check_parameters(name: str, family: str, params: dict[str, Any]) -> None:
    """Refuse a parameter the follower does not take, naming the ones it does (with units and defaults)."""
    known = follower_parameters(name, family)
    unknown = [k for k in params if k not in {p.name for p in known}]
    if unknown:
        takes = "; ".join(f"{p.name} ({p.unit}, default {p.default})" for p in known)
        raise GuidanceError(
            f"{name} takes no parameter {', '.join(map(repr, unknown))}; a {family} vehicle's {name} takes: {takes} "
            "(in a scenario as controller.params.NAME; point, poles_per_m and gains as controller.point, "
            "controller.poles_per_m and controller.gains)"
        )


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
    _check_parameters(name, family, params)
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
