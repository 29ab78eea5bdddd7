"""Kanayama's tracking controller for differential and tracked robots.

Y. Kanayama, Y. Kimura, F. Miyazaki, T. Noguchi, "A stable tracking control
method for an autonomous mobile robot", ICRA 1990. A reference (virtual)
vehicle moves along the path with pose ``p_r = (x_r, y_r, theta_r)``, speed
``v_r`` and yaw rate ``omega_r``; the error in the robot frame is
``e = R(theta)^T (p_r - p)`` with ``e_theta = theta_r - theta``, and

    v     = v_r cos(e_theta) + K_x e_x
    omega = omega_r + v_r K_y e_y + |v_r| K_theta sin(e_theta)

With ``V = e_x^2 + e_y^2 + 2 (1 - cos e_theta) / K_y`` the closed loop gives
``dV/dt = -2 K_x e_x^2 - 2 |v_r| K_theta sin^2(e_theta) / K_y <= 0``. The
original law has ``v_r K_theta``; using ``|v_r|`` keeps the same Lyapunov
function decreasing when the reference reverses (v_r < 0), so reverse
segments of a path are tracked too (our extension, derived in the docstring
of :func:`kanayama_law`).

Gains per metre: ``K_y`` (1/m^2) and ``K_theta`` (1/m) act per distance
travelled, so the convergence *distance* does not change with speed. The
default is critically damped for small errors (``K_theta = 2 sqrt(K_y)``,
Kanayama's own choice) with a characteristic distance ``D``:
``K_y = 1/D^2``, ``K_theta = 2/D``.

The reference moves along an :class:`agvnav.guidance.paths.Path` at a cruise
speed with a trapezoidal profile (agvnav.actuators.profile_speed), stopping
at the path end and at every change of direction of travel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_positive
from agvnav.actuators import DriveGeometry, profile_speed
from agvnav.geometry import wrap_angle
from agvnav.guidance.gains import SETTLING_FRACTION
from agvnav.guidance.paths import Path

__all__ = [
    "CRITICAL_SETTLING_PER_DISTANCE",
    "DriveCommand",
    "KanayamaController",
    "KanayamaGains",
    "kanayama_law",
    "kanayama_path_rate",
    "tracking_error",
]


def _critical_settling(fraction: float = SETTLING_FRACTION) -> float:
    """x with ``(1 + x) exp(-x) = fraction`` (Newton on the log form, from x = 5)."""
    x = 5.0
    for _ in range(30):
        x -= (math.log1p(x) - x - math.log(fraction)) / (1.0 / (1.0 + x) - 1.0)
    return x


CRITICAL_SETTLING_PER_DISTANCE = _critical_settling()
"""x = 5.834: a critically damped loop with double pole -1/D per metre, started from a
lateral offset with zero slope, has error ``(1 + s/D) exp(-s/D)``, below 2 % beyond x D."""


@dataclass(frozen=True)
class DriveCommand:
    """Set-points for a differential/tracked drive.

    ``v`` (m/s) and ``omega`` (rad/s, CCW positive) of base_link, and the same
    as wheel (sprocket) speeds ``wheel_speeds = [right, left]`` (rad/s, [seed004 eq1]
    [seed004 eq2]). ``state`` names the controller state that produced it.
    """

    v: float
    omega: float
    wheel_speeds: NDArray[np.float64]
    state: str = ""


@dataclass(frozen=True)
class KanayamaGains:
    """``k_x`` (1/s), ``k_y`` (1/m^2), ``k_theta`` (1/m); all > 0."""

    k_x: float = 1.0
    k_y: float = 4.0
    k_theta: float = 4.0

    def __post_init__(self) -> None:
        require_positive("k_x", self.k_x)
        require_positive("k_y", self.k_y)
        require_positive("k_theta", self.k_theta)

    @classmethod
    def from_distance(cls, distance: float, k_x: float = 1.0) -> KanayamaGains:
        """Critically damped lateral dynamics with characteristic distance ``distance`` (m)."""
        require_positive("distance", distance)
        return cls(k_x=k_x, k_y=1.0 / distance**2, k_theta=2.0 / distance)

    @classmethod
    def from_convergence_distance(cls, distance: float, k_x: float = 1.0) -> KanayamaGains:
        """Critically damped gains whose lateral error falls below 2 % within ``distance`` (m).

        The characteristic distance is ``distance / CRITICAL_SETTLING_PER_DISTANCE``
        (see :data:`CRITICAL_SETTLING_PER_DISTANCE`), the same 2 % measure the
        tricycle controllers are tuned to.
        """
        require_positive("convergence_distance", distance)
        return cls.from_distance(distance / CRITICAL_SETTLING_PER_DISTANCE, k_x)


def tracking_error(pose: ArrayLike, ref_pose: ArrayLike) -> NDArray[np.float64]:
    """Kanayama's error ``(..., 3)`` = [e_x, e_y, e_theta]: the reference seen from the robot."""
    p = np.asarray(pose, dtype=np.float64)
    r = np.asarray(ref_pose, dtype=np.float64)
    c, s = np.cos(p[..., 2]), np.sin(p[..., 2])
    dx, dy = r[..., 0] - p[..., 0], r[..., 1] - p[..., 1]
    return np.stack([c * dx + s * dy, -s * dx + c * dy, wrap_angle(r[..., 2] - p[..., 2])], axis=-1)


