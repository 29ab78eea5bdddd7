"""Systematic and non-systematic odometry errors (seed 002 §3.1), as a "true vehicle" vs "nominal odometry" split.

A simulation commands wheel rotations; the encoders report them; the odometry
converts them to distances with the *nominal* geometry while the ground truth
moves with the *true* geometry plus random slip and bumps. Systematic errors
follow Borenstein and Feng (1996): ``E_d = D_R/D_L`` (ratio of the actual wheel
diameters, their mean being the nominal one) and ``E_b = b_actual/b_nominal``;
misalignment turns both wheels' rolling direction by a small angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_angle_below, require_nonnegative, require_positive
from agvnav.kinematics.base import twist_step
from agvnav.odometry.increments import differential_increments

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class DifferentialGeometry:
    """Wheel radii and track of a differential vehicle (m); nominal or true."""

    radius_right: float
    radius_left: float
    track: float

    def __post_init__(self) -> None:
        require_positive("radius_right", self.radius_right)
        require_positive("radius_left", self.radius_left)
        require_positive("track", self.track)

    @classmethod
    def symmetric(cls, wheel_radius: float, track: float) -> DifferentialGeometry:
        """Both wheels of radius ``wheel_radius``."""
        return cls(wheel_radius, wheel_radius, track)

    def increments(self, phi_right: ArrayLike, phi_left: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """``(ΔD, Δθ)`` for wheel rotations (rad) with this geometry [seed002 eq16]."""
        return differential_increments(np.asarray(phi_right) * self.radius_right,
                                       np.asarray(phi_left) * self.radius_left, self.track)


@dataclass(frozen=True)
class SystematicErrors:
    """Systematic errors of the true vehicle relative to the nominal one.

    e_d : ``D_R/D_L`` of the actual wheels (1 = equal diameters); the mean diameter is nominal.
    e_b : actual track / nominal track.
    misalignment : angle (rad) by which the wheels' rolling direction is turned from the body x-axis.
    """

    e_d: float = 1.0
    e_b: float = 1.0
    misalignment: float = 0.0

    def __post_init__(self) -> None:
        require_positive("e_d", self.e_d)
        require_positive("e_b", self.e_b)
        require_angle_below("misalignment", self.misalignment, np.pi / 4)

    def true_geometry(self, nominal: DifferentialGeometry) -> DifferentialGeometry:
        """Actual geometry (Borenstein & Feng): ``r_R = 2/(1/E_d + 1)·r_a``, ``r_L = 2/(E_d + 1)·r_a``, ``b = E_b·b_n``.

        ``r_a`` is the mean nominal radius (m), ``b_n`` the nominal track (m).
        """
        r_a = 0.5 * (nominal.radius_right + nominal.radius_left)
        return DifferentialGeometry(2.0 / (1.0 / self.e_d + 1.0) * r_a, 2.0 / (self.e_d + 1.0) * r_a,
                                    self.e_b * nominal.track)


@dataclass(frozen=True)
class NonSystematicErrors:
    """Random wheel-ground errors of the true vehicle.

    slip_k : variance of each wheel's ground distance per metre rolled (m²/m), Gaussian.
    bump_rate : expected bumps per metre rolled per wheel (1/m), Poisson.
    bump_loss : ground distance lost by a wheel climbing one bump (m): the
        encoder counts the rolled arc, the floor sees less horizontal progress.
    steering_std : standard deviation (rad) of a random error of a steered
        wheel's true angle, drawn afresh per simulation step (tricycle only).
    """

    slip_k: float = 0.0
    bump_rate: float = 0.0
    bump_loss: float = 0.005
    steering_std: float = 0.0

    def __post_init__(self) -> None:
        require_nonnegative("slip_k", self.slip_k)
        require_nonnegative("bump_rate", self.bump_rate)
        require_nonnegative("bump_loss", self.bump_loss)
        require_nonnegative("steering_std", self.steering_std)

    def perturb(self, distance: ArrayLike, rng: np.random.Generator) -> FloatArray:
        """Ground distance (m) for a rolled distance (m): slip noise, then bump losses against the motion."""
        d = np.asarray(distance, dtype=np.float64)
        out = d + rng.normal(0.0, 1.0, d.shape) * np.sqrt(self.slip_k * np.abs(d))
        if self.bump_rate > 0.0:
            bumps = rng.poisson(self.bump_rate * np.abs(d))
            out = out - np.sign(d) * np.minimum(bumps * self.bump_loss, np.abs(d))
        return out

    def perturb_scalar(self, distance: float, rng: np.random.Generator) -> float:
        """Scalar fast path of :meth:`perturb` for one wheel in a hot loop (m in, m out).

        Same model and draw order (one normal, then one Poisson when ``bump_rate > 0``),
        except that it draws nothing it does not need: no normal when ``slip_k = 0``,
        nothing at all for ``distance = 0``. The slip term is computed as
        ``sqrt(slip_k) * sqrt(|d|)`` (equal to the kernel's ``sqrt(slip_k |d|)`` to
        rounding; ``sqrt(s**2) == s`` exactly, so a standard deviation ``s`` given as
        ``slip_k = s**2`` is applied bit for bit).
        """
        d = float(distance)
        if d == 0.0:
            return d
        out = d
        if self.slip_k > 0.0:
            out += math.sqrt(self.slip_k) * math.sqrt(abs(d)) * float(rng.standard_normal())
        if self.bump_rate > 0.0:
            bumps = int(rng.poisson(self.bump_rate * abs(d)))
            out -= math.copysign(min(bumps * self.bump_loss, abs(d)), d)
        return out

    def perturb_steering_scalar(self, gamma: float, rng: np.random.Generator) -> float:
        """True steered-wheel angle (rad) for a nominal one: ``gamma + steering_std·N(0, 1)``.

        One normal draw when ``steering_std > 0``, none otherwise.
        """
        if self.steering_std > 0.0:
            return gamma + self.steering_std * float(rng.standard_normal())
        return gamma


class TrueDifferentialVehicle:
    """Ground truth of a differential vehicle whose odometry uses ``nominal``.

    Parameters
    ----------
    nominal : the geometry the odometry believes.
    systematic : systematic errors of the real vehicle.
    nonsystematic : slip and bumps (None: none).
    seed : seed or Generator for the non-systematic errors (same seed, same truth).
    """

    def __init__(self, nominal: DifferentialGeometry, systematic: SystematicErrors | None = None,
                 nonsystematic: NonSystematicErrors | None = None,
                 seed: int | np.random.Generator | None = 0) -> None:
        self.nominal = nominal
        self.systematic = systematic or SystematicErrors()
        self.nonsystematic = nonsystematic
        self.geometry = self.systematic.true_geometry(nominal)
        self.rng = np.random.default_rng(seed)

    def ground_increments(self, phi_right: ArrayLike, phi_left: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """True ``(ΔD, Δθ)`` of the axle midpoint for wheel rotations (rad)."""
        g = self.geometry
        d_r = np.asarray(phi_right, dtype=np.float64) * g.radius_right
        d_l = np.asarray(phi_left, dtype=np.float64) * g.radius_left
        if self.nonsystematic is not None:
            d_r = self.nonsystematic.perturb(d_r, self.rng)
            d_l = self.nonsystematic.perturb(d_l, self.rng)
        return differential_increments(d_r, d_l, g.track)

    def advance(self, pose: ArrayLike, phi_right: ArrayLike, phi_left: ArrayLike) -> FloatArray:
        """True pose after wheel rotations (rad): exact arc, displaced along the misaligned rolling direction."""
        dd, dth = self.ground_increments(phi_right, phi_left)
        m = self.systematic.misalignment
        return twist_step(pose, dd * np.cos(m), dd * np.sin(m), dth, 1.0)


@dataclass(frozen=True)
class TricycleErrors:
    """Systematic errors of a true tricycle (seed-000 stacker) relative to its nominal odometry.

    radius_scale : true / nominal traction-wheel radius (wear, tyre load).
    wheelbase_scale : true / nominal wheelbase L.
    steering_offset : angle (rad) the steered wheel truly points beyond what the
        steering encoder reads (its zero error); the encoder side of it is
        ``SteeringEncoder(offset=steering_offset)``.
    """

    radius_scale: float = 1.0
    wheelbase_scale: float = 1.0
    steering_offset: float = 0.0

    def __post_init__(self) -> None:
        require_positive("radius_scale", self.radius_scale)
        require_positive("wheelbase_scale", self.wheelbase_scale)
        require_angle_below("steering_offset", self.steering_offset, math.pi / 4)


class TrueTricycleVehicle:
    """Ground truth of a front-drive tricycle whose odometry uses nominal ``wheelbase`` and ``wheel_radius``.

    Parameters
    ----------
    wheelbase, wheel_radius : nominal values (m).
    systematic : ``TricycleErrors`` (None: none).
    nonsystematic : slip and bumps of the traction wheel (None: none).
    seed : seed or Generator (same seed, same truth).
    """

    def __init__(self, wheelbase: float, wheel_radius: float, systematic: TricycleErrors | None = None,
                 nonsystematic: NonSystematicErrors | None = None,
                 seed: int | np.random.Generator | None = 0) -> None:
        self.systematic = systematic or TricycleErrors()
        self.wheelbase = require_positive("wheelbase", wheelbase) * self.systematic.wheelbase_scale
        self.wheel_radius = require_positive("wheel_radius", wheel_radius) * self.systematic.radius_scale
        self.nonsystematic = nonsystematic
        self.rng = np.random.default_rng(seed)

    def advance(self, pose: ArrayLike, wheel_rotation: ArrayLike, gamma: ArrayLike) -> FloatArray:
        """True pose of O after the traction wheel turns ``wheel_rotation`` (rad) at steering angle γ (rad).

        Exact arc for γ held over the step (pass the mid-step γ when it changes), [seed000 eq8].
        γ is what the steering encoder reads; the wheel points ``γ + steering_offset``
        plus the non-systematic steering error (drawn after the slip).
        """
        ds = np.asarray(wheel_rotation, dtype=np.float64) * self.wheel_radius
        g = np.asarray(gamma, dtype=np.float64) + self.systematic.steering_offset
        if self.nonsystematic is not None:
            ds = self.nonsystematic.perturb(ds, self.rng)
            if self.nonsystematic.steering_std > 0.0:
                g = g + self.nonsystematic.steering_std * self.rng.standard_normal(g.shape)
        return twist_step(pose, ds * np.cos(g), 0.0, ds * np.sin(g) / self.wheelbase, 1.0)
