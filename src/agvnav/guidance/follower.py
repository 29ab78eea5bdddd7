"""The path-follower role: one narrow interface for every vehicle family.

docs/ARCHITECTURE.md, "One closed loop for every vehicle": a path follower is
created by name (:func:`agvnav.guidance.make_follower`) and offers

* ``set_path(path)`` and ``reset()``;
* ``command(pose (3,), v, steering=0.0) -> (v_lateral, rate)``: ``pose`` the
  estimated base_link pose ``[x, y, psi]`` (m, m, rad) in ``map``, ``v`` the
  signed speed of the tracked point along the path (m/s, negative on reverse
  segments), ``steering`` the measured steering angle (rad, steered family);
  ``rate`` is the steering rate (steered) or the yaw rate (unicycle,
  holonomic), rad/s, ``v_lateral`` the body-frame lateral speed (m/s,
  holonomic only, else 0);
* read-only ``last_errors`` (errors of the last command, None after a reset)
  and ``family``.

Failures are :class:`GuidanceError` (a ValueError) or its subclass
:class:`InfeasiblePathError` (the path cannot be followed by the vehicle,
naming the segment), so a caller maps them to run outcomes.

:class:`ProjectingFollower` holds what the unicycle and holonomic followers
share: the path, the projection of base_link onto it (searched within
``window`` m of the previous one, so a self-crossing path does not make the
follower jump) and the :class:`FollowErrors` it yields.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

from agvnav._validate import require_positive
from agvnav.geometry.angles import wrap_angle_scalar
from agvnav.guidance.errors import TrackingErrors
from agvnav.guidance.paths import Path

__all__ = [
    "FAMILIES",
    "FollowErrors",
    "GuidanceError",
    "InfeasiblePathError",
    "PathFollower",
    "ProjectingFollower",
    "check_pose",
]

FAMILIES = ("steered", "unicycle", "holonomic")
"""Vehicle families of the plant role (docs/ARCHITECTURE.md)."""


class GuidanceError(ValueError):
    """A path follower cannot do what it was asked (wrong family, bad parameters, bad path)."""


class InfeasiblePathError(GuidanceError):
    """The vehicle cannot follow segment ``segment`` of the path (curvature, reverse, corner)."""

    def __init__(self, segment: int, reason: str):
        self.segment = int(segment)
        self.reason = reason
        super().__init__(f"path segment {self.segment}: {reason}")


@dataclass(frozen=True)
class FollowErrors:
    """Errors of base_link against the path at its projection (plain floats).

    ``s`` arclength of the projection (m); ``lateral`` signed distance of
    base_link left of the path tangent (m); ``heading_error`` the body heading
    minus the wanted heading (rad, in [-pi, pi)): the tangent, + pi on reverse
    segments for a unicycle, + the segment's ``yaw_offset`` for a holonomic
    base; ``path_heading`` the tangent (rad); ``curvature`` (1/m), ``direction`` (+1/-1) and ``segment`` (index)
    of the path there.
    """

    s: float
    lateral: float
    heading_error: float
    path_heading: float
    curvature: float
    direction: int
    segment: int

    def as_dict(self) -> dict[str, float]:
        """The errors as a flat dict of floats (for recording one time step)."""
        return {
            "s": self.s,
            "lateral": self.lateral,
            "heading_error": self.heading_error,
            "path_heading": self.path_heading,
            "curvature": self.curvature,
            "direction": float(self.direction),
            "segment": float(self.segment),
        }


class PathFollower(Protocol):
    """The path-follower role (see module doc)."""

    family: str

    @property
    def path(self) -> Path: ...

    @property
    def last_errors(self) -> TrackingErrors | FollowErrors | None: ...

    def set_path(self, path: Path) -> None: ...

    def reset(self) -> None: ...

    def command(self, pose: ArrayLike, v: float, steering: float = 0.0) -> tuple[float, float]: ...


def check_pose(pose: ArrayLike, v: float) -> tuple[float, float, float, float]:
    """``(x, y, psi, v)`` as plain floats; ValueError naming a bad shape or a NaN/inf.

    ``pose`` must have shape (3,) = ``[x, y, psi]`` (m, m, rad); ``v`` in m/s.
    """
    arr = pose if isinstance(pose, np.ndarray) else np.asarray(pose, dtype=np.float64)
    if arr.shape != (3,):
        raise ValueError(f"pose must have shape (3,) = [x, y, psi], got {arr.shape}")
    x, y, psi, vv = float(arr[0]), float(arr[1]), float(arr[2]), float(v)
    if not all(math.isfinite(q) for q in (x, y, psi)):
        raise ValueError(f"pose contains NaN or inf: {arr!r}")
    if not math.isfinite(vv):
        raise ValueError(f"v must be a finite speed (m/s), got {v!r}")
    return x, y, psi, vv


class ProjectingFollower:
    """Shared state of the unicycle and holonomic followers: path, projection hint, last errors.

    Subclasses set ``family`` and implement ``command`` with :meth:`errors_at`.
    """

    family: str = ""

    def __init__(self, path: Path, window: float = 1.0):
        self._check_path(path)
        self.window = require_positive("window", window)
        self._path = path
        self._s: float | None = None
        self._last: FollowErrors | None = None

    @staticmethod
    def _check_path(path: Path) -> None:
        if not isinstance(path, Path):
            raise GuidanceError(f"path must be an agvnav.guidance.Path, got {type(path).__name__}")

    @property
    def path(self) -> Path:
        """The planned path of base_link."""
        return self._path

    @property
    def last_errors(self) -> FollowErrors | None:
        """Errors computed by the last command (None after a reset)."""
        return self._last

    def set_path(self, path: Path) -> None:
        """Follow a new path from its closest point (resets the follower)."""
        self._check_path(path)
        self._path = path
        self.reset()

    def reset(self) -> None:
        """Forget the projection hint and the last errors."""
        self._s = None
        self._last = None

    def heading_offset(self, direction: int, yaw_offset: float) -> float:
        """Wanted heading minus path tangent (rad) on a segment: pi on reverse segments (subclasses extend)."""
        return math.pi if direction < 0 else 0.0

    def errors_at(self, x: float, y: float, psi: float) -> FollowErrors:
        """Project base_link ``(x, y)`` (m) with heading ``psi`` (rad) and record the errors.

        The wanted heading is the path tangent plus :meth:`heading_offset`.
        """
        window = None if self._s is None else self.window
        pr = self._path.project_point(x, y, self._s, window)
        wanted = pr.heading + self.heading_offset(pr.direction, self._path.segments[pr.segment].yaw_offset)
        err = FollowErrors(
            s=pr.s,
            lateral=pr.lateral,
            heading_error=wrap_angle_scalar(psi - wanted),
            path_heading=pr.heading,
            curvature=pr.curvature,
            direction=int(pr.direction),
            segment=int(pr.segment),
        )
        self._s = pr.s
        self._last = err
        return err
