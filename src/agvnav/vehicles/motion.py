"""Helpers shared by the wheeled plants: the piecewise-constant-twist trajectory of one step.

A plant that moves with a constant body twist inside each sub-step records the
pose at every sub-step start and the twist of every sub-step; the pose at any
instant of the step is then exact: the SE(2) exponential
(:func:`agvnav.kinematics.twist.twist_pose`, seed 002 eq. 25 for ``v_y = 0``) of the
sub-step's twist for the time elapsed in it, one compiled call for all the instants asked
(:func:`agvnav.kinematics.twist.twist_table_poses`, the kernel a fleet's bodies use too).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agvnav.kinematics.twist import TwistPoses, twist_table_poses

__all__ = ["SubstepTrajectory", "differential_twist_matrix", "hermite_pose", "piecewise_twist_pose"]


def piecewise_twist_pose(
    t: NDArray[np.float64],
    t0: float,
    h: float,
    states: NDArray[np.float64],
    twists: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Pose ``(k, 3)`` at instants ``t (k,)`` (s) of a step made of constant-twist sub-steps [seed002 eq25].

    Parameters
    ----------
    t : query instants (s); clipped to the step ``[t0, t0 + n h]``.
    t0 : step start (s). h : sub-step length (s).
    states : ``(n + 1, 3)`` poses ``[x, y, heading]`` at the sub-step boundaries (m, rad).
    twists : ``(n, 3)`` body twists ``[v_x, v_y, omega]`` of the sub-steps (m/s, rad/s).
    """
    t = np.ascontiguousarray(t, dtype=np.float64).reshape(-1)
    return np.asarray(twist_table_poses(states, twists, float(t0), float(h), t), dtype=np.float64)


def differential_twist_matrix(track: float, misalignment: float = 0.0) -> list[list[float]]:
    """Body twist ``[v_x, v_y, omega]`` per wheel ground speed ``[v_R, v_L]`` of a differential base, ``(3, 2)``.

    ``v = (v_R + v_L)/2``, ``omega = (v_R - v_L)/b`` [seed002 eq16], the midpoint moving
    along the wheels' rolling direction turned by ``misalignment`` (rad; seed 002
    §3.1 systematic errors). Applied to wheel *distances* of a step it gives the
    odometry increments ``(ΔD, Δθ)`` of seed 002 eq. 16. Nested floats, the form
    :func:`agvnav.kinematics.scalar.track_twist` takes.
    """
    if not (math.isfinite(track) and track > 0.0):
        raise ValueError(f"track must be a positive number of metres, got {track!r}")
    c, s = math.cos(misalignment), math.sin(misalignment)
    return [[0.5 * c, 0.5 * c], [0.5 * s, 0.5 * s], [1.0 / track, -1.0 / track]]


def hermite_pose(
    t: NDArray[np.float64],
    t0: float,
    h: float,
    poses: NDArray[np.float64],
    rates: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Piecewise cubic Hermite pose ``(k, 3)`` at instants ``t (k,)`` (s) of a step of sub-steps of ``h`` s.

    ``poses (n + 1, 3)`` are the exact poses at the sub-step boundaries (from ``t0``)
    and ``rates (n + 1, 3)`` their time derivatives. The error on a sub-step is
    ``h^4/384 max|d4p/dt4|``; instants outside the step are clipped to it.
    """
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    n = poses.shape[0] - 1
    rel = np.clip(t - t0, 0.0, n * h)
    i = np.minimum((rel / h).astype(np.int64), n - 1)
    u = ((rel - i * h) / h)[:, None]
    u2 = u * u
    u3 = u2 * u
    return ((2.0 * u3 - 3.0 * u2 + 1.0) * poses[i] + (u3 - 2.0 * u2 + u) * h * rates[i]
            + (3.0 * u2 - 2.0 * u3) * poses[i + 1] + (u3 - u2) * h * rates[i + 1])


class SubstepTrajectory:
    """The true motion of a plant that holds a constant body twist inside each sub-step.

    Keeps the pose now and the last step's sub-step boundaries and twists, and gives
    ``pose``, ``substep_twists``, ``substep_length`` and the exact ``pose_at`` of the
    Plant role (:func:`piecewise_twist_pose`). Plants call :meth:`_start_trajectory`
    once and :meth:`_record_step` at the end of every ``advance``.
    """

    _pose: tuple[float, float, float]
    _t0: float
    _h: float
    _states: NDArray[np.float64]
    _twists: NDArray[np.float64]
    _poses: TwistPoses

    def _start_trajectory(self, initial_pose: NDArray[np.float64], substep: float) -> None:
        """At rest at ``initial_pose`` ``[x, y, heading]`` (m, rad); ``substep`` (s)."""
        p = np.asarray(initial_pose, dtype=np.float64).reshape(3)
        self._pose = (float(p[0]), float(p[1]), float(p[2]))
        self._t0, self._h = 0.0, float(substep)
        self._states = p[None, :].repeat(2, axis=0)
        self._twists = np.zeros((1, 3))
        self._poses = TwistPoses(self._states, self._twists, self._t0, self._h)

    def _record_step(
        self, t0: float, h: float, states: list[tuple[float, float, float]], twists: list[tuple[float, float, float]]
    ) -> None:
        """Keep a step from ``t0`` (s) of sub-steps ``h`` (s): boundary poses ``states`` and ``twists``."""
        self._pose = states[-1]
        self._t0, self._h = float(t0), h
        self._states = np.array(states)
        self._twists = np.array(twists)
        self._poses.set(self._states, self._twists, self._t0, h)

    @property
    def pose(self) -> NDArray[np.float64]:
        """True base_link pose ``[x, y, heading]`` now (m, rad)."""
        return np.array(self._pose)

    @property
    def substep_twists(self) -> NDArray[np.float64]:
        """Body twists ``(n, 3)`` ``[v_x, v_y, omega]`` (m/s, rad/s) of the last step's sub-steps (a copy)."""
        return self._twists.copy()

    @property
    def substep_length(self) -> float:
        """Length (s) of the last step's sub-steps."""
        return self._h

    @property
    def pose_at(self) -> TwistPoses:
        """True pose ``(k, 3)`` at instants ``t (k,)`` (s) of the last step (exact per sub-step twist): ``pose_at(t)``,
        a :class:`~agvnav.kinematics.twist.TwistPoses` updated in place every step."""
        return self._poses
