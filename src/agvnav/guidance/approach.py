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

The heading law (derived from the tricycle kinematics [seed000 eq8]: ``psi' = v sin(gamma) / L``,
O moving at ``v cos(gamma)`` along the body axis, C at ``v`` along the wheel). With ``d`` the
sign of ``v``, ``kappa`` the path curvature and ``lat`` the guided point's lateral offset
(left of the tangent along the motion, ``d eps``), the path tangent at the guided point's
projection turns at ``kappa |v_P| cos(a) / (1 - kappa lat)`` (``a`` the angle of the point's
velocity to the tangent: ``xi`` for O, ``xi_r`` for C). The heading error
``xi = psi - psi_ref`` (relative to the feed-forward, :mod:`agvnav.guidance.errors`) then
evolves along the guided point's own arclength ``s`` as

* point O (``ds = |v| cos(gamma) dt``): ``d xi / ds = d tan(gamma) / L - kappa cos(xi) / (1 - kappa lat)``;
* point C (``ds = |v| dt``): ``d xi / ds = d sin(gamma) / L - kappa cos(xi_r) / (1 - kappa lat)``.

Setting ``d xi / ds = -xi / heading_distance`` gives the steering target (:func:`hold_steering`),
with the feed-forward ``tan(gamma_ss) = d L kappa`` (O) or ``sin(gamma_ss) = d L kappa`` (C) and
``q = cos(.) / (1 - kappa lat)``:

* O: ``gamma* = atan(q tan(gamma_ss) - d L xi / heading_distance)``;
* C: ``gamma* = asin(q sin(gamma_ss) - d L xi / heading_distance)``, where ``q`` holds
  ``xi_r = xi + gamma* - gamma_ss`` and so ``gamma*`` itself (solved in closed form by :func:`hold_steering`),

so that ``xi`` decays as ``exp(-s / heading_distance)`` in distance, whatever the speed and
the curvature (on a line ``gamma_ss = 0``, ``q`` drops out). The earlier
``gamma_ss + atan(-d L xi / heading_distance)`` was this only on a line: on an arc its decay rate
was ``1 + tan(gamma_ss)^2`` times too fast for O to first order (measured at L / R = 0.4 and 0.8 deg:
1.10 forward, 1.22 backing; 0.92 for C). A first-order servo
(``servo_tau``, :func:`agvnav.guidance.baselines.servo_rate`) steers towards the target.
"""

from __future__ import annotations

import math
from typing import Any

from numpy.typing import ArrayLike

from agvnav.guidance.baselines import servo_rate
from agvnav.guidance.errors import TrackingErrors
from agvnav.guidance.follower import GuidanceError
from agvnav.guidance.paths import Path

__all__ = ["HeadingHoldApproach", "hold_steering"]


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
        target = hold_steering(e, float(self.follower.wheelbase), self.point, 1.0 if v > 0.0 else -1.0,
                               self.heading_distance)
        hold = float(servo_rate(target, float(steering), self.servo_tau))
        if abs(steering) >= self.follower.max_steer and hold * steering > 0.0:
            hold = 0.0
        return 0.0, hold

    def drive_speed(self, v: float, steering: float) -> float:
        """Speed (m/s) of the driven wheel for the tracked point's speed ``v`` (m/s): the wrapped follower's."""
        return float(self.follower.drive_speed(v, steering))


def hold_steering(errors: TrackingErrors, wheelbase: float, point: str, direction: float,
                  heading_distance: float) -> float:
    """The steering angle (rad) that makes the heading error decay as ``exp(-s / heading_distance)``.

    ``errors`` the guided ``point``'s errors ("O" or "C", :mod:`agvnav.guidance.errors`: ``xi``,
    ``xi_r``, ``eps_o``/``eps_c``, ``kappa``), ``wheelbase`` L (m), ``direction`` the sign of the
    speed, ``heading_distance`` hd (m); ``s`` is the guided point's arclength. Derived from
    [seed000 eq8] in the module doc: ``tan(gamma*)`` (O) or ``sin(gamma*)`` (C) ``= d L (q kappa - xi / hd)``
    with ``q = cos(xi or xi_r) / (1 - kappa d eps)``; on a line ``atan(-d L xi / hd)`` or its asin.
    For C, ``xi_r = xi + gamma* - gamma_ss`` depends on the target itself: ``sin(g) = A cos(g + phi) - B``
    (``A = d L kappa / (1 - kappa d eps_c)``, ``B = d L xi / hd``, ``phi = xi - gamma_ss``) is solved in
    closed form, ``g = atan2(A cos(phi), 1 + A sin(phi)) + asin(-B / R)``,
    ``R = hypot(1 + A sin(phi), A cos(phi))``.
    """
    d = 1.0 if direction > 0.0 else -1.0
    kappa, xi = float(errors.kappa), float(errors.xi)
    b = d * wheelbase * xi / heading_distance  # on a line O's target is atan(-b), bit for bit the earlier one
    if point == "O":
        q = math.cos(xi) / (1.0 - kappa * d * float(errors.eps_o))
        return math.atan(d * wheelbase * q * kappa - b)
    if point == "C":  # xi_r = xi + gamma - gamma_ss moves with gamma: sin(g) = A cos(g + phi) - B
        a = d * wheelbase * kappa / (1.0 - kappa * d * float(errors.eps_c))
        phi = xi - float(errors.gamma_ss)
        c1, c2 = 1.0 + a * math.sin(phi), a * math.cos(phi)  # c1 sin(g) - c2 cos(g) = R sin(g - delta) = -b
        r = math.hypot(c1, c2)
        return math.atan2(c2, c1) + math.asin(min(1.0, max(-1.0, -b / r)))
    raise ValueError(f"point must be 'O' or 'C', got {point!r}")
