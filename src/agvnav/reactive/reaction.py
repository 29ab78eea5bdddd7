"""The reaction to the safety fields: slow down, emergency stop, resume (issue 18).

States (their index is the level recorded in the series):

* ``clear`` (speed scale 1): no field intruded;
* ``slow`` (``slow_speed_fraction``): the warning field is intruded;
* ``stop`` (scale 0): the protective field is intruded (or a front ranger reads
  below its threshold); the autopilot brakes at the emergency deceleration.

A worse demand applies at once; a better one only after it has been demanded
continuously for ``resume_after_s`` (the field must stay clear that long, so the
vehicle does not surge while a person is still at the edge of the field); a demand
that worsens during that hold restarts it. The same hysteresis as the positioning
guard of issue 12, and the two compose: the autopilot drives at the smaller scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["REACTION_STATES", "Reaction", "ReactionLimits", "field_demand"]

#: Reaction states in order of severity; their index is the level.
REACTION_STATES = ("clear", "slow", "stop")


@dataclass(frozen=True)
class ReactionLimits:
    """``slow_speed_fraction`` (0..1] of the speed while warned; ``resume_after_s`` (s) hold before speeding up."""

    slow_speed_fraction: float = 0.3
    resume_after_s: float = 1.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.slow_speed_fraction) and 0.0 < self.slow_speed_fraction <= 1.0):
            raise ValueError(f"slow_speed_fraction must be in (0, 1], got {self.slow_speed_fraction!r}")
        if not (math.isfinite(self.resume_after_s) and self.resume_after_s >= 0.0):
            raise ValueError(f"resume_after_s must be >= 0 and finite, got {self.resume_after_s!r}")


def field_demand(protective: bool, warning: bool) -> int:
    """The level the fields demand: 2 protective intruded, 1 warning only, 0 clear."""
    return 2 if protective else (1 if warning else 0)


class Reaction:
    """The state machine of the module docstring.

    Attributes
    ----------
    level : current level (0 clear, 1 slow, 2 stop).
    stops : number of transitions into ``stop``.
    transitions : ``(t, from, to)`` of every change of level.
    """

    def __init__(self, limits: ReactionLimits = ReactionLimits(), enabled: bool = True) -> None:
        self.limits = limits
        self.enabled = bool(enabled)
        self.level = 0
        self.stops = 0
        self.transitions: list[tuple[float, int, int]] = []
        self._better_since: float | None = None
        self._last_demand = 0
        self._scales = (1.0, float(limits.slow_speed_fraction), 0.0)

    def update(self, t: float, demand: int) -> float:
        """Take the demanded level at ``t`` (s) and return the speed scale (0..1); 1 when disabled."""
        if demand not in (0, 1, 2):
            raise ValueError(f"demand must be 0, 1 or 2, got {demand!r}")
        if not self.enabled:
            return 1.0
        if demand >= self.level:
            self._set(t, demand)
            self._better_since = None
        elif self._better_since is None or demand > self._last_demand:
            self._better_since = t
        self._last_demand = demand
        if self._better_since is not None and t - self._better_since >= self.limits.resume_after_s - 1e-9:
            self._set(t, demand)
            self._better_since = None
        return self._scales[self.level]

    def _set(self, t: float, level: int) -> None:
        if level != self.level:
            self.transitions.append((t, self.level, level))
            if level == 2:
                self.stops += 1
            self.level = level

    @property
    def state(self) -> str:
        """The current state's name."""
        return REACTION_STATES[self.level]

    @property
    def scale(self) -> float:
        """The speed scale of the current state (1 when disabled)."""
        return self._scales[self.level] if self.enabled else 1.0
