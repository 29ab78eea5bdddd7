"""The streaming estimator's lifecycle part: status, start-up and relocalisation, the lock-out watch.

Status (:func:`status_of`): ``"initialising"`` until the pose is set, then ``"tracking"``,
``"degraded"`` or ``"lost"`` by the integrity monitor's verdict, and ``"dead_reckoning"``
after ``dead_reckoning_after`` seconds without an accepted reflection.

:class:`StartUp` buffers reflections at standstill and searches the pose from one revolution
(:func:`~agvnav.positioning.identification.initial_pose_search`), at start-up and, lost, to
relocalise: only an unambiguous pose within reach of the last trusted one is taken.

:class:`LockoutWatch` counts the reflections of the last 1.5 revolutions that fell into no
gate: the classic EKF lock-out (a confident but wrong estimate rejecting the true
reflections) shows as rejections outnumbering acceptances twice over.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from numpy.typing import NDArray

from agvnav.positioning.identification import InitialPoseResult, initial_pose_search

__all__ = ["MAX_INFLATED_POSITION_VAR", "STATUSES", "LockoutWatch", "StartUp", "status_of"]

#: Lock-out inflation stops once the position variance trace reaches this (m²).
MAX_INFLATED_POSITION_VAR = 0.25

#: Values of :attr:`~agvnav.positioning.estimator.StreamingEstimator.status`.
STATUSES = ("initialising", "tracking", "degraded", "dead_reckoning", "lost")


def status_of(has_pose: bool, verdict: str, dead_reckoning: bool) -> str:
    """The status (one of :data:`STATUSES`) from the pose, the monitor's verdict and the dead-reckoning flag."""
    if not has_pose:
        return "initialising"
    if verdict == "lost":
        return "lost"
    if dead_reckoning:
        return "dead_reckoning"
    return "degraded" if verdict == "degraded" else "tracking"


class LockoutWatch:
    """Reflections of the last 1.5 revolutions (``window`` s): accepted or in no gate.

    :meth:`record` says when rejections outnumber acceptances twice over (and at least four):
    the caller then inflates ``P`` (:meth:`~agvnav.positioning.estimator.StreamingEstimator.update`).
    """

    def __init__(self, window: float) -> None:
        self.window = window
        self.recent: deque[tuple[float, bool]] = deque()
        self.n_ok = 0  # accepted reflections in recent (a running count)

    def clear(self) -> None:
        """Forget the window."""
        self.recent.clear()
        self.n_ok = 0

    def _prune(self, t: float) -> None:
        recent = self.recent
        while recent and not t - recent[0][0] <= self.window:  # times never decrease: the old ones lead
            self.n_ok -= recent.popleft()[1]

    def would_trigger(self, t: float) -> bool:
        """Whether :meth:`record` of an accepted reflection at ``t`` (s) would trigger (counts alone)."""
        self._prune(t)
        n_ok = self.n_ok + 1
        n_bad = len(self.recent) + 1 - n_ok
        return n_bad >= 4 and 2 * n_ok < n_bad

    def record(self, t: float, accepted: bool) -> bool:
        """Add one reflection at ``t`` (s); True when the window says lock-out."""
        self._prune(t)
        self.recent.append((t, accepted))
        self.n_ok += accepted
        n_bad = len(self.recent) - self.n_ok
        return n_bad >= 4 and 2 * self.n_ok < n_bad

    def inflated(self, t: float, accepted: bool, P: tuple[float, ...]) -> tuple[float, ...] | None:
        """:meth:`record` the reflection at ``t`` (s); on a lock-out, ``P`` (row-major ``(9,)``) x4, else None.

        A wrong early association (a spurious reflection inside a wide initial gate) can leave
        a confident but wrong estimate that then rejects the true reflections: the classic
        EKF lock-out. The covariance is inflated -- never the pose -- until the gates admit the
        reflectors again, up to :data:`MAX_INFLATED_POSITION_VAR` (None beyond it). Only
        reflections that fall into no gate count as rejections (the caller passes no ambiguous
        one: in the racked aisles half of each revolution is ambiguous, with the estimate 6 mm
        from the truth).

        The caller then runs the monitor's check at once rather than at the next revolution:
        the differential AGV whose encoders dropped out (zero increments while it drove on)
        stood 14-25 cm off while "tracking" for 1.05 s before the once-a-revolution check
        caught up. The check, not the inflation, decides the verdict: heavy clutter inflates
        with the pose sound.
        """
        if not self.record(t, accepted):
            return None
        if P[0] + P[4] < MAX_INFLATED_POSITION_VAR:
            return tuple(4.0 * v for v in P)
        return None


class StartUp:
    """The start-up and relocalisation search over one revolution of reflections at standstill.

    ``sweep`` one revolution (s); the map, mount and gate as for
    :func:`~agvnav.positioning.identification.initial_pose_search`; ``max_speed`` (m/s) and
    ``slack`` (m) bound how far a relocalised pose may lie from the last trusted one.
    """

    def __init__(
        self, reflector_xy: NDArray[np.float64], radius: NDArray[np.float64], mount: NDArray[np.float64],
        bearing_std: float, sweep: float, max_range: float, gate: float, map_std: float, max_speed: float,
        slack: float,
    ) -> None:
        self._search_args = (reflector_xy, radius, mount, bearing_std)
        self._search_kwargs = {"max_range": max_range, "gate": gate, "map_std": map_std}
        self.sweep = sweep
        self.max_speed, self.slack = max_speed, slack
        self.buffer: list[tuple[float, float]] = []
        self.next_search_t = -math.inf
        self.last_search: InitialPoseResult | None = None
        self.ambiguous = False
        self.n_relocalisations = 0
        self.n_unreachable = 0
        self.trusted: tuple[float, float, float, float] | None = None  # x, y (m), var x + var y (m²), t (s)

    def search(self, relocalising: bool) -> InitialPoseResult | None:
        """The found pose once a full revolution is buffered (and reachable when ``relocalising``), else None."""
        times = np.array([b[0] for b in self.buffer])
        if times[-1] - times[0] < self.sweep or times[-1] < self.next_search_t:
            return None
        t_end = float(times[-1])
        sweep = [z for (tb, z) in self.buffer if t_end - tb < self.sweep]
        result = initial_pose_search(sweep, *self._search_args, **self._search_kwargs)  # type: ignore[arg-type]
        self.last_search = result
        self.ambiguous = bool(result.ambiguous)
        self.buffer = [b for b in self.buffer if t_end - b[0] < self.sweep]
        if result.found and relocalising and not self.reachable(result.pose, t_end):
            self.n_unreachable += 1
            self.next_search_t = t_end + 1.0
            return None
        if result.found:
            self.n_relocalisations += relocalising
            self.buffer.clear()
            return result
        if relocalising:  # lost: the search costs ~0.1 s, try again a second later
            self.next_search_t = t_end + 1.0
        return None

    def reachable(self, pose: NDArray[np.float64], t: float) -> bool:
        """Whether base_link could have reached ``pose`` (m) at ``t`` (s) from the last trusted pose."""
        if self.trusted is None:
            return True
        x, y, var, t0 = self.trusted
        reach = self.max_speed * max(t - t0, 0.0) + 3.0 * math.sqrt(max(var, 0.0)) + self.slack
        return math.hypot(float(pose[0]) - x, float(pose[1]) - y) <= reach
