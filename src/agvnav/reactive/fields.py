"""Protective and warning fields of a safety scanner, switched by speed and direction (issue 18).

An industrial safety scanner holds several *field sets*; the vehicle's controller
selects one from its speed and direction of travel. A set is a protective field
(an intrusion stops the vehicle) and a warning field (an intrusion slows it),
polygons in base_link. Generated here from the stopping distance at the top speed
of each band:

``D(v) = v t_r + v^2 / (2 a) + margin``

(``t_r`` the reaction time: scanner response, control step and drive lag before
braking starts; ``a`` the deceleration of an emergency stop; the margin covers the
noise of the range and a drive that brakes later than commanded). The protective
field is a rectangle ahead of the body (behind it when reversing), ``D`` long and
as wide as the body plus ``lateral_margin`` on each side; the warning field is
``v t_w`` longer (``t_w`` the warning time). A set holds for ``|v|`` up to its band's
top speed; the fields of a faster band contain those of a slower one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import Polygon

__all__ = [
    "FieldConfig",
    "FieldSet",
    "field_rectangle",
    "generate_fields",
    "intrusions",
    "stopping_distance",
]


def stopping_distance(
    v: ArrayLike, reaction_time: float, decel: float, margin: float = 0.0
) -> NDArray[np.float64]:
    """Distance (m) to stop from speed ``v`` (m/s, sign ignored): ``|v| t_r + v^2 / (2 a) + margin``.

    ``reaction_time`` (s) >= 0, ``decel`` (m/s^2) > 0, ``margin`` (m) >= 0; broadcast over ``v``.
    """
    if not (math.isfinite(reaction_time) and reaction_time >= 0.0):
        raise ValueError(f"reaction_time must be >= 0 and finite, got {reaction_time!r}")
    if not (math.isfinite(decel) and decel > 0.0):
        raise ValueError(f"decel must be a positive finite number, got {decel!r}")
    if not (math.isfinite(margin) and margin >= 0.0):
        raise ValueError(f"margin must be >= 0 and finite, got {margin!r}")
    s = np.abs(np.asarray(v, dtype=np.float64))
    return np.asarray(s * reaction_time + s * s / (2.0 * decel) + margin, dtype=np.float64)


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


@dataclass(frozen=True)
class FieldSet:
    """One field set: valid for ``|v| <= v_max`` (m/s) in ``direction`` (+1 forward, -1 reverse).

    ``protective``/``warning`` are polygons ``(k, 2)`` in base_link (m); ``protective_length``
    and ``warning_length`` their reach beyond the body (m).
    """

    v_max: float
    direction: int
    protective: NDArray[np.float64]
    warning: NDArray[np.float64]
    protective_length: float
    warning_length: float


@dataclass(frozen=True)
class FieldConfig:
    """The field sets of one scanner, selected by speed and direction (:meth:`select`)."""

    sets: tuple[FieldSet, ...]

    def __post_init__(self) -> None:
        if not self.sets:
            raise ValueError("a field configuration needs at least one field set")

    def select(self, v: float, direction: int | None = None) -> FieldSet:
        """The set for speed ``v`` (m/s, signed): the slowest band whose ``v_max >= |v|`` in the direction
        of ``v`` (``direction`` when given, else forward at standstill); the fastest band beyond all."""
        d = direction if direction is not None else (-1 if v < 0.0 else 1)
        sets = [s for s in self.sets if s.direction == d] or list(self.sets)
        speed = abs(v)
        fitting = [s for s in sets if s.v_max >= speed - 1e-12]
        if fitting:
            return min(fitting, key=lambda s: s.v_max)
        return max(sets, key=lambda s: s.v_max)

    def polygons(self) -> list[tuple[int, float, Polygon, Polygon]]:
        """``(direction, v_max, protective, warning)`` as shapely polygons, for plots and tests."""
        return [(s.direction, s.v_max, Polygon(s.protective), Polygon(s.warning)) for s in self.sets]


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
    approach_speed: float = 0.0,
) -> FieldConfig:
    """Field sets for ``bands`` equal speed bands up to ``v_max`` (m/s) (see the module docstring).

    Band ``i`` (1-based) holds up to ``v_i = i v_max / bands``; its protective field is
    :func:`stopping_distance` ``(v_i)`` long, its warning field ``v_i warning_time`` longer.
    ``protective_length``/``warning_length`` (m) fix one set per direction instead. ``reverse``:
    mirror sets behind the body for reversing. ``approach_speed`` (m/s): a person may walk towards
    the vehicle at this speed while it reacts and brakes, so the protective field is longer by
    ``u_a (t_r + v_i / a)`` (the ``K T`` term of ISO 13855's ``S = K T + C``; 0: obstacles that
    stand or cross without approaching).
    """
    if not (math.isfinite(approach_speed) and approach_speed >= 0.0):
        raise ValueError(f"approach_speed must be >= 0 and finite, got {approach_speed!r}")
    if not (math.isfinite(v_max) and v_max > 0.0):
        raise ValueError(f"v_max must be a positive finite speed, got {v_max!r}")
    if bands < 1:
        raise ValueError(f"bands must be at least 1, got {bands!r}")
    if not (math.isfinite(warning_time) and warning_time >= 0.0):
        raise ValueError(f"warning_time must be >= 0 and finite, got {warning_time!r}")
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
            p_len += approach_speed * (reaction_time + v / decel)
            w_len = p_len + v * warning_time
            sets.append(FieldSet(v, d, field_rectangle(footprint, p_len, lateral_margin, d),
                                 field_rectangle(footprint, w_len, lateral_margin, d), p_len, w_len))
    return FieldConfig(tuple(sets))


def intrusions(points: ArrayLike, polygon: ArrayLike) -> NDArray[np.bool_]:
    """Which points ``(..., 2)`` (base_link, m; NaN rows are no echo) lie inside ``polygon (k, 2)``, ``(...)``."""
    p = np.asarray(points, dtype=np.float64)
    inside = shapely.contains_xy(Polygon(np.asarray(polygon, dtype=np.float64)), p[..., 0], p[..., 1])
    return np.asarray(inside & np.isfinite(p[..., 0]), dtype=np.bool_)
