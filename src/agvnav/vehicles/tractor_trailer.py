"""A differential tractor towing one off-axle trailer (seed 003 §3.2.7) as a truth vehicle.

The tractor is a :class:`~agvnav.vehicles.differential.DifferentialPlant` (speed
loops, true wheel geometry and slip, encoders, nominal odometry: the odometry and
base_link are the tractor's); the trailer, hitched ``d`` behind the tractor axle
with its axle ``D`` behind the hitch (:class:`agvnav.kinematics.TractorTrailer`),
is integrated along the tractor's true motion sub-step by sub-step. The hitch
angle ``φ = θ − θ_trailer`` obeys the trailer axle's no-side-slip constraint,
written here for a tractor body twist ``(v_x, v_y, ω)``::

    φ' = ω − (v_x sin φ + (v_y − d ω) cos φ) / D

(the hitch moves at ``(v_x, v_y − d ω)`` in the tractor frame; only its component
normal to the trailer turns the trailer). With ``v_y = 0`` this is the seed's
``φ' = −(sin φ / D) v + (1 + (d/D) cos φ) ω`` [seed003 §3.2.7]. A jackknife
(|φ| reaching the trailer's ``max_hitch_angle``) is a physical failure of the run.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from agvnav.kinematics.tractor_trailer import TractorTrailer
from agvnav.vehicles.geometry import UnicycleGeometry
from agvnav.vehicles.wheel_pair import WheelPairPlant

__all__ = ["TractorTrailerPlant", "hitch_rate"]


def hitch_rate(phi: float, v_x: float, v_y: float, omega: float, trailer_length: float, hitch_offset: float) -> float:
    """Hitch-angle rate ``φ'`` (rad/s) for a tractor body twist (m/s, m/s, rad/s) [seed003 §3.2.7].

    ``trailer_length`` D (m) hitch to trailer axle, ``hitch_offset`` d (m) tractor
    axle to hitch (positive behind). See the module docstring for the derivation.
    """
    return omega - (v_x * math.sin(phi) + (v_y - hitch_offset * omega) * math.cos(phi)) / trailer_length


class TractorTrailerPlant:
    """Truth tractor-trailer: a differential tractor and one off-axle trailer.

    Parameters
    ----------
    tractor : the truth tractor, a :class:`DifferentialPlant` (or any
        :class:`~agvnav.vehicles.wheel_pair.WheelPairPlant`, e.g. a tracked one): its pose is
        base_link; its command, odometry, geometry and footprint are the plant's.
    trailer : :class:`agvnav.kinematics.TractorTrailer` with D, d and the jackknife limit.
    initial_hitch_angle : true φ at the start (rad), below the jackknife limit.

    Plant role: ``family = "unicycle"`` (command ``(omega_right, omega_left)``, rad/s);
    ``failure()`` is ``"jackknife"`` from the first step at whose end |φ| reached
    ``trailer.max_hitch_angle``, and stays so.
    """

    family: ClassVar[str] = "unicycle"

    def __init__(self, tractor: WheelPairPlant, trailer: TractorTrailer, initial_hitch_angle: float = 0.0) -> None:
        phi0 = float(initial_hitch_angle)
        if not (math.isfinite(phi0) and abs(phi0) < trailer.max_hitch_angle):
            raise ValueError(
                f"initial_hitch_angle must be finite and below max_hitch_angle {trailer.max_hitch_angle!r} rad, "
                f"got {initial_hitch_angle!r}"
            )
        self.tractor = tractor
        self.trailer = trailer
        self.signal_names: tuple[str, ...] = (
            *tractor.signal_names, "hitch_angle", "x_trailer", "y_trailer", "psi_trailer",
        )
        self.hitch_angle = phi0
        self.max_hitch_angle_seen = abs(phi0)
        self._failure: str | None = None

    @property
    def geometry(self) -> UnicycleGeometry:
        """The tractor's nominal :class:`UnicycleGeometry`."""
        return self.tractor.geometry

    @property
    def footprint(self) -> NDArray[np.float64]:
        """The tractor's body polygon ``(k, 2)`` (m, base_link)."""
        return self.tractor.footprint

    @property
    def pose(self) -> NDArray[np.float64]:
        """True tractor (base_link) pose ``[x, y, heading]`` now (m, rad)."""
        return self.tractor.pose

    @property
    def trailer_pose(self) -> NDArray[np.float64]:
        """True trailer axle-midpoint pose ``[x, y, heading]`` now (m, rad)."""
        state = np.append(self.tractor.pose, self.hitch_angle)
        return self.trailer.trailer_pose(state)

    def failure(self) -> str | None:
        """``"jackknife"`` once |hitch angle| reached its limit, else None."""
        return self._failure

    def advance(self, command: Sequence[float], t0: float, dt: float, rng: np.random.Generator) -> None:
        """Advance the tractor (see :meth:`DifferentialPlant.advance`), then the hitch angle along its sub-steps."""
        self.tractor.advance(command, t0, dt, rng)
        h = self.tractor.substep_length
        D, d = self.trailer.trailer_length, self.trailer.hitch_offset
        phi = self.hitch_angle
        for vx, vy, w in self.tractor.substep_twists.tolist():
            k1 = hitch_rate(phi, vx, vy, w, D, d)
            k2 = hitch_rate(phi + 0.5 * h * k1, vx, vy, w, D, d)
            k3 = hitch_rate(phi + 0.5 * h * k2, vx, vy, w, D, d)
            k4 = hitch_rate(phi + h * k3, vx, vy, w, D, d)
            phi += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            self.max_hitch_angle_seen = max(self.max_hitch_angle_seen, abs(phi))
        self.hitch_angle = phi
        if self.max_hitch_angle_seen >= self.trailer.max_hitch_angle:
            self._failure = "jackknife"

    def pose_at(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """True tractor pose ``(k, 3)`` at instants ``t (k,)`` (s) of the last step."""
        return self.tractor.pose_at(t)

    def odometry(self) -> tuple[float, float, float]:
        """The tractor's ``(delta_d, delta_theta, 0.0)`` (m, rad, m), nominal geometry."""
        return self.tractor.odometry()

    def signals(self) -> tuple[float, ...]:
        """The tractor's signals, then ``hitch_angle`` (rad) and the trailer axle pose (m, m, rad)."""
        tp = self.trailer_pose
        return (*self.tractor.signals(), self.hitch_angle, float(tp[0]), float(tp[1]), float(tp[2]))
