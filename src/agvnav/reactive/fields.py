"""Protective and warning fields of a safety scanner, switched by speed and direction (issue 18).

An industrial safety scanner holds several *field sets*; the vehicle's controller
selects one from its speed and direction of travel. A set is a protective field
(an intrusion stops the vehicle) and a warning field (an intrusion slows it),
polygons in base_link.

Design rule (ISO 13855's minimum distance ``S = K T + C``). Once something enters
the protective field the vehicle needs ``T = t_r + v / a`` to stand still (``t_r`` the
reaction time: scanner response, control step and drive lag before braking starts;
``a`` the deceleration of an emergency stop) and sweeps the strip

``H = [x_f, x_f + v t_r + v^2 / (2 a) + C] x [-(w + c_l), w + c_l]``

ahead of its front face ``x_f`` (``w`` the body's half-width, ``C`` the margin ahead
and ``c_l`` the lateral margin: range noise, a drive that brakes later than
commanded). A person walking at up to ``K`` (ISO 13855: 1.6 m/s) from any direction
can reach a point of ``H`` before the vehicle stops iff it starts within ``K T`` of
``H``; arriving early and waiting there is as bad as arriving just in time, and ``H``
only grows with the time since detection, so the set of such starting points is the
Minkowski sum ``H (+) disc(K T)``: ``H`` widened by ``K T`` sideways, lengthened by
``K T`` ahead, corners rounded. The protective field is that set (its arcs drawn as a
circumscribed polygon, so the polygon contains the set), cut at the front face
``x >= x_f`` (behind it the body and its flanks, which a front scanner does not see:
a person stepping in from alongside the body needs side scanners). A person who
*appears* outside it (``dist(p, H) >= K T``: it needs at least ``T`` to reach the swept
strip) cannot be hit, whatever its direction; one who appears inside it may be.
``K = 0`` gives back the stopping-distance rectangle ``H`` (obstacles that stand or
cross without approaching).

The warning field is the protective field swept ``v t_w`` further ahead (``t_w`` the
warning time). A set holds for ``|v|`` up to its band's top speed; the fields of a
faster band contain those of a slower one. An optional *creep* set (``creep_speed``)
is the ``K = 0`` rectangle at a low speed, for a local avoidance manoeuvre that passes
a static obstacle closer than any approach field allows (a stated limit: a person
stepping in from the side during a detour is not covered by the ``K T`` rule); with
``reverse`` a mirrored one behind the body (``creep_reverse``). Reversing on a detour never
gets the forward creep set: without a reverse creep set the reverse bands apply.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import Polygon

from agvnav.geometry.polygon import points_inside

__all__ = [
    "ISO13855_K_M_S",
    "FieldConfig",
    "FieldSet",
    "approach_clearance",
    "approach_field",
    "approach_reach",
    "field_rectangle",
    "generate_fields",
    "intrusions",
    "stopping_distance",
    "swept_strip",
]

#: ISO 13855's walking approach speed of a person (m/s), the default ``K``.
ISO13855_K_M_S = 1.6


def stopping_distance(
    v: ArrayLike, reaction_time: float, decel: float, margin: float = 0.0
) -> NDArray[np.float64]:
    """Distance (m) to stop from speed ``v`` (m/s, sign ignored): ``|v| t_r + v^2 / (2 a) + margin``.

    ``reaction_time`` (s) >= 0, ``decel`` (m/s^2) > 0, ``margin`` (m) >= 0; broadcast over ``v``.
    """
    _check_stop(reaction_time, decel)
    if not (math.isfinite(margin) and margin >= 0.0):
        raise ValueError(f"margin must be >= 0 and finite, got {margin!r}")
    s = np.abs(np.asarray(v, dtype=np.float64))
    return np.asarray(s * reaction_time + s * s / (2.0 * decel) + margin, dtype=np.float64)


def _check_stop(reaction_time: float, decel: float) -> None:
    if not (math.isfinite(reaction_time) and reaction_time >= 0.0):
        raise ValueError(f"reaction_time must be >= 0 and finite, got {reaction_time!r}")
    if not (math.isfinite(decel) and decel > 0.0):
        raise ValueError(f"decel must be a positive finite number, got {decel!r}")


def approach_reach(v: float, reaction_time: float, decel: float, approach_speed: float = ISO13855_K_M_S) -> float:
    """``K T`` (m): how far a person walking at ``approach_speed`` K (m/s) gets while the vehicle at ``v`` (m/s)
    reacts and brakes to a stop, ``T = t_r + |v| / a`` (s) [ISO 13855: S = K T + C]."""
    _check_stop(reaction_time, decel)
    if not (math.isfinite(approach_speed) and approach_speed >= 0.0):
        raise ValueError(f"approach_speed must be >= 0 and finite, got {approach_speed!r}")
    return approach_speed * (reaction_time + abs(float(v)) / decel)


def field_rectangle(
    footprint: ArrayLike, length: float, lateral_margin: float, direction: int = 1
) -> NDArray[np.float64]:
    """Rectangle ``(4, 2)`` in base_link (m): ``length`` ahead of the body's front (``direction`` +1)
    or behind its rear (-1), as wide as the body plus ``lateral_margin`` each side; counter-clockwise."""
    fp = np.asarray(footprint, dtype=np.float64)
    if not (math.isfinite(length) and length > 0.0):
        raise ValueError(f"field length must be positive and finite, got {length!r}")
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    y_lo, y_hi = float(fp[:, 1].min()) - lateral_margin, float(fp[:, 1].max()) + lateral_margin
    if direction == 1:
        x0 = float(fp[:, 0].max())
        x_lo, x_hi = x0, x0 + length
    else:
        x0 = float(fp[:, 0].min())
        x_lo, x_hi = x0 - length, x0
    return np.array([[x_lo, y_lo], [x_hi, y_lo], [x_hi, y_hi], [x_lo, y_hi]])


def swept_strip(footprint: ArrayLike, length: float, lateral_margin: float, direction: int = 1) -> Polygon:
    """The strip ``H`` of the module docstring as a shapely polygon (m, base_link): :func:`field_rectangle`."""
    return Polygon(field_rectangle(footprint, length, lateral_margin, direction))


def approach_field(
    footprint: ArrayLike, length: float, lateral_margin: float, reach: float, direction: int = 1,
    arc_segments: int = 8,
) -> NDArray[np.float64]:
    """The protective field ``(k, 2)`` (m, base_link, counter-clockwise): the strip ``H`` (``length`` ahead of
    the front, body + ``lateral_margin`` wide) widened by ``reach`` = K T (m) all round, cut at the front face.

    Each rounded corner is ``arc_segments`` edges tangent to its circle (vertices at ``reach / cos(pi /
    (4 arc_segments))``), so the polygon contains ``H (+) disc(reach)`` and exceeds it by at most
    ``reach (1 / cos(pi / (4 arc_segments)) - 1)`` (0.5 % for 8). ``reach`` 0: :func:`field_rectangle`.
    """
    rect = field_rectangle(footprint, length, lateral_margin, direction)
    if not (math.isfinite(reach) and reach >= 0.0):
        raise ValueError(f"reach must be >= 0 and finite, got {reach!r}")
    if arc_segments < 1:
        raise ValueError(f"arc_segments must be at least 1, got {arc_segments!r}")
    if reach == 0.0:
        return rect
    x_lo, y_lo = rect[0]
    x_hi, y_hi = rect[2]
    # the far corners (direction +1: x_hi; -1: x_lo) carry the arcs; the field is cut at the front face
    far = x_hi if direction == 1 else x_lo
    near = x_lo if direction == 1 else x_hi
    half = math.pi / (4.0 * arc_segments)  # half the angle of one arc edge
    r_v = reach / math.cos(half)
    def arc(cx: float, cy: float, a0: float) -> list[tuple[float, float]]:
        return [(cx + r_v * math.cos(a0 + (2 * k + 1) * half), cy + r_v * math.sin(a0 + (2 * k + 1) * half))
                for k in range(arc_segments)]
    if direction == 1:
        pts = [(near, y_lo - reach), (far, y_lo - reach), *arc(far, y_lo, -0.5 * math.pi),
               (far + reach, y_lo), (far + reach, y_hi), *arc(far, y_hi, 0.0),
               (far, y_hi + reach), (near, y_hi + reach)]
    else:
        pts = [(near, y_hi + reach), (far, y_hi + reach), *arc(far, y_hi, 0.5 * math.pi),
               (far - reach, y_hi), (far - reach, y_lo), *arc(far, y_lo, math.pi),
               (far, y_lo - reach), (near, y_lo - reach)]
    return np.asarray(pts, dtype=np.float64)


@dataclass(frozen=True)
class FieldSet:
    """One field set: valid for ``|v| <= v_max`` (m/s) in ``direction`` (+1 forward, -1 reverse).

    ``protective``/``warning`` are polygons ``(k, 2)`` in base_link (m); ``protective_length``
    and ``warning_length`` their reach ahead of the body (m); ``reach`` the approach term
    ``K T`` (m) they were widened by (0: the stopping-distance rectangles).
    """

    v_max: float
    direction: int
    protective: NDArray[np.float64]
    warning: NDArray[np.float64]
    protective_length: float
    warning_length: float
    reach: float = 0.0


@dataclass(frozen=True)
class FieldConfig:
    """The field sets of one scanner, selected by speed and direction (:meth:`select`); ``creep`` the
    optional forward set of a local avoidance manoeuvre, ``creep_reverse`` its reverse one (see the module
    docstring)."""

    sets: tuple[FieldSet, ...]
    creep: FieldSet | None = None
    creep_reverse: FieldSet | None = None

    def __post_init__(self) -> None:
        if not self.sets:
            raise ValueError("a field configuration needs at least one field set")
        if self.creep is not None and self.creep.direction != 1:
            raise ValueError(f"the creep set must be a forward set (direction 1), got {self.creep.direction}")
        if self.creep_reverse is not None and self.creep_reverse.direction != -1:
            raise ValueError(f"the reverse creep set must be a reverse set (direction -1), "
                             f"got {self.creep_reverse.direction}")

    def select(self, v: float, direction: int | None = None, creep: bool = False) -> FieldSet:
        """The set for speed ``v`` (m/s, signed): the slowest band whose ``v_max >= |v|`` in the direction
        of ``v`` (``direction`` when given, else forward at standstill); the fastest band beyond all.
        ``creep`` (a detour driven at most at the creep set's speed): the creep set of that direction, when
        there is one (reversing: ``creep_reverse``; never the forward set, whose fields lie ahead of the body)."""
        d = direction if direction is not None else (-1 if v < 0.0 else 1)
        if d not in (1, -1):
            raise ValueError(f"direction must be +1 (forward) or -1 (reverse), got {direction!r}")
        slow = self.creep if d == 1 else self.creep_reverse
        if creep and slow is not None and abs(v) <= slow.v_max + 1e-12:
            return slow
        sets = [s for s in self.sets if s.direction == d] or list(self.sets)
        speed = abs(v)
        fitting = [s for s in sets if s.v_max >= speed - 1e-12]
        if fitting:
            return min(fitting, key=lambda s: s.v_max)
        return max(sets, key=lambda s: s.v_max)

    def polygons(self) -> list[tuple[int, float, Polygon, Polygon]]:
        """``(direction, v_max, protective, warning)`` as shapely polygons, for plots and tests."""
        return [(s.direction, s.v_max, Polygon(s.protective), Polygon(s.warning)) for s in self.sets]


def _swept_ahead(polygon: NDArray[np.float64], distance: float, direction: int) -> NDArray[np.float64]:
    """``polygon`` swept ``distance`` (m) along x in ``direction``: the hull of it and its translate
    (exact for the convex fields generated here)."""
    if distance <= 0.0:
        return polygon
    moved = polygon + np.array([direction * distance, 0.0])
    hull = shapely.convex_hull(shapely.MultiPoint(np.concatenate([polygon, moved])))
    ring = shapely.get_exterior_ring(hull)
    return np.asarray(shapely.get_coordinates(ring), dtype=np.float64)[:-1]


def _field_set(footprint: ArrayLike, v: float, direction: int, p_len: float, w_extra: float, lateral_margin: float,
               reach: float) -> FieldSet:
    prot = approach_field(footprint, p_len, lateral_margin, reach, direction)
    warn = _swept_ahead(prot, w_extra, direction)
    return FieldSet(v, direction, prot, warn, p_len + reach, p_len + reach + w_extra, reach)


def generate_fields(
    footprint: ArrayLike,
    v_max: float,
    decel: float,
    reaction_time: float,
    margin: float = 0.2,
    lateral_margin: float = 0.1,
    warning_time: float = 1.5,
    bands: int = 4,
    reverse: bool = False,
    protective_length: float | None = None,
    warning_length: float | None = None,
    approach_speed: float = ISO13855_K_M_S,
    creep_speed: float | None = None,
) -> FieldConfig:
    """Field sets for ``bands`` equal speed bands up to ``v_max`` (m/s) (see the module docstring).

    Band ``i`` (1-based) holds up to ``v_i = i v_max / bands``; its protective field is the strip ``H``
    :func:`stopping_distance` ``(v_i)`` long (``margin`` C included) widened all round by the approach
    reach ``K T = approach_speed (t_r + v_i / a)`` [ISO 13855: S = K T + C], cut at the front face
    (:func:`approach_field`); its warning field is the protective one swept ``v_i warning_time`` further
    ahead. ``approach_speed`` K (m/s, default ISO 13855's 1.6; 0: the plain stopping-distance rectangles).
    ``protective_length``/``warning_length`` (m) fix one rectangular set per direction instead (no
    approach term). ``reverse``: mirrored sets behind the body for reversing. ``creep_speed`` (m/s): also a
    ``K = 0`` set for a local avoidance manoeuvre driven at most that fast (:meth:`FieldConfig.select`), and
    with ``reverse`` its mirror behind the body.
    """
    if not (math.isfinite(approach_speed) and approach_speed >= 0.0):
        raise ValueError(f"approach_speed must be >= 0 and finite, got {approach_speed!r}")
    if not (math.isfinite(v_max) and v_max > 0.0):
        raise ValueError(f"v_max must be a positive finite speed, got {v_max!r}")
    if bands < 1:
        raise ValueError(f"bands must be at least 1, got {bands!r}")
    if not (math.isfinite(warning_time) and warning_time >= 0.0):
        raise ValueError(f"warning_time must be >= 0 and finite, got {warning_time!r}")
    if creep_speed is not None and not (math.isfinite(creep_speed) and 0.0 < creep_speed <= v_max):
        raise ValueError(f"creep_speed must be in (0, v_max], got {creep_speed!r}")
    directions = (1, -1) if reverse else (1,)
    sets = []
    for d in directions:
        if protective_length is not None:
            wl = warning_length if warning_length is not None else protective_length
            if wl < protective_length:
                raise ValueError("warning_length must be at least protective_length")
            sets.append(FieldSet(v_max, d, field_rectangle(footprint, protective_length, lateral_margin, d),
                                 field_rectangle(footprint, wl, lateral_margin, d), protective_length, wl))
            continue
        for i in range(1, bands + 1):
            v = v_max * i / bands
            p_len = float(stopping_distance(v, reaction_time, decel, margin))
            reach = approach_reach(v, reaction_time, decel, approach_speed)
            sets.append(_field_set(footprint, v, d, p_len, v * warning_time, lateral_margin, reach))
    creep = creep_reverse = None
    if creep_speed is not None:
        p_len = float(stopping_distance(creep_speed, reaction_time, decel, margin))
        creep = _field_set(footprint, creep_speed, 1, p_len, creep_speed * warning_time, lateral_margin, 0.0)
        if reverse:
            creep_reverse = _field_set(footprint, creep_speed, -1, p_len, creep_speed * warning_time,
                                       lateral_margin, 0.0)
    return FieldConfig(tuple(sets), creep, creep_reverse)


def intrusions(points: ArrayLike, polygon: ArrayLike) -> NDArray[np.bool_]:
    """Which points ``(..., 2)`` (base_link, m; NaN rows are no echo) lie inside ``polygon (k, 2)``, ``(...)``:
    the compiled crossing-number test (:func:`agvnav.geometry.polygon.points_inside`)."""
    return points_inside(points, polygon)


def approach_clearance(
    points: ArrayLike, footprint: ArrayLike, v: float, reaction_time: float, decel: float, margin: float,
    lateral_margin: float, approach_speed: float = ISO13855_K_M_S, direction: int = 1,
) -> NDArray[np.float64]:
    """``dist(p, H) - K T`` (m) for points ``(..., 2)`` (base_link), ``(...)``: >= 0 where a person walking at up
    to K (m/s) needs at least the stopping time ``T`` to reach the strip ``H`` swept by the vehicle stopping from
    ``v`` (m/s): outside the designed protective field, unconstrained by the front-face cut [ISO 13855: S = K T + C].
    """
    p = np.asarray(points, dtype=np.float64)
    length = float(stopping_distance(v, reaction_time, decel, margin))
    strip = swept_strip(footprint, length, lateral_margin, direction) if length > 0.0 else None
    if strip is None:
        raise ValueError("the swept strip is empty: give a speed or a margin")
    d = shapely.distance(strip, shapely.points(p[..., 0], p[..., 1]))
    return np.asarray(d - approach_reach(v, reaction_time, decel, approach_speed), dtype=np.float64)
