"""A small layout problem shared by the layout tests: a 20 x 12 m hall with one rack and two routes."""

from __future__ import annotations

import pytest

SMALL = """\
name: small
seed: 3
hall:
  outer: [[0, 0], [20, 0], [20, 12], [0, 12], [0, 0]]
  occluders:
    - {id: rack, kind: rack, points: [[5, 5], [15, 5], [15, 7], [5, 7], [5, 5]]}
routes:
  - name: south
    path: {start: [2, 2.5, 0], segments: [{type: line, length_m: 16}]}
  - name: north
    path: {start: [18, 9.5, 180], segments: [{type: line, length_m: 16}]}
goniometer: {max_range_m: 15, reflector_radius_m: 0.04}
candidates:
  sites: [{face: outer, spacing_m: 1.0}, {face: rack, spacing_m: 1.0}]
target: {position_3sigma_m: 0.01, heading_3sigma_deg: 0.1, fraction: 0.99, min_visible: 3, route_spacing_m: 1.0}
verify: {max_length_m: 8, section_m: 4}
"""


@pytest.fixture
def small_text() -> str:
    """The YAML text of the small layout problem."""
    return SMALL
