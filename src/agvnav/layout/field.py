"""Predicted accuracy over the whole hall (for the heat map): σ and visible count on a regular grid."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray

from agvnav.layout.plan import LayoutPlan
from agvnav.layout.prediction import information, sigmas
from agvnav.layout.visibility import mutual_hiding, visibility

__all__ = ["HallField", "hall_field"]


@dataclass(frozen=True)
class HallField:
    """Grid ``x`` ``(nx,)``, ``y`` ``(ny,)`` (m) and per cell ``sigma_pos`` (m) and ``count`` ``(ny, nx)``;
    NaN / -1 outside the free floor (outside the hall or inside an occluder)."""

    x: NDArray[np.float64]
    y: NDArray[np.float64]
    sigma_pos: NDArray[np.float64]
    count: NDArray[np.int64]


def hall_field(plan: LayoutPlan, chosen: NDArray[np.int64] | None = None, cells: int = 12000) -> HallField:
    """Predicted ``sigma_pos`` and visible count of the layout ``chosen`` (default: the plan) on about ``cells``
    grid cells over the hall (the head at the cell centre)."""
    chosen = plan.result.chosen if chosen is None else np.asarray(chosen, dtype=np.int64)
    x0, y0, x1, y1 = plan.hall.outer.bounds
    step = math.sqrt((x1 - x0) * (y1 - y0) / cells)
    x = np.arange(x0 + step / 2, x1, step)
    y = np.arange(y0 + step / 2, y1, step)
    gx, gy = np.meshgrid(x, y)
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    geo = shapely.points(pts)
    free = shapely.contains(plan.hall.outer, geo)
    for o in plan.hall.occluders.values():
        free &= ~shapely.intersects(o, geo)
    g = plan.spec.goniometer
    refl = plan.problem.sites[chosen]
    head = pts[free]
    vis = mutual_hiding(head, refl, g.reflector_radius_m,
                        visibility(head, refl, plan.hall.segments, g.min_range_m, g.max_range_m))
    sp, _ = sigmas(information(head, refl, vis, plan.problem.bearing_std))
    sigma = np.full(pts.shape[0], np.nan)
    count = np.full(pts.shape[0], -1, dtype=np.int64)
    sigma[free] = sp
    count[free] = vis.sum(axis=1)
    return HallField(x, y, sigma.reshape(gx.shape), count.reshape(gx.shape))
