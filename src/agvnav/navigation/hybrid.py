"""The seed-004 hybrid automaton as the vehicle's autopilot: its wheel set-points each step (seed 004 Fig. 7).

:class:`HybridAutopilot` adapts :class:`agvnav.guidance.hybrid.HybridController` (the
automaton, built bound to its wall-landmark estimator) to the closed loop's Autopilot role
(:class:`agvnav.roles.Autopilot`); :mod:`agvnav.sim.laps` wires it on the tracked robot's route.
"""

from __future__ import annotations

from agvnav.guidance.hybrid import HybridController
from agvnav.roles import Estimator, Plant

__all__ = ["HybridAutopilot"]


class HybridAutopilot:
    """Seed 004 Fig. 7: the hybrid automaton's wheel set-points.

    The automaton reads the estimator it was built bound to (see
    :meth:`agvnav.guidance.hybrid.HybridController.bind`), which must be the loop's: one given
    to :meth:`command` that is not raises ValueError (the automaton would steer on another
    estimate than the one the sensors feed).
    """

    signal_names: tuple[str, ...] = (
        "v_cmd",
        "omega_cmd",
        "omega_right_cmd",
        "omega_left_cmd",
        "state",
        "leg",
        "laps_done",
    )

    def __init__(self, controller: HybridController) -> None:
        self.controller = controller
        self._sig: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    @property
    def finished(self) -> bool:
        """True once the automaton has driven its laps."""
        return bool(self.controller.finished)

    def command(self, t: float, estimator: Estimator, plant: Plant, dt: float) -> tuple[float, float]:
        """The wheel set-points ``(omega_right, omega_left)`` (rad/s) of the automaton at ``t`` (s)."""
        c = self.controller
        if id(c.estimator) != id(estimator):  # the same object (the protocols differ)
            raise ValueError("the hybrid automaton reads the estimator it was bound to: give the loop that one")
        cmd = c.command(t)
        w = cmd.wheel_speeds
        self._sig = (
            cmd.v,
            cmd.omega,
            float(w[0]),
            float(w[1]),
            float(c.state.value[1]),
            float(c.leg),
            float(c.laps_done),
        )
        return float(w[0]), float(w[1])

    def signals(self) -> tuple[float, ...]:
        """``v_cmd`` (m/s), ``omega_cmd``, the wheel set-points (rad/s), ``state``, ``leg``, ``laps_done``."""
        return self._sig
