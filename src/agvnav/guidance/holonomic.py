"""Path follower for holonomic (mecanum) bases: lateral error and heading profile apart.

A four-wheel mecanum base (seed 003 §3.2.3, Swedish wheels) takes any body
twist ``(v_x, v_y, omega)``, so its heading need not follow the path tangent:
each path segment carries a ``yaw_offset`` (heading minus tangent, rad; pi/2
for sideways travel to the left, :mod:`agvnav.guidance.paths`), and a reverse
segment adds pi. :class:`HolonomicFollower` controls the two apart:

* translation: base_link moves at ``|v|`` along the tangent at its projection
  plus a normal correction ``u_n = -k |v| d`` (m/s) towards the path, d the
  lateral error (m, left positive). The base is commanded in velocity, so
  ``dd/ds = -k d`` per metre travelled: a first-order loop whose proportional
  term is all the control needs (a derivative term would only scale the gain,
  since d' is the commanded u_n itself);
* heading: ``omega = kappa |v| - k_h |v| h``, h = heading minus the wanted
  heading (rad), so the heading error too decays per metre, at any yaw offset.

Both gains come from ``convergence_distance`` D (m): ``k = ln(50) / D`` brings
an error to 2 % within D (:data:`~agvnav.guidance.gains.SETTLING_FRACTION`).
The world velocity is turned into the body frame: the follower returns
``(v_lateral, omega)`` = ``(v_y, omega)`` and records the whole body twist in
:attr:`HolonomicFollower.last_twist` ``(v_x, v_y, omega)``, the holonomic
plant command.
"""

from __future__ import annotations

import math

from numpy.typing import ArrayLike

from agvnav._validate import require_positive
from agvnav.guidance.controller import DEFAULT_CONVERGENCE_DISTANCE_M
from agvnav.guidance.follower import GuidanceError, ProjectingFollower, check_pose
from agvnav.guidance.gains import SETTLING_FRACTION
from agvnav.guidance.paths import Path

__all__ = ["HolonomicFollower", "holonomic_body_twist"]


def holonomic_body_twist(
    speed: float, normal_speed: float, path_heading: float, psi: float
) -> tuple[float, float]:
    """Body-frame ``(v_x, v_y)`` (m/s) of the world velocity ``speed t + normal_speed n``.

    ``t`` is the path tangent at ``path_heading`` (rad), ``n`` its left normal,
    ``psi`` the body heading (rad): the velocity is rotated by ``-psi``.
    """
    rel = path_heading - psi
    c, s = math.cos(rel), math.sin(rel)
    return speed * c - normal_speed * s, speed * s + normal_speed * c


class HolonomicFollower(ProjectingFollower):
    """Lateral-error and heading-profile follower for a mecanum base (see module doc).

    Parameters
    ----------
    path : the planned path of base_link, with per-segment ``yaw_offset``.
    convergence_distance : D (m), default 2 m: both gains ``ln(50) / D`` (1/m).
    lateral_gain, heading_gain : k and k_h (1/m) given instead of D.
    window : projection search window (m).
    max_rate : |omega| limit (rad/s), default none.
    """

    family = "holonomic"

    def __init__(
        self,
        path: Path,
        *,
        convergence_distance: float | None = None,
        lateral_gain: float | None = None,
        heading_gain: float | None = None,
        window: float = 1.0,
        max_rate: float = math.inf,
    ):
        super().__init__(path, window)
        if convergence_distance is not None and (lateral_gain is not None or heading_gain is not None):
            raise GuidanceError("give convergence_distance or lateral_gain/heading_gain, not both")
        d = DEFAULT_CONVERGENCE_DISTANCE_M if convergence_distance is None else convergence_distance
        k = math.log(1.0 / SETTLING_FRACTION) / require_positive("convergence_distance", d)
        self.lateral_gain = k if lateral_gain is None else require_positive("lateral_gain", lateral_gain)
        self.heading_gain = k if heading_gain is None else require_positive("heading_gain", heading_gain)
        if not max_rate > 0.0:
            raise GuidanceError(f"max_rate must be > 0 rad/s, got {max_rate!r}")
        self.max_rate = float(max_rate)
        self.last_twist: tuple[float, float, float] | None = None

    def heading_offset(self, direction: int, yaw_offset: float) -> float:
        """Wanted heading minus tangent (rad): the segment's yaw_offset, + pi on a reverse segment."""
        return yaw_offset + (math.pi if direction < 0 else 0.0)

    def reset(self) -> None:
        """Forget the projection hint, the last errors and the last twist."""
        super().reset()
        self.last_twist = None

    def command(self, pose: ArrayLike, v: float, steering: float = 0.0) -> tuple[float, float]:
        """``(v_y, omega)`` (m/s, rad/s) for base_link at ``pose`` moving at ``v`` (m/s) along the path.

        ``steering`` is unused. The full body twist is in :attr:`last_twist`.
        """
        x, y, psi, v = check_pose(pose, v)
        e = self.errors_at(x, y, psi)
        speed = abs(v)
        normal = -self.lateral_gain * speed * e.lateral
        vx, vy = holonomic_body_twist(speed, normal, e.path_heading, psi)
        omega = speed * (e.curvature - self.heading_gain * e.heading_error)
        omega = min(max(omega, -self.max_rate), self.max_rate)
        self.last_twist = (vx, vy, omega)
        return vy, omega
