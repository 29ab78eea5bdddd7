"""Path followers for unicycle vehicles: differential, tracked, the differential tractor.

A unicycle (``x' = v cos(theta)``, ``y' = v sin(theta)``, ``theta' = omega``
[seed003 §3.2.4]) turns about base_link (the axle midpoint) at any yaw rate, so each
law here returns a yaw rate ``omega`` (rad/s) for the caller's speed ``v``
(m/s); ``v_lateral`` is always 0. Every law works in the frame of the
direction of motion: heading ``psi_m = psi`` on a forward segment and
``psi + pi`` on a reverse one (the path tangent always points the way the
vehicle moves, :mod:`agvnav.guidance.paths`). Backing along a segment is then
the forward law of a mirrored vehicle, with ``omega = d psi_m / dt`` the same
yaw rate, so reverse segments are followed alike. The follower uses ``|v|``
as the speed along the segment's own direction, so a speed whose sign lags
the segment at a cusp (where it is about 0) does not flip the law.

Followers (all take ``convergence_distance`` (m): the linearised lateral
error after an offset stays within 2 % beyond it, as for the tricycle
controllers, :func:`agvnav.guidance.controller.loop_convergence_distance`):

* :class:`KanayamaPathFollower` - Kanayama et al. 1990 with the reference at
  the robot's projection (:func:`~agvnav.guidance.kanayama.kanayama_path_rate`);
* :class:`UnicyclePurePursuit` - curvature of the arc through a look-ahead
  point (Coulter 1992), ``omega = |v| kappa``;
* :class:`UnicycleStanley` - Stanley's law (Thrun et al. 2006) steering a
  virtual front axle ahead of base_link in the direction of motion.

Tractor-trailer [seed003 §3.2.7]: the followers steer the tractor on the path;
they do not see the hitch angle, so the trailer's off-tracking on arcs is not
corrected, and backing a trailer is unstable (jackknife): such a plant must
not allow reverse segments (:func:`agvnav.guidance.check_path_feasible` with
``reverse_allowed=False``).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

import numpy as np
from numpy.typing import ArrayLike

from agvnav._validate import require_positive
from agvnav.geometry.angles import wrap_angle_scalar
from agvnav.guidance.baselines import MAX_STEERING_RAD
from agvnav.guidance.controller import DEFAULT_CONVERGENCE_DISTANCE_M
from agvnav.guidance.follower import FollowErrors, GuidanceError, ProjectingFollower, check_pose
from agvnav.guidance.gains import envelope_distance, modal_response
from agvnav.guidance.kanayama import CRITICAL_SETTLING_PER_DISTANCE, KanayamaGains, kanayama_path_rate
from agvnav.guidance.paths import Path

__all__ = [
    "KanayamaPathFollower",
    "UnicycleFollower",
    "UnicyclePurePursuit",
    "UnicycleStanley",
    "pure_pursuit_lookahead_for_distance",
]


def _one_of(name: str, value: float | None, convergence_distance: float | None) -> float | None:
    """The explicitly given tuning value, or None to design from the convergence distance."""
    if value is not None and convergence_distance is not None:
        raise GuidanceError(f"give {name} or convergence_distance, not both")
    return None if value is None else require_positive(name, value)


def _distance(convergence_distance: float | None) -> float:
    d = DEFAULT_CONVERGENCE_DISTANCE_M if convergence_distance is None else convergence_distance
    return require_positive("convergence_distance", d)


class UnicycleFollower(ProjectingFollower, ABC):
    """Shared ``command`` of the unicycle followers: project, then :meth:`yaw_rate` (rad/s)."""

    family = "unicycle"

    def __init__(self, path: Path, window: float = 1.0, max_rate: float = math.inf):
        super().__init__(path, window)
        if not max_rate > 0.0:
            raise GuidanceError(f"max_rate must be > 0 rad/s, got {max_rate!r}")
        self.max_rate = float(max_rate)

    def command(self, pose: ArrayLike, v: float, steering: float = 0.0) -> tuple[float, float]:
        """``(0.0, omega)``: yaw rate (rad/s) for base_link at ``pose`` moving at ``v`` (m/s); ``steering`` unused."""
        x, y, psi, v = check_pose(pose, v)
        e = self.errors_at(x, y, psi)
        speed = abs(v)
        if speed == 0.0:
            return 0.0, 0.0
        omega = self.yaw_rate(e, x, y, psi, speed)
        return 0.0, min(max(omega, -self.max_rate), self.max_rate)

    @abstractmethod
    def yaw_rate(self, e: FollowErrors, x: float, y: float, psi: float, speed: float) -> float:
        """Yaw rate (rad/s) from the errors ``e``, the pose and ``speed`` = |v| > 0 (m/s)."""


class KanayamaPathFollower(UnicycleFollower):
    """Kanayama's law as a path follower (reference = projection; the caller sets the speed).

    ``gains`` (:class:`~agvnav.guidance.kanayama.KanayamaGains`, only k_y and
    k_theta are used) or ``convergence_distance`` (m, critically damped:
    :meth:`KanayamaGains.from_convergence_distance`). The time-parametrised
    :class:`~agvnav.guidance.kanayama.KanayamaController` stays for the
    seed-004 pipeline.
    """

    def __init__(
        self,
        path: Path,
        *,
        gains: KanayamaGains | None = None,
        convergence_distance: float | None = None,
        window: float = 1.0,
        max_rate: float = math.inf,
    ):
        super().__init__(path, window, max_rate)
        if gains is not None and convergence_distance is not None:
            raise GuidanceError("give gains or convergence_distance, not both")
        self.gains = gains or KanayamaGains.from_convergence_distance(_distance(convergence_distance))

    def yaw_rate(self, e: FollowErrors, x: float, y: float, psi: float, speed: float) -> float:
        """Kanayama path rate (:func:`~agvnav.guidance.kanayama.kanayama_path_rate`)."""
        return kanayama_path_rate(e.lateral, e.heading_error, e.curvature, speed, self.gains)


def pure_pursuit_lookahead_for_distance(distance: float) -> float:
    """Look-ahead (m) of :class:`UnicyclePurePursuit` converging within ``distance`` (m).

    Linearised on a line, per metre: ``d'' + (2/l) d' + (2/l^2) d = 0``
    (poles ``(-1 +/- j)/l``), so the 2 % envelope distance
    (:func:`~agvnav.guidance.gains.envelope_distance`) is proportional to l;
    it is computed once for l = 1 m and scaled.
    """
    require_positive("distance", distance)
    a = np.array([[0.0, 1.0], [-2.0, -2.0]])  # l = 1 m, state (d, d')
    unit = envelope_distance(*modal_response(a, np.array([1.0, 0.0]), np.array([1.0, 0.0])))
    return distance / unit


class UnicyclePurePursuit(UnicycleFollower):
    """Pure pursuit (Coulter 1992) of the point ``lookahead`` m of arclength ahead of the projection.

    With the bearing ``alpha`` of the look-ahead point from the direction of
    motion, the arc through base_link tangent to its velocity and through the
    point has curvature ``kappa = 2 sin(alpha) / l`` (l taken as the look-ahead
    arclength, as :func:`~agvnav.guidance.baselines.pure_pursuit_steering`),
    and ``omega = |v| kappa``. ``lookahead`` (m) or ``convergence_distance``
    (m, :func:`pure_pursuit_lookahead_for_distance`).
    """

    def __init__(
        self,
        path: Path,
        *,
        lookahead: float | None = None,
        convergence_distance: float | None = None,
        window: float = 1.0,
        max_rate: float = math.inf,
    ):
        super().__init__(path, window, max_rate)
        given = _one_of("lookahead", lookahead, convergence_distance)
        self.lookahead = given or pure_pursuit_lookahead_for_distance(_distance(convergence_distance))

    def yaw_rate(self, e: FollowErrors, x: float, y: float, psi: float, speed: float) -> float:
        """``|v| 2 sin(alpha) / l`` (see class doc)."""
        gx, gy = self._path.extrapolate_point(e.s + self.lookahead)
        psi_motion = psi + (math.pi if e.direction < 0 else 0.0)
        alpha = wrap_angle_scalar(math.atan2(gy - y, gx - x) - psi_motion)
        return speed * 2.0 * math.sin(alpha) / self.lookahead


class UnicycleStanley(UnicycleFollower):
    """Stanley's law (Thrun et al. 2006) on a virtual front axle ``front_offset`` m ahead in the direction of motion.

    The unicycle is driven as a bicycle whose rear axle is base_link and whose
    steered front wheel F is at distance a (``front_offset``) ahead. With the
    lateral error d of base_link and the heading error h (motion heading minus
    tangent), F's lateral error in the same path frame is ``d_F = d + a sin h``
    (as seed 000 eq. 10 relates C to O) and Stanley's steering angle is

        delta = atan(a kappa) - h - atan(k d_F),

    where ``atan(a kappa)`` is the feed-forward that holds a steady turn on an
    arc of curvature kappa with base_link on the path. The bicycle's yaw rate
    ``omega = |v| tan(delta) / a`` is commanded directly (delta clipped to
    +/- 89 deg). Linearised on a line, per metre:
    ``d'' + (k + 1/a) d' + (k/a) d = 0``, poles ``-k`` and ``-1/a``. From
    ``convergence_distance`` D both are put at ``-x/D`` (critically damped,
    x = :data:`~agvnav.guidance.kanayama.CRITICAL_SETTLING_PER_DISTANCE`);
    or give ``gain_per_m`` k (1/m) and ``front_offset`` a (m).
    """

    def __init__(
        self,
        path: Path,
        *,
        gain_per_m: float | None = None,
        front_offset: float | None = None,
        convergence_distance: float | None = None,
        window: float = 1.0,
        max_rate: float = math.inf,
    ):
        super().__init__(path, window, max_rate)
        k = _one_of("gain_per_m", gain_per_m, convergence_distance)
        a = _one_of("front_offset", front_offset, convergence_distance)
        pole = CRITICAL_SETTLING_PER_DISTANCE / _distance(convergence_distance)
        self.gain_per_m = pole if k is None else k
        self.front_offset = 1.0 / pole if a is None else a

    def yaw_rate(self, e: FollowErrors, x: float, y: float, psi: float, speed: float) -> float:
        """``|v| tan(delta) / a`` with Stanley's delta on the virtual front axle (see class doc)."""
        a = self.front_offset
        d_front = e.lateral + a * math.sin(e.heading_error)
        delta = math.atan(a * e.curvature) - e.heading_error - math.atan(self.gain_per_m * d_front)
        delta = min(max(delta, -MAX_STEERING_RAD), MAX_STEERING_RAD)
        return speed * math.tan(delta) / a
