"""Fine positioning at standstill of a spot-turning vehicle after a station stop (issue 14).

* :class:`FinePositioner` - settle, check, turn-drive-turn corrections commanded open loop;
* :func:`move_profile` - the per-step rates of one such move (trapezoidal, exact integral).

Used by the mission autopilot (:mod:`agvnav.navigation.mission`), which wires it to the plant's twist command.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import wrap_angle_scalar

__all__ = ["MAX_MOVE_STEPS", "FinePositioner", "move_profile", "stopping_rate"]


class FinePositioner:
    """Fine positioning of a spot-turning vehicle at standstill after a station stop.

    Why (warehouse_mission_differential, issue 14): the creep-in stops the guided point
    where the *estimate* says the station is, at that instant. Two things leave it off:
    the estimate can reach the station a few mm off (after a poorly covered stretch
    of lane the EKF's error decays over seconds while its covariance already claims
    ~1 mm: N2, seed 1, 6 mm lateral at the stop command, converging to 2.7 mm within
    2 s of standing), and the wheels run on: their PI speed loops integrate the speed
    error, so at rest each wheel has turned the *integral of its command*, and the
    lag accumulated while moving (3-9 mm at the 0.05 m/s creep; ~0.3 deg after a spot
    turn stopped on the estimate) is paid out after the zero command. So, as a real
    AGV's final positioning does:

    1. *settle*: stand still until the estimate stops moving: the mean estimated pose
       over the latest revolution differs from the one ``settle_revolutions`` earlier
       by less than ``tolerance / 4`` (and the heading by less than ``heading_tolerance / 2``),
       or for at most ``settle_timeout`` s. This also waits out the speed loops' catch-up;
    2. *check*: the estimated guided point (``offset`` m ahead of base_link) against
       the station; within ``tolerance`` and the heading within ``heading_tolerance``,
       the stop is done;
    3. else *correct* in three commanded moves, each computed from the settled
       estimate and followed by a settle: turn on the spot to face the base_link
       target (the station point ``offset`` m back along the station heading),
       forward or backing up whichever needs the smaller turn; drive straight the
       distance to it along the heading; turn to the station heading. A move is a
       speed profile (accel ``max_accel`` or ``turn_accel``, peak ``speed`` or
       ``turn_rate``) whose integral is exactly the move, commanded open loop: the speed
       loops then end it at rest about where it was asked (stopping when the estimate
       arrives would leave their lag as run-on; what the sampled loops still miss, ~15 %
       of a short turn, the next check takes up). Only the heading off: the last turn alone.
       At most ``attempts`` position corrections and as many heading-only turns,
       then the stop stands as it is.

    Parameters (SI units): ``twist(v, omega)`` the plant command of a body twist (m/s,
    rad/s); ``revolution_s`` the goniometer's revolution period (s); ``max_accel`` (m/s^2)
    the traction limit; ``turn_accel`` (rad/s^2) the spot-turn acceleration (the traction
    limit at the wheels: ``max_accel`` over the wheels' lever, half the track of a differential
    base, half length plus half width of an X mecanum one: ``navigation.fine_positioning.spot_turn_lever``);
    ``turn_rate`` (rad/s) the
    vehicle's spot-turn rate (``mission.turn_rate_deg_s``, the planner's).

    ``tolerance`` (m, default 2 mm): the position the correction aims within. Standing
    still, the estimate jitters by a few tenths of a mm and keeps the survey floor of
    its reflectors (2 mm survey error over ~10 reflectors: ~1 mm), so a smaller
    tolerance would chase the estimate's own error with moves. ``heading_tolerance``
    (rad, default 0.1 deg): the heading it aims within, with the same margin, a fifth
    of the 0.5 deg a station stop is allowed (issue 14); the standstill heading
    estimate jitters by ~0.02 deg and a spot turn lands within ~15 %, so a tighter
    one spends the turns on noise.

    ``settle_revolutions`` (default 8): the settle window. At standstill the estimate's
    error decays with a time constant of about 1 s (8 revolutions at 8 Hz, measured in
    the warehouse); over one time constant an exponential decay moves by 63 % of what
    remains, so a move under ``tolerance / 4`` means under ~0.8 mm left to converge.
    ``settle_timeout`` (default 5 s, five time constants): past it the estimate's
    motion is noise, not convergence.

    ``speed`` (m/s, default half the tolerance per revolution: 8 mm/s at 8 Hz): the
    goniometer fixes during a correction are never more than half the tolerance
    apart along it, and the speed loops' lag stays a fraction of a mm.

    ``attempts`` (default 3): a correction driven on a settled estimate removes most of
    the error; the second takes up what the first one's turns translated the base
    (the two wheels' loops lag unequally: up to ~3 mm on a 50 deg turn); the third is
    margin. ``max_correction`` (m, default 0.1, the path autopilot's ``end_tolerance``):
    a settled estimate further off than the autopilot accepted as arrived contradicts
    the arrival (a positioning fault, not a stop error): no correction is driven on it.
    """

    def __init__(
        self,
        twist: Callable[[float, float], tuple[float, ...]],
        revolution_s: float,
        max_accel: float,
        turn_accel: float,
        turn_rate: float,
        tolerance: float = 0.002,
        heading_tolerance: float = math.radians(0.1),
        settle_revolutions: int = 8,
        settle_timeout: float = 5.0,
        speed: float | None = None,
        attempts: int = 3,
        max_correction: float = 0.1,
    ) -> None:
        for name, v in (("revolution_s", revolution_s), ("max_accel", max_accel), ("turn_accel", turn_accel),
                        ("turn_rate", turn_rate), ("tolerance", tolerance), ("heading_tolerance", heading_tolerance),
                        ("settle_timeout", settle_timeout), ("max_correction", max_correction)):
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"{name} must be positive, got {v!r}")
        if settle_revolutions < 1:
            raise ValueError(f"settle_revolutions must be at least 1, got {settle_revolutions!r}")
        if attempts < 0:
            raise ValueError(f"attempts must be non-negative, got {attempts!r}")
        self._twist = twist
        self.turn_rate, self.heading_tolerance = float(turn_rate), float(heading_tolerance)
        self.revolution_s = float(revolution_s)
        self.max_accel, self.turn_accel = float(max_accel), float(turn_accel)
        self.tolerance = float(tolerance)
        self.settle_window = settle_revolutions * self.revolution_s
        self.settle_timeout = max(float(settle_timeout), self.settle_window + 2.0 * self.revolution_s)
        self.speed = 0.5 * self.tolerance / self.revolution_s if speed is None else float(speed)
        if not (math.isfinite(self.speed) and self.speed > 0.0):
            raise ValueError(f"speed must be positive, got {speed!r}")
        self.attempts = int(attempts)
        self.max_correction = float(max_correction)
        self.corrections = 0
        """position corrections driven at the current station."""
        self.turns = 0
        """heading-only turns at the current station."""
        self._phase = "idle"
        self._target = (0.0, 0.0, 0.0)
        self._offset = 0.0
        self._t = 0.0
        self._hist: list[tuple[float, float, float, float]] = []
        self._queue: list[str] = []
        self._move: list[float] = []
        self._move_kind = ""
        self._turn_to = 0.0

    def start(self, x: float, y: float, heading: float, offset: float = 0.0) -> None:
        """Begin at a station: guided point ``offset`` m ahead of base_link onto ``(x, y)`` (m), ``heading`` (rad)."""
        self._target = (float(x), float(y), float(heading))
        self._offset = float(offset)
        self.corrections = self.turns = 0
        self._queue = []
        self._settle()

    def _settle(self) -> None:
        self._phase, self._t, self._hist = "settle", 0.0, []

    def _base_target(self) -> tuple[float, float]:
        x, y, h = self._target
        return x - self._offset * math.cos(h), y - self._offset * math.sin(h)

    def _mean(self, lo: float, hi: float) -> tuple[float, float, float] | None:
        sel = [p for p in self._hist if lo <= p[0] <= hi]
        if not sel:
            return None
        psi0 = sel[0][3]
        return (sum(p[1] for p in sel) / len(sel), sum(p[2] for p in sel) / len(sel),
                psi0 + sum(wrap_angle_scalar(p[3] - psi0) for p in sel) / len(sel))

    def _settled(self) -> bool:
        """True once the estimate moved less than tolerance/4 (and the heading tolerance) over the window."""
        if self._t > self.settle_timeout:
            return True
        if self._t < self.settle_window + self.revolution_s:
            return False
        now = self._mean(self._t - self.revolution_s, self._t)
        then = self._mean(self._t - self.settle_window - self.revolution_s, self._t - self.settle_window)
        if now is None or then is None:
            return False
        return (math.hypot(now[0] - then[0], now[1] - then[1]) < 0.25 * self.tolerance
                and abs(wrap_angle_scalar(now[2] - then[2])) < 0.5 * self.heading_tolerance)

    def _check(self, pose: NDArray[np.float64], dt: float) -> tuple[float, ...] | None:
        """After settling: done (None), or the first command of a correction or a heading turn."""
        x, y, psi = (float(c) for c in pose)
        heading_ok = abs(wrap_angle_scalar(psi - self._target[2])) <= self.heading_tolerance
        px, py = x + self._offset * math.cos(psi), y + self._offset * math.sin(psi)
        miss = math.hypot(self._target[0] - px, self._target[1] - py)
        if self.tolerance < miss <= self.max_correction and self.corrections < self.attempts:
            self.corrections += 1
            tx, ty = self._base_target()
            bearing = math.atan2(ty - y, tx - x)
            forward = abs(wrap_angle_scalar(bearing - psi)) <= 0.5 * math.pi  # else back up: the smaller turn
            self._turn_to = bearing if forward else wrap_angle_scalar(bearing + math.pi)
            self._queue = ["face", "drive", "heading"]
        elif not heading_ok and self.turns < self.attempts:
            self.turns += 1
            self._queue = ["heading"]
        else:
            self._phase = "done"
            return None
        return self._next_move(pose, dt)

    def _next_move(self, pose: NDArray[np.float64], dt: float) -> tuple[float, ...] | None:
        """Plan the next queued move from the settled ``pose`` and give its first command (or check)."""
        if not self._queue:
            return self._check(pose, dt)
        kind = self._queue.pop(0)
        psi = float(pose[2])
        if kind == "drive":
            tx, ty = self._base_target()
            amount = (tx - float(pose[0])) * math.cos(psi) + (ty - float(pose[1])) * math.sin(psi)
            self._move = move_profile(amount, self.speed, self.max_accel, dt)
        else:
            heading = self._turn_to if kind == "face" else self._target[2]
            self._move = move_profile(wrap_angle_scalar(heading - psi), self.turn_rate, self.turn_accel, dt)
        self._move_kind = "drive" if kind == "drive" else "turn"
        self._phase = "move"
        return self._step_move(pose, dt)

    def _step_move(self, pose: NDArray[np.float64], dt: float) -> tuple[float, ...] | None:
        if not self._move:
            self._settle()
            return self.command_pose(pose, dt)
        rate = self._move.pop(0)
        return self._twist(rate, 0.0) if self._move_kind == "drive" else self._twist(0.0, rate)

    def command_pose(self, pose: NDArray[np.float64], dt: float) -> tuple[float, ...] | None:
        """One ``dt`` s step from the estimated base_link ``pose`` (m, m, rad): the plant command, or None when done."""
        if self._phase == "settle":
            self._t += dt
            self._hist.append((self._t, float(pose[0]), float(pose[1]), float(pose[2])))
            if not self._settled():
                return self._twist(0.0, 0.0)
            return self._next_move(pose, dt)
        if self._phase == "move":
            return self._step_move(pose, dt)
        return None

    def command(self, estimator: Any, dt: float) -> tuple[float, ...] | None:
        """The plant command for the next ``dt`` s from ``estimator.pose``, or None once the stop is done.

        Without a defined estimate the vehicle stands still and the stop is done as it is.
        """
        pose = np.asarray(estimator.pose, dtype=float)
        if not np.all(np.isfinite(pose)):
            self._phase = "done"
            return None
        return self.command_pose(pose, dt)


#: Most steps :func:`move_profile` plans (a move beyond it is a parameter error, not a fine correction).
MAX_MOVE_STEPS = 1_000_000


def stopping_rate(left: float, step: float) -> float:
    """The largest rate (per s) from which a move held ``dt`` s per step can still stop exactly on ``left``.

    ``left`` is what is left to move divided by ``dt`` (the sum of the remaining rates, m/s or rad/s),
    ``step`` the largest change of rate per step (``accel * dt``). From a rate ``r = n step``
    the shortest stop drives ``r, r - step, r - 2 step, ...`` while positive and then rests,
    whose sum is ``f(r) = r + sum_j max(r - j step, 0) = step k (n - (k - 1) / 2)`` with
    ``k = ceil(n)``; any sum above it is reachable too (rates may dwell before braking).
    So the bound is ``f^-1(left)``: with ``k`` the least integer with ``k (k + 1) / 2 >= left / step``,
    ``r = left / k + (k - 1) step / 2``. It equals the continuous-looking bound
    ``step (sqrt(1/4 + 2 left / step) - 1/2)`` at whole ``k`` and lies below it in between
    (by ``step (k - n)(n + 1 - k) / (2 k)``), where that one would leave a last step
    more than ``step`` below its predecessor (or past the target).
    """
    if left <= 0.0:
        return 0.0
    q = left / step
    k = max(1, math.ceil(0.5 * (math.sqrt(1.0 + 8.0 * q) - 1.0)))
    while k > 1 and (k - 1) * k >= 2.0 * q:  # rounding: the least k with k (k + 1) / 2 >= q
        k -= 1
    while k * (k + 1) < 2.0 * q:
        k += 1
    return left / k + 0.5 * (k - 1) * step


def move_profile(amount: float, peak: float, accel: float, dt: float) -> list[float]:
    """Per-step rates (signed; m/s or rad/s) of a move of ``amount`` (m or rad) held ``dt`` s each.

    Trapezoidal in discrete steps: each rate is the previous one plus at most ``accel * dt``
    (m/s^2 or rad/s^2, times s), at most ``peak`` (m/s or rad/s), and at most the
    :func:`stopping_rate` of what is left, so that braking at ``accel`` ends exactly on
    ``amount``. Every step (the first from rest, and the rest after the last) changes the
    rate by at most ``accel * dt``, and the rates times ``dt`` sum to ``amount`` (to rounding).
    ``peak``, ``accel`` and ``dt`` must be positive and ``amount`` finite (ValueError naming it);
    a move needing more than :data:`MAX_MOVE_STEPS` steps is refused (ValueError).
    """
    for name, v in (("peak", peak), ("accel", accel), ("dt", dt)):
        if not (math.isfinite(v) and v > 0.0):
            raise ValueError(f"{name} must be positive and finite, got {v!r}")
    if not math.isfinite(amount):
        raise ValueError(f"amount must be finite (m or rad), got {amount!r}")
    total = abs(float(amount))
    step = accel * dt
    if total / (peak * dt) + peak / step + 2.0 > MAX_MOVE_STEPS:
        raise ValueError(f"amount {amount!r} at peak {peak!r} needs more than {MAX_MOVE_STEPS} steps of {dt!r} s")
    left, rate = total / dt, 0.0
    out: list[float] = []
    while left > 1e-12 / dt:
        rate = min(peak, rate + step, stopping_rate(left, step))  # the last: left itself (k = 1)
        out.append(math.copysign(rate, amount))
        left -= rate
    return out
