"""Integrity checks on geometry and visibility: which reflectors the head can see, and its clock.

* :func:`reflectors_in_sight` -- the goniometer's line-of-sight test; the monitor counts the
  reflectors in sight to judge the share the estimate explains (``"unexplained"``) and the
  estimator's gate takes only those as candidates;
* :class:`HeadClock` -- the head's phase learnt from the reflections' stamps and bearings: a
  window whose reflections are mostly off the phase fails ``"timing"`` (stale stamps).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from numpy.typing import ArrayLike

from agvnav.geometry import wrap_angle_scalar
from agvnav.sensors.beam import line_of_sight

__all__ = ["HeadClock", "reflectors_in_sight"]

_PI = math.pi


def reflectors_in_sight(
    reflector_xy: ArrayLike,
    reflector_radius: ArrayLike,
    head_xy: ArrayLike,
    walls: ArrayLike | None = None,
    max_range: float = math.inf,
    min_range: float = 0.0,
) -> np.ndarray:
    """``(N,)`` bool: which reflectors the goniometer head at ``head_xy`` can see.

    The goniometer's own test (:func:`agvnav.sensors.beam.line_of_sight`): the beam
    length to the tangent point ``sqrt(d^2 - r^2)`` within ``[min_range, max_range]`` (m)
    and the segment from the head to the reflector's near surface crossing no wall
    segment of ``walls (M, 2, 2)`` (m; :attr:`agvnav.world.WorldMap.wall_segments`, racks
    and pillars included) and no other reflector. Without ``walls`` only the range counts.

    ``reflector_xy (N, 2)`` and ``reflector_radius (N,)`` in m, ``head_xy (2,)`` in m.
    """
    xy = np.asarray(reflector_xy, dtype=np.float64).reshape(-1, 2)
    r = np.ascontiguousarray(np.asarray(reflector_radius, dtype=np.float64).reshape(-1))
    if r.shape[0] != xy.shape[0]:
        raise ValueError(f"reflector_radius must have shape ({xy.shape[0]},), got {r.shape}")
    head = np.asarray(head_xy, dtype=np.float64).reshape(-1)
    if head.shape != (2,) or not np.all(np.isfinite(head)):
        raise ValueError(f"head_xy must be a finite (2,) position, got {head_xy!r}")
    w = np.zeros((0, 2, 2)) if walls is None else np.asarray(walls, dtype=np.float64).reshape(-1, 2, 2)
    n = xy.shape[0]
    rx, ry = np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1])
    d = np.hypot(rx - head[0], ry - head[1])
    return np.asarray(line_of_sight(
        np.arange(n, dtype=np.int64), np.full(n, head[0]), np.full(n, head[1]), d, rx, ry, r,
        np.ascontiguousarray(w[:, 0, 0]), np.ascontiguousarray(w[:, 0, 1]),
        np.ascontiguousarray(w[:, 1, 0] - w[:, 0, 0]), np.ascontiguousarray(w[:, 1, 1] - w[:, 0, 1]),
        float(min_range), float(max_range) if math.isfinite(max_range) else 1e300,
    ), dtype=bool)


class HeadClock:
    """The goniometer head's phase, learnt from the stamps and bearings of the reflections.

    A reported bearing is the encoder reading at the reflection's instant, so
    ``wrap(z - s omega t)`` is the same for every reflection (``s`` the turning sense,
    ``omega = 2 pi / revolution_s``). The first ``LEARN`` residuals fix ``s`` and the
    reference phase when they agree within ``tolerance`` (else the clock stays unknown
    and keeps trying on the latest ones: synthetic streams need not come from a
    rotating head); afterwards each residual within ``tolerance`` nudges the reference
    (gain ``GAIN``: slow drift of the head's rate is followed), the others are late.
    """

    LEARN = 16
    GAIN = 0.05

    def __init__(self, revolution_s: float, tolerance: float) -> None:
        self.omega = 2.0 * math.pi / revolution_s
        self.tolerance = tolerance
        self.sense = 0  # 0 unknown, +1 CCW, -1 CW
        self.phase = 0.0
        self._learn: deque[tuple[float, float]] = deque(maxlen=self.LEARN)

    def on_time(self, t: float, z: float) -> bool:
        """True when the reflection ``(t s, z rad)`` agrees with the head's phase (or it is not known yet)."""
        w = self.omega * t
        if self.sense == 0:
            self._learn.append((wrap_angle_scalar(z - w), wrap_angle_scalar(z + w)))
            if len(self._learn) == self.LEARN:
                for k, sense in ((0, 1), (1, -1)):
                    ref = math.atan2(sum(math.sin(v[k]) for v in self._learn), sum(math.cos(v[k]) for v in self._learn))
                    if all(abs(wrap_angle_scalar(v[k] - ref)) <= 0.5 * self.tolerance for v in self._learn):
                        self.sense, self.phase = sense, ref
                        break
            return True
        dev = z - self.sense * w - self.phase
        if not -_PI <= dev < _PI:  # wrap_angle_scalar's own shortcut, its call only when it wraps (issue 11)
            dev = wrap_angle_scalar(dev)
        if abs(dev) <= self.tolerance:
            phase = self.phase + self.GAIN * dev
            self.phase = phase if -_PI <= phase < _PI else wrap_angle_scalar(phase)
            return True
        return False
