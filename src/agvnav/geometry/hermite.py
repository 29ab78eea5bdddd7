"""A step's motion as a cubic Hermite curve of poses: the truth plants' ``pose_at`` (issue 11).

The tricycle plant integrates its kinematics once per step and keeps the exact poses and
time derivatives at both ends; :func:`hermite_poses` evaluates the cubic Hermite curve
between them at any instant of the step ([seed000 eq8] gives the derivatives). Its error is
``h^4/384 max|d4x/dt4|`` (below 1e-8 m for a 0.05 s step, tested with the plant).

:class:`HermitePoses` is that ``pose_at`` as an object: callable like any pose function,
and a kernel that knows the curve (the goniometer's scan,
:func:`agvnav.sensors.beam.scan_motion`) evaluates it itself, compiled, instead of calling
back into Python for every instant of its root finder.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._jit import jit

__all__ = ["HermitePoses", "hermite_poses"]


@jit
def hermite_poses(hermite: NDArray[np.float64], t0: float, dt: float, t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cubic Hermite poses ``(k, 3)`` at instants ``t (k,)`` (s) of the step ``[t0, t0 + dt]``.

    ``hermite`` ``(4, 3)`` holds the pose at the start ``p0``, its time derivative times
    ``dt`` ``d0``, the pose at the end ``p1`` and its derivative times ``dt`` ``d1``;
    ``u = (t - t0) / dt`` clipped to [0, 1]; pose ``= h00 p0 + h10 d0 + h01 p1 + h11 d1`` with
    the cubic Hermite basis (derivatives of [seed000 eq8] at both ends). Compiled
    (:mod:`agvnav._jit`): one formulation for the goniometer's few instants and for batches.
    """
    out = np.empty((t.shape[0], 3))
    # the table as twelve floats, read once (plain Python floats when interpreted: NumPy scalars were
    # most of this kernel's interpreted cost; the same arithmetic either way)
    p0x, p0y, p0h = float(hermite[0, 0]), float(hermite[0, 1]), float(hermite[0, 2])
    d0x, d0y, d0h = float(hermite[1, 0]), float(hermite[1, 1]), float(hermite[1, 2])
    p1x, p1y, p1h = float(hermite[2, 0]), float(hermite[2, 1]), float(hermite[2, 2])
    d1x, d1y, d1h = float(hermite[3, 0]), float(hermite[3, 1]), float(hermite[3, 2])
    for i in range(t.shape[0]):
        u = min(max((float(t[i]) - t0) / dt, 0.0), 1.0)
        u2 = u * u
        u3 = u2 * u
        h00, h10 = 2.0 * u3 - 3.0 * u2 + 1.0, u3 - 2.0 * u2 + u
        h01, h11 = 3.0 * u2 - 2.0 * u3, u3 - u2
        out[i, 0] = h00 * p0x + h10 * d0x + h01 * p1x + h11 * d1x
        out[i, 1] = h00 * p0y + h10 * d0y + h01 * p1y + h11 * d1y
        out[i, 2] = h00 * p0h + h10 * d0h + h01 * p1h + h11 * d1h
    return out


class HermitePoses:
    """``pose_at`` of the last step: :func:`hermite_poses` of a ``(4, 3)`` table over ``[t0, t0 + dt]``.

    One object per plant, updated in place every step (:meth:`set`), so a reference taken
    once (a fault or collision wrapper keeps ``plant.pose_at``) always gives the current step.
    """

    __slots__ = ("dt", "t0", "table")

    def __init__(self, table: NDArray[np.float64], t0: float, dt: float) -> None:
        self.set(table, t0, dt)

    def set(self, table: NDArray[np.float64], t0: float, dt: float) -> None:
        """Hold the step from ``t0`` (s) of length ``dt`` (s, > 0) with its ``(4, 3)`` Hermite table."""
        self.table, self.t0, self.dt = table, float(t0), float(dt)

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        """True base_link pose ``(..., 3)`` (m, m, rad) at instants ``t (...)`` (s) inside the step."""
        t = np.asarray(t, dtype=np.float64)
        return hermite_poses(self.table, self.t0, self.dt, t.reshape(-1)).reshape(*t.shape, 3)
