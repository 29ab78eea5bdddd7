"""Test support for the traffic execution tests: a conservative conflict relation from bounding circles.

Two resources conflict when their sampled centre lines come within the sum of the two models' bounding
radii plus a margin: a superset of the swept-footprint conflicts (a disc contains the footprint in every
heading), so plans and ADGs built on it are safe for any footprint inside the discs.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from agvnav.routes.network import RouteNetwork

Resource = tuple[str, str]


class DiscZones:
    """Conflicts from bounding discs of radius ``radius[model]`` (m) plus ``margin`` (m)."""

    def __init__(self, network: RouteNetwork, radius: dict[str, float], margin: float = 0.1) -> None:
        self.radius = radius
        self.margin = margin
        self.points: dict[Resource, np.ndarray] = {}
        for n in network.nodes.values():
            self.points[("node", n.id)] = np.array([[n.x, n.y]])
        for e in network.edges.values():
            pts = e.curve.points
            s = np.linspace(0.0, 1.0, max(2, int(e.curve.length / 0.1) + 1))
            idx = np.minimum((s * (len(pts) - 1)).round().astype(int), len(pts) - 1)
            self.points[("edge", e.id)] = pts[idx]
        self.keys = list(self.points)
        owner = np.concatenate([np.full(len(self.points[k]), i) for i, k in enumerate(self.keys)])
        self.owner = owner
        self.tree = cKDTree(np.concatenate([self.points[k] for k in self.keys]))
        self._memo: dict[tuple[str, Resource, str], frozenset[Resource]] = {}

    def conflicts(self, model_a: str, res_a: Resource, model_b: str) -> frozenset[Resource]:
        key = (model_a, res_a, model_b)
        if key not in self._memo:
            r = self.radius[model_a] + self.radius[model_b] + self.margin
            hits = self.tree.query_ball_point(self.points[res_a], r)
            found = {self.keys[self.owner[j]] for lst in hits for j in lst}
            self._memo[key] = frozenset(found)
        return self._memo[key]
