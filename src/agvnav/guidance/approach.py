"""Station approach of a steered vehicle: hold the heading over the last centimetres before the stop.

Why (issue 14, warehouse_arcs N1): a tricycle moves its guided point sideways only by
turning its body, and it cannot turn at standstill. Correcting a lateral error
``delta`` of the guided point O within a distance ``d`` takes a heading excursion of
about ``2 delta / d`` (an S: turn away, turn back), and the stop lands wherever that
excursion is. During the creep-in (the last ~0.3 m at ~0.05 m/s) the position estimate
still wanders laterally by ~2-5 mm (EKF convergence at low speed, the reflectors' survey
error) while its heading stays within ~0.02 deg of the truth; the seed-000 law on O
(convergence ~1 m, its error decaying in ~0.15 m) turns that wandering into heading
swings up to ~0.8 deg at the stop, beyond the 0.5 deg a station allows, for a lateral gain
of a few mm against a 10 mm tolerance.

So, as a stacker's final positioning does (the forks enter the load straight): over the
last ``hold_distance`` m before the end of the path the steering no longer corrects the
lateral error; it holds the heading of the path there (the station heading). The lateral
error stays what the approach left (the law on O has had at least 0.5 m to bring it in,
``sim.mission.MIN_APPROACH_M``), plus the heading error integrated over the hold (at most
``xi0 * heading_distance``: 0.8 deg over 0.1 m is 1.4 mm).

The heading law: with O's arclength ``s`` along the motion, ``d psi / ds = tan(gamma) / L``
([seed000 eq8]: ``psi' = v sin(gamma) / L``, ``v_O = v cos(gamma)``), so the steering target
``gamma* = gamma_ss + atan(-sign(v) L xi / heading_distance)`` makes the heading error ``xi``
decay as ``exp(-s / heading_distance)`` in distance, whatever the speed; a first-order
servo (``servo_tau``, :func:`agvnav.guidance.baselines.servo_rate`) steers towards it.
"""

from __future__ import annotations

import math
from typing import Any

from numpy.typing import ArrayLike

from agvnav.guidance.baselines import servo_rate
from agvnav.guidance.errors import TrackingErrors
from agvnav.guidance.follower import GuidanceError
from agvnav.guidance.paths import Path

__all__ = ["HeadingHoldApproach"]


class HeadingHoldApproach:
    """A steered path follower (:class:`agvnav.guidance.steered.SteeredFollower`) that holds the heading near a stop.

    Delegates everything to ``follower`` except the steering rate over the last
    ``hold_distance`` m (of the tracked point's progress) before the end of a path that
    ends at ``end`` (x, y; m, within 1 mm): there the rate is the heading hold's (module
    doc). Paths ending elsewhere (a cusp, a handover) are followed by ``follower`` alone.

    Parameters (SI units): ``hold_distance`` (m): the mission's creep distance, the stretch
    driven slowly into the station. ``heading_distance`` (m, default a third of
    ``hold_distance``): the distance constant of the heading's decay, so that by the stop
    (three constants) what is left of the heading error at the start of the hold is
    ``exp(-3)``, 5 %; shorter would steer harder on the heading estimate's jitter (its
    ~0.02 deg gives ``L xi / heading_distance`` ~ 0.2 deg of steering at 0.1 m), longer
    would leave more of the initial error. ``servo_tau`` (s, default 0.1, the pure-pursuit
    and Stanley baselines' steering servo): at the 0.05 m/s creep the heading loop's time
    constant is ``heading_distance / v`` = 2 s, twenty servo constants, so the loop sees
    the steering as immediate.
    """

    family = "steered"

    def __init__(
        self,
        follower: Any,
        end: tuple[float, float],
        hold_distance: float,
        heading_distance: float | None = None,
        servo_tau: float = 0.1,
    ) -> None:
        if getattr(follower, "family", None) != "steered":
            raise GuidanceError("the heading hold steers a steered vehicle: give a steered follower")
        hd = hold_distance / 3.0 if heading_distance is None else heading_distance
        for name, v in (("hold_distance", hold_distance), ("heading_distance", hd), ("servo_tau", servo_tau)):
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"{name} must be positive (m or s), got {v!r}")
        if len(end) != 2 or not all(math.isfinite(float(c)) for c in end):
            raise ValueError(f"end must be a finite point (x, y) in m, got {end!r}")
        self.follower = follower
        self.end = (float(end[0]), float(end[1]))
        self.hold_distance = float(hold_distance)
        self.heading_distance = float(hd)
        self.servo_tau = float(servo_tau)
        self.holding = False
        """True while the last command held the heading."""
        self._stops_at_end = self._ends_at(follower.path)

    def _ends_at(self, path: Path) -> bool:
        p = path.point_at(path.length)
        return math.hypot(float(p[0]) - self.end[0], float(p[1]) - self.end[1]) <= 1e-3

    @property
    def name(self) -> str:
        """The wrapped follower's law."""
        return str(getattr(self.follower, "name", ""))

    @property
    def point(self) -> str:
        """The tracked point, "C" or "O"."""
        return str(self.follower.point)

    @property
    def path(self) -> Path:
        """The planned path of the tracked point."""
        return self.follower.path

    @property
    def last_errors(self) -> TrackingErrors | None:
        """The wrapped follower's errors of the last command (None after a reset)."""
        return self.follower.last_errors

    def set_path(self, path: Path) -> None:
        """Follow a new path (resets); the heading is held near its end only if it ends at ``end``."""
        self.follower.set_path(path)
        self._stops_at_end = self._ends_at(path)
        self.holding = False

    def reset(self) -> None:
        """Forget the projection hint and the last errors."""
        self.follower.reset()
        self.holding = False

    def command(self, pose: ArrayLike, v: float, steering: float = 0.0) -> tuple[float, float]:
        """``(0.0, steering rate)`` (rad/s): the wrapped law's, or the heading hold's near the stop.

        ``pose`` the estimated base_link pose (m, m, rad), ``v`` the tracked point's signed speed (m/s),
        ``steering`` the measured steering angle (rad).
        """
        v_lat, rate = self.follower.command(pose, v, steering)
        e = self.follower.last_errors
        self.holding = bool(self._stops_at_end and e is not None
                            and self.follower.path.length - float(e.s) <= self.hold_distance)
        if not self.holding or e is None:
            return v_lat, rate
        if v == 0.0:
            return 0.0, 0.0
        lever = float(self.follower.wheelbase) * float(e.xi) / self.heading_distance
        target = float(e.gamma_ss) + math.atan(-lever if v > 0.0 else lever)
        hold = float(servo_rate(target, float(steering), self.servo_tau))
        if abs(steering) >= self.follower.max_steer and hold * steering > 0.0:
            hold = 0.0
        return 0.0, hold

    def drive_speed(self, v: float, steering: float) -> float:
        """Speed (m/s) of the driven wheel for the tracked point's speed ``v`` (m/s): the wrapped follower's."""
        return float(self.follower.drive_speed(v, steering))
