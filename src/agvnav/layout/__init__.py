"""Reflector layout planner (issue 15): where to mount the reflectors, and what accuracy they give on the routes.

Modules: :mod:`~agvnav.layout.schema` (input file), :mod:`~agvnav.layout.hall`
(polygons, candidate sites, route poses), :mod:`~agvnav.layout.visibility`,
:mod:`~agvnav.layout.prediction` (bearing-only CRLB), :mod:`~agvnav.layout.optimise`,
:mod:`~agvnav.layout.baseline`, :mod:`~agvnav.layout.plan`, :mod:`~agvnav.layout.verify`.
"""

from __future__ import annotations

from agvnav.layout.plan import LayoutPlan, TargetUnreachable, build_problem, plan_layout, summary_rows
from agvnav.layout.schema import LayoutSpec, load_layout, parse_layout

__all__ = [
    "LayoutPlan",
    "LayoutSpec",
    "TargetUnreachable",
    "build_problem",
    "load_layout",
    "parse_layout",
    "plan_layout",
    "summary_rows",
]
