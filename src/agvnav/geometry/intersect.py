"""Intersections and triangle helpers, vectorised over leading batch dimensions."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def cross2(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Z component of the cross product of 2-vectors ``(..., 2)``."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def intersect_lines(
    p1: ArrayLike, angle1: ArrayLike, p2: ArrayLike, angle2: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Intersection of the lines through ``p1``/``p2`` ``(..., 2)`` with directions ``angle1``/``angle2`` (rad).

    Returns ``(point (..., 2), valid (...))``; parallel lines give ``valid=False``
    and a NaN point (flagged, never silent).
    """
    p1 = np.asarray(p1, dtype=np.float64)
    p2 = np.asarray(p2, dtype=np.float64)
    d1 = np.stack([np.cos(angle1), np.sin(angle1)], axis=-1)
    d2 = np.stack([np.cos(angle2), np.sin(angle2)], axis=-1)
    denom = cross2(d1, d2)
    valid = np.abs(denom) > 1e-12
    safe = np.where(valid, denom, 1.0)
    t = cross2(p2 - p1, d2) / safe
    point = p1 + t[..., None] * d1
    return np.where(valid[..., None], point, np.nan), valid


def circumcentre(
    a: ArrayLike, b: ArrayLike, c: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Centre of the circle through three points ``(..., 2)``.

    Returns ``(centre (..., 2), valid (...))``; collinear points give ``valid=False``.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    c = np.asarray(c, dtype=np.float64)
    ab, ac = b - a, c - a
    d = 2.0 * cross2(ab, ac)
    scale = np.maximum(np.sum(ab * ab, -1), np.sum(ac * ac, -1))
    valid = np.abs(d) > 1e-12 * np.maximum(scale, 1e-300)
    safe = np.where(valid, d, 1.0)
    ab2, ac2 = np.sum(ab * ab, -1), np.sum(ac * ac, -1)
    ux = (ac[..., 1] * ab2 - ab[..., 1] * ac2) / safe
    uy = (ab[..., 0] * ac2 - ac[..., 0] * ab2) / safe
    centre = a + np.stack([ux, uy], axis=-1)
    return np.where(valid[..., None], centre, np.nan), valid


def triangle_signed_area(a: ArrayLike, b: ArrayLike, c: ArrayLike) -> NDArray[np.float64]:
    """Signed area (m²) of triangle ``abc``; positive when counter-clockwise."""
    a = np.asarray(a, dtype=np.float64)
    return 0.5 * cross2(np.asarray(b) - a, np.asarray(c) - a)


def segment_distances(point: ArrayLike, segments: ArrayLike) -> NDArray[np.float64]:
    """Distance (m) from ``point (2,)`` to every segment ``(m, 2, 2)``, ``(m,)``."""
    p = np.asarray(point, dtype=np.float64)
    seg = np.asarray(segments, dtype=np.float64)
    a, b = seg[:, 0, :], seg[:, 1, :]
    ab = b - a
    denom = np.einsum("ij,ij->i", ab, ab)
    u = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.where(denom > 0, denom, 1.0), 0.0, 1.0)
    closest = a + u[:, None] * ab
    return np.asarray(np.hypot(*(closest - p).T), dtype=np.float64)