def kanayama_law(
    error: ArrayLike, v_ref: ArrayLike, omega_ref: ArrayLike, gains: KanayamaGains
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(v, omega) from the error ``(..., 3)`` and the reference speeds ``(...)``.

    Kanayama et al. 1990, their control rule (5), with ``|v_r|`` in the heading term. Proof
    sketch: the error dynamics are ``e_x' = omega e_y - v + v_r cos e_theta``,
    ``e_y' = -omega e_x + v_r sin e_theta``, ``e_theta' = omega_r - omega``; so
    ``V' = 2 e_x (v_r cos e_theta - v) + 2 e_y v_r sin e_theta
    + 2 sin e_theta (omega_r - omega) / K_y`` and the law makes it
    ``-2 K_x e_x^2 - 2 |v_r| K_theta sin^2 e_theta / K_y``.
    """
    e = np.asarray(error, dtype=np.float64)
    vr = np.asarray(v_ref, dtype=np.float64)
    v = vr * np.cos(e[..., 2]) + gains.k_x * e[..., 0]
    omega = np.asarray(omega_ref) + vr * gains.k_y * e[..., 1] + np.abs(vr) * gains.k_theta * np.sin(e[..., 2])
    return v, omega


def kanayama_path_rate(
    lateral: float, heading_error: float, curvature: float, speed: float, gains: KanayamaGains
) -> float:
    """Yaw rate (rad/s) of Kanayama's law with the reference at the robot's projection on the path.

    Path-following form of Kanayama et al. 1990, control rule (5), in the frame of the
    direction of motion (the body heading, + pi when reversing, so a reverse
    segment is the forward law mirrored). The reference is the foot of the
    perpendicular from the robot, moving at the caller's ``speed`` = |v| (m/s)
    along the tangent, so ``omega_r = curvature * speed``. With ``lateral`` = d
    (m, robot left of the tangent positive) and ``heading_error`` = h (rad,
    motion heading minus tangent), the robot-frame error to the foot is
    ``e_y = -d cos h``, ``e_theta = -h`` and

        omega = kappa |v| - |v| K_y d cos(h) - |v| K_theta sin(h).

    Linearised on a line, per metre travelled: ``d'' + K_theta d' + K_y d = 0``
    (critically damped with :meth:`KanayamaGains.from_distance`). The speed
    part of the law is not used: the caller sets the speed.
    """
    u = abs(speed)
    return u * (curvature - gains.k_y * lateral * math.cos(heading_error) - gains.k_theta * math.sin(heading_error))


class KanayamaController:
    """Path follower for differential/tracked robots (nav2-like: set_path, command, reset).

    Parameters
    ----------
    gains : :class:`KanayamaGains` (default: critically damped over 0.5 m).
    cruise_speed : reference speed along the path (m/s, > 0).
    max_accel : reference acceleration/deceleration limit (m/s^2).
    geometry : converts (v, omega) to wheel speeds ([seed004 eq1] [seed004 eq2]).
    max_speed, max_omega : saturation of the commands (m/s, rad/s).
    """

    def __init__(
        self,
        gains: KanayamaGains | None = None,
        cruise_speed: float = 0.15,
        max_accel: float = 0.2,
        geometry: DriveGeometry | None = None,
        max_speed: float = 0.3,
        max_omega: float = 1.0,
    ):
        self.gains = gains or KanayamaGains.from_distance(0.5)
        self.cruise_speed = require_positive("cruise_speed", cruise_speed)
        self.max_accel = require_positive("max_accel", max_accel)
        self.geometry = geometry or DriveGeometry()
        self.max_speed = require_positive("max_speed", max_speed)
        self.max_omega = require_positive("max_omega", max_omega)
        self.path: Path | None = None
        self.reset()

    def set_path(self, path: Path) -> None:
        """Follow ``path`` from its start; stops are the path end and direction changes."""
        if not isinstance(path, Path):
            raise ValueError(f"path must be an agvnav.guidance.paths.Path, got {type(path).__name__}")
        self.path = path
        starts = path.segment_starts
        dirs = np.array([seg.direction for seg in path.segments])
        cusps = [starts[i] for i in range(1, len(dirs)) if dirs[i] != dirs[i - 1]]
        self._stops = np.array(cusps + [path.length])
        self.reset()

    def reset(self) -> None:
        """Put the reference back at the path start, at rest."""
        self.s_ref, self.speed_ref = 0.0, 0.0
        self._t: float | None = None

    @property
    def finished(self) -> bool:
        """True once the reference has stopped at the path end."""
        return self.path is not None and self.s_ref >= self.path.length - 1e-9 and self.speed_ref == 0.0

    def reference(self) -> tuple[NDArray[np.float64], float, float]:
        """Reference pose ``(3,)``, body speed v_r (m/s, signed) and yaw rate omega_r (rad/s)."""
        path = self._require_path()
        direction = int(path.direction_at(min(self.s_ref + 1e-9, path.length)))
        heading = float(path.heading_at(self.s_ref)) + (0.0 if direction > 0 else math.pi)
        xy = path.point_at(self.s_ref)
        curvature = float(path.curvature_at(min(self.s_ref + 1e-9, path.length)))
        pose = np.array([xy[0], xy[1], float(wrap_angle(heading))])
        return pose, direction * self.speed_ref, curvature * self.speed_ref

    def command(self, t: float, pose: ArrayLike) -> DriveCommand:
        """Set-points at time ``t`` (s) for the robot at ``pose (3,)`` (m, m, rad) in ``map``."""
        p = require_finite("pose", pose).reshape(3)
        self._advance_reference(float(t))
        ref, v_r, omega_r = self.reference()
        v_law, omega_law = kanayama_law(tracking_error(p, ref), v_r, omega_r, self.gains)
        v = float(np.clip(v_law, -self.max_speed, self.max_speed))
        omega = float(np.clip(omega_law, -self.max_omega, self.max_omega))
        state = "finished" if self.finished else "tracking"
        return DriveCommand(v, omega, self.geometry.to_wheels(v, omega), state)

    def _advance_reference(self, t: float) -> None:
        path = self._require_path()
        dt = 0.0 if self._t is None else t - self._t
        if dt < 0.0:
            raise ValueError(f"time went backwards: {t} < {self._t}")
        self._t = t
        if dt == 0.0:
            return
        stop = path.length
        if self.s_ref < path.length - 1e-9:  # next stop: a change of direction or the end
            stop = float(self._stops[np.searchsorted(self._stops, self.s_ref + 1e-9)])
        remaining = stop - self.s_ref
        speed = profile_speed(self.speed_ref, self.cruise_speed, remaining, dt, self.max_accel, self.max_accel)
        self.speed_ref = float(speed)
        if remaining <= 1e-6:
            self.speed_ref, self.s_ref = 0.0, stop
            return
        self.s_ref = min(self.s_ref + self.speed_ref * dt, stop)

    def _require_path(self) -> Path:
        if self.path is None:
            raise ValueError("no path set: call set_path(path) first")
        return self.path
