"""A solved map as a reflector map YAML (``agvnav simulate``/``agvnav localize`` load it) and a summary.

Each reflector carries its 2x2 covariance (``covariance_m2``, m²) and ``survey_std_m``, the
isotropic std per axis of the same total variance, ``sqrt(tr(C) / 2)``: the positioning estimators
read the latter as the reflector's survey uncertainty (the EKF's consider filter, issue 12, takes it
per axis). The largest eigenvalue, used before, overstated the error along the well-determined
direction: hall, seeds 0-1, baseline maps replayed by main's consider-filter EKF, positioning ratio
1.33/1.24 with it, 1.23/1.11 with this (surveyed2 maps unchanged, 1.36/1.22: their 1 mm anchor survey
moves the whole map). Walls are
copied from a given map (the mapping drive does not see walls).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from agvnav.mapping.slam import MappingResult
from agvnav.world import Reflector, WorldMap, save_map

__all__ = ["map_summary", "result_to_map", "write_map"]


def result_to_map(result: MappingResult, radius: float = 0.04, walls_from: WorldMap | None = None) -> WorldMap:
    """The mapped reflectors as a :class:`WorldMap` (radius ``radius`` m, walls of ``walls_from``)."""
    refl = []
    for rid, xy, cov in zip(result.ids, result.xy, result.covariance, strict=True):
        c = 0.5 * (cov + cov.T)
        std = math.sqrt(max(0.5 * float(np.trace(c)), 0.0))
        refl.append(Reflector(rid, float(xy[0]), float(xy[1]), radius, std,
                              ((float(c[0, 0]), float(c[0, 1])), (float(c[0, 1]), float(c[1, 1])))))
    return WorldMap(tuple(refl), walls_from.walls if walls_from is not None else ())


def write_map(result: MappingResult, path: str | Path, radius: float = 0.04,
              walls_from: WorldMap | None = None) -> WorldMap:
    """Write the map YAML (a header comment states the anchor) and return the map."""
    world = result_to_map(result, radius, walls_from)
    p = Path(path)
    save_map(world, p)
    head = (f"# agvnav map: {len(result.ids)} reflectors from a mapping drive; frame and scale anchored by "
            f"{result.anchor}; odometry scale {result.scale:.5f} +- {result.scale_std:.5f}\n"
            "# covariance_m2: 2x2 covariance of each centre (m^2); survey_std_m: sqrt of half its trace (per axis)\n")
    p.write_text(head + p.read_text(encoding="utf-8"), encoding="utf-8")
    return world


def map_summary(result: MappingResult) -> dict[str, Any]:
    """JSON-ready figures of a solved map (SI units)."""
    stds = [math.sqrt(max(float(np.linalg.eigvalsh(c).max()), 0.0)) for c in result.covariance]
    return {
        "anchor": result.anchor,
        "reflectors": len(result.ids),
        "new_reflectors": len([i for i in result.ids if i not in result.existing_ids]),
        "reflections": result.reflections,
        "associated": result.associated,
        "odometry_scale": result.scale,
        "odometry_scale_std": result.scale_std,
        "odometry_heading_rate_rad_m": result.heading_rate,
        "odometry_turn_scale": result.turn_scale,
        "odometry_noise": list(result.odometry_noise) if result.odometry_noise is not None else None,
        "max_std_m": max(stds) if stds else None,
        "chi2_per_dof": result.chi2_per_dof,
        "runtime_s": result.runtime_s,
    }
