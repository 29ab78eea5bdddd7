"""Measurement models: what a sensor's reading predicts of the pose, for the EKF core.

A scalar measurement ``z`` of the base_link pose ``x = [x, y, psi]`` (m, m, rad) is
described by a :class:`MeasurementModel`: the predicted reading ``h(x)``, its Jacobian row
``H = dh/dx``, the noise variance ``R``, the residual ``y = z - h`` (wrapped for angles) and
the chi-square gate on ``y^2 / S``. A measurement may also see *consider* parameters that
the filter never estimates (the surveyed reflector position's error, seed 000 §4.1): then
``consider_index`` names the reflector and :meth:`MeasurementModel.consider_jacobian` gives
``H_p = dh/dp`` (2,) (:mod:`agvnav.positioning.ekf` for the Schmidt-Kalman form).

:class:`~agvnav.positioning.ekf_core.EkfCore` updates the pose with any model
(:meth:`~agvnav.positioning.ekf_core.EkfCore.update`), so a new sensor is one simulator
plus one model here, not a hand-written EKF update. Two models today:

* :class:`BearingMeasurement` -- the goniometer's leading-edge bearing of one identified
  reflector (seed 000 §2.1; the kernels
  :func:`~agvnav.positioning._fast.edge_bearing` and
  :func:`~agvnav.positioning._fast.bearing_jacobian`, the one scalar form of
  :func:`~agvnav.positioning.edge_bearing.bearing_model`);
* :class:`WallRangeMeasurement` -- an ultrasonic range to a known wall line
  ([seed004 eq6] [seed004 eq7] [seed004 eq8]; :func:`~agvnav.positioning.wall_ranges.wall_range`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from agvnav.positioning import _fast
from agvnav.positioning.wall_ranges import WallRangeMeasurement

__all__ = ["BearingMeasurement", "MeasurementModel", "WallRangeMeasurement"]

Row = tuple[float, float, float]
Pose = Sequence[float]


@runtime_checkable
class MeasurementModel(Protocol):
    """One scalar reading of the pose ``x (3,)`` (m, m, rad): ``h``, ``H``, ``R``, residual, gate."""

    @property
    def name(self) -> str:
        """What is measured (``"bearing"``, ``"wall_range"``), for step records."""
        ...

    @property
    def index(self) -> int:
        """The map row the reading was associated with (reflector, wall), -1 for none."""
        ...

    @property
    def gate(self) -> float:
        """Chi-square threshold (1 dof) on ``y^2 / S``."""
        ...

    @property
    def consider_index(self) -> int:
        """Map row of the consider parameter block the reading sees (a reflector), -1 for none."""
        ...

    def h(self, x: Pose) -> float:
        """Predicted reading at pose ``x``."""
        ...

    def jacobian(self, x: Pose) -> Row:
        """``H = dh/dx`` (3,) at ``x``."""
        ...

    def noise(self, x: Pose) -> float:
        """Variance ``R`` of the reading's white noise (unit²)."""
        ...

    def residual(self, z: float, h: float) -> float:
        """``y = z - h``, wrapped to ``[-pi, pi)`` for an angle."""
        ...

    def consider_jacobian(self, x: Pose) -> tuple[float, float]:
        """``H_p = dh/dp`` (2,) with respect to the consider parameters (0 without)."""
        ...


def _head(x: Pose, mount: Row) -> tuple[float, float, float, float]:
    """Head position ``(px, py)`` (m) and its derivative with respect to psi, for the pose ``x``."""
    c, s = math.cos(x[2]), math.sin(x[2])
    mx, my = mount[0], mount[1]
    return x[0] + c * mx - s * my, x[1] + s * mx + c * my, -s * mx - c * my, c * mx - s * my


@dataclass(frozen=True)
class BearingMeasurement:
    """The leading-edge bearing (rad) of reflector ``index`` from the goniometer head (seed 000 §2.1).

    ``h = wrap(atan2(dy, dx) - psi - theta_m - asin(r / d))`` from the head at
    ``mount = (x_m, y_m, theta_m)`` on base_link to the reflector centre ``(rx, ry)`` of
    radius ``r`` (m), ``d`` the distance; ``R = bearing_var`` (rad²). The survey error of
    the reflector (std ``survey_std`` m per axis) is a consider parameter: the bearing moves
    with the reflector as against the head, ``H_p = -H[:2]``.
    """

    reflector: tuple[float, float, float]  # (rx, ry, r) m
    mount: Row
    bearing_var: float
    index: int = -1
    gate: float = math.inf
    name: str = "bearing"

    @property
    def consider_index(self) -> int:
        """The reflector's map row (its survey error is the consider parameter)."""
        return self.index

    def _edge(self, x: Pose) -> tuple[float, float, float, float, float, float, float]:
        px, py, dpx, dpy = _head(x, self.mount)
        rx, ry, r = self.reflector
        h, dx, dy, d2, d = _fast.edge_bearing(px, py, x[2], self.mount[2], rx, ry, r)
        return h, dx, dy, d2, d, dpx, dpy

    def h(self, x: Pose) -> float:
        """Predicted leading-edge bearing (rad), seed 000 §2.1."""
        return self._edge(x)[0]

    def jacobian(self, x: Pose) -> Row:
        """``dh/d[x, y, psi]`` (rad/m, rad/m, rad/rad)."""
        _, dx, dy, d2, d, dpx, dpy = self._edge(x)
        h0, h1, h2 = _fast.bearing_jacobian(dx, dy, d2, d, self.reflector[2], dpx, dpy)
        return h0, h1, h2

    def noise(self, x: Pose) -> float:
        """``sigma_b^2`` (rad²): the survey error enters as a consider parameter, not here."""
        return self.bearing_var

    def residual(self, z: float, h: float) -> float:
        """``wrap(z - h)`` (rad)."""
        return _fast.wrap(z - h)

    def consider_jacobian(self, x: Pose) -> tuple[float, float]:
        """``dh/d(rx, ry) = -dh/d(x, y)`` (rad/m)."""
        h0, h1, _ = self.jacobian(x)
        return -h0, -h1
