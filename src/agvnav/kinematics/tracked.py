"""Tracked / skid-steer vehicle: the differential model with track slip (seed 004 §II.A).

Seed 004 drives its tracked robot with the unicycle inverse kinematics ([seed004 eq1]
[seed004 eq2]) and dead-reckons with the ideal differential model ([seed004 eq3]
[seed004 eq4] [seed004 eq5]); on the
ground the tracks slip, which is where its ~50 cm per lap drift comes from.
Here the truth uses the instantaneous-centre-of-rotation (ICR) model of
tracked vehicles (Martínez et al. 2005, "Approximating kinematics for tracked
mobile robots", IJRR 24(10); the model reviewed in seed 004's reference [1],
González et al. 2015): each track's ground contact turns about its own ICR at
lateral body coordinate ``y_l`` (left) or ``y_r`` (right), further out than
the track centre lines, plus longitudinal slip ratios. For ``y_l = B/2``,
``y_r = −B/2`` and no slip it is exactly [seed004 eq3] [seed004 eq4] [seed004 eq5].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_positive
from agvnav.kinematics.base import FloatArray, KinematicModel, twist_step
from agvnav.kinematics.differential import wheel_speeds_unchecked


@dataclass(frozen=True)
class TrackTerrain:
    """Track-ground interaction parameters (all dimensionless except ``x_icr``).

    Attributes
    ----------
    slip_left, slip_right : longitudinal slip ratios ``s`` in [0, 1): ground
        speed of a track = ``(1 − s)`` × its sprocket speed. Unequal values
        curve a commanded straight line (the asymmetry behind seed 004's drift).
    icr_left, icr_right : ICR expansion factors ``χ >= 1`` of each track:
        ``y_l = χ_l B/2``, ``y_r = −χ_r B/2`` (1 = no skid while turning).
    x_icr : longitudinal position (m) of the vehicle ICR in the body frame;
        non-zero gives a lateral skid velocity ``v_y = −x_icr ω``.
    source : where the figures come from, or "assumption".
    """

    slip_left: float = 0.0
    slip_right: float = 0.0
    icr_left: float = 1.0
    icr_right: float = 1.0
    x_icr: float = 0.0
    source: str = "ideal (no slip)"

    def __post_init__(self) -> None:
        for name in ("slip_left", "slip_right"):
            s = getattr(self, name)
            if not np.isfinite(s) or not 0.0 <= s < 1.0:
                raise ValueError(f"{name} must be in [0, 1), got {s!r}")
        for name in ("icr_left", "icr_right"):
            chi = getattr(self, name)
            if not np.isfinite(chi) or chi <= 0.0:
                raise ValueError(f"{name} must be a positive finite factor, got {chi!r}")
        if not np.isfinite(self.x_icr):
            raise ValueError(f"x_icr must be finite, got {self.x_icr!r}")


#: Named terrain presets for seed 004's two test surfaces. Seed 004 gives no
#: slip figures, only that concrete slips less than artificial grass (§III);
#: the numbers below are ASSUMPTIONS of the order reported for rubber tracks
#: (Martínez et al. 2005 report ICR expansion of roughly 1.1-1.5 depending on
#: the surface). They are symmetric; calibrate slip/asymmetry against seed
#: 004's per-lap error tables (about 50 cm per 14 m lap without landmarks).
TERRAIN_PRESETS: dict[str, TrackTerrain] = {
    "ideal": TrackTerrain(),
    "concrete": TrackTerrain(
        slip_left=0.02, slip_right=0.02, icr_left=1.15, icr_right=1.15,
        source="assumption: rubber track on concrete, slip 2 %, ICR expansion 1.15",
    ),
    "artificial_grass": TrackTerrain(
        slip_left=0.06, slip_right=0.06, icr_left=1.4, icr_right=1.4,
        source="assumption: rubber track on artificial grass, slip 6 %, ICR expansion 1.4",
    ),
}


@dataclass(frozen=True)
class TrackSlipNoise:
    """Random (non-systematic) slip of the two tracks on top of the terrain's mean slip.

    Over a step in which the faster track rolls ``distance`` metres, each track's
    ground speed is multiplied by ``1 + k z`` with ``z ~ N(0, 1)`` independent per
    track and ``k = std / sqrt(distance / 1 m)``: the ground-distance error has
    variance ``std**2 * distance`` (``std`` metres after 1 m), so it does not depend
    on the step length (the random-walk slip of seed 002 §3.1, per track).

    std : standard deviation (m) of a track's ground-distance error per metre rolled, >= 0.
    """

    std: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.std) and self.std >= 0.0):
            raise ValueError(f"slip noise std must be a finite number >= 0, got {self.std!r}")

    def factors(self, distance: ArrayLike, rng: np.random.Generator) -> FloatArray:
        """Speed factors ``[right, left]`` ``(..., 2)`` for steps rolling ``distance (...)`` m.

        Draws ``(..., 2)`` normals when ``std > 0`` (right then left per step), none
        otherwise; a step with ``distance <= 0`` gets factors 1 (its draws are spent).
        """
        d = np.asarray(distance, dtype=np.float64)
        if self.std <= 0.0:
            return np.ones(d.shape + (2,))
        z = rng.standard_normal(d.shape + (2,))
        k = np.where(d > 0.0, self.std / np.sqrt(np.where(d > 0.0, d, 1.0)), 0.0)
        return 1.0 + k[..., None] * z

    def factors_scalar(self, distance: float, rng: np.random.Generator) -> tuple[float, float]:
        """Scalar fast path of :meth:`factors` for one step (same draws, same values)."""
        if self.std <= 0.0:
            return 1.0, 1.0
        z = rng.standard_normal(2)
        k = self.std / math.sqrt(distance) if distance > 0.0 else 0.0
        return 1.0 + k * float(z[0]), 1.0 + k * float(z[1])


def terrain_preset(name: str) -> TrackTerrain:
    """Terrain preset by name (``"ideal"``, ``"concrete"``, ``"artificial_grass"``)."""
    try:
        return TERRAIN_PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown terrain {name!r}; presets: {sorted(TERRAIN_PRESETS)}") from None


class TrackedVehicle(KinematicModel):
    """Skid-steer tracked vehicle with the ICR slip model.

    State ``[x, y, theta]`` (centre between the tracks), input the sprocket
    surface speeds ``[v_R, v_L]`` (m/s, = sprocket radius × angular speed).

    Parameters
    ----------
    track : B, distance between the track centre lines (m), > 0 (``gauge=`` is its former
        keyword, still accepted; ``gauge`` also reads it back).
    sprocket_radius : r (m), > 0 (for wheel-rate conversions, [seed004 eq1] [seed004 eq2]).
    terrain : a ``TrackTerrain`` or a preset name.
    max_track_speed : |v_R|, |v_L| limit (m/s).
    """

    state_names = ("x", "y", "theta")
    input_names = ("v_R", "v_L")

    def __init__(self, track: float | None = None, sprocket_radius: float = 0.05, terrain: TrackTerrain | str = "ideal",
                 max_track_speed: float = np.inf, *, gauge: float | None = None) -> None:
        value = track if gauge is None else gauge
        if value is None or (track is not None and gauge is not None):
            raise ValueError(f"give the track (m) once, as track= (gauge= is its former name): {track!r}, {gauge!r}")
        self.track = require_positive("track", value)
        self.sprocket_radius = require_positive("sprocket_radius", sprocket_radius)
        self.terrain = terrain_preset(terrain) if isinstance(terrain, str) else terrain
        if np.isnan(max_track_speed) or max_track_speed <= 0.0:
            raise ValueError(f"max_track_speed must be > 0, got {max_track_speed!r}")
        self.max_track_speed = float(max_track_speed)
        t = self.terrain
        self.y_left = t.icr_left * 0.5 * self.track
        self.y_right = -t.icr_right * 0.5 * self.track
        span = self.y_left - self.y_right
        g_r, g_l = 1.0 - t.slip_right, 1.0 - t.slip_left
        # Body twist [v_x, v_y, ω] = twist_matrix @ [v_R, v_L] (Martínez et al. 2005, with slip ratios).
        self.twist_matrix = np.array([
            [g_r * self.y_left / span, -g_l * self.y_right / span],
            [-t.x_icr * g_r / span, t.x_icr * g_l / span],
            [g_r / span, -g_l / span],
        ])

    @property
    def gauge(self) -> float:
        """Former name of :attr:`track` (m), kept for callers not yet renamed."""
        return self.track

    def body_twist(self, u: ArrayLike) -> FloatArray:
        """Body twist ``[v_x, v_y, ω]`` ``(..., 3)`` for track speeds ``[v_R, v_L]``."""
        return np.asarray(u, dtype=np.float64) @ self.twist_matrix.T

    def track_speeds(self, v: ArrayLike, omega: ArrayLike, compensate: bool = True) -> FloatArray:
        """Inverse kinematics: track speeds ``[v_R, v_L]`` ``(..., 2)`` for forward speed v and yaw rate ω.

        ``compensate=False`` is [seed004 eq1] [seed004 eq2] times r (ideal tracks):
        ``v_R = v + ωB/2``, ``v_L = v − ωB/2``, by :func:`agvnav.kinematics.wheel_speeds_unchecked`.
        ``compensate=True`` inverts the slip model: ``v_R = (v − ω y_r)/(1 − s_R)``, ``v_L = (v − ω y_l)/(1 − s_L)``.
        """
        v = np.asarray(v, dtype=np.float64)
        w = np.asarray(omega, dtype=np.float64)
        if not compensate:
            return np.stack(wheel_speeds_unchecked(v, w, self.track), axis=-1)
        t = self.terrain
        return np.stack([(v - w * self.y_right) / (1.0 - t.slip_right), (v - w * self.y_left) / (1.0 - t.slip_left)],
                        axis=-1)

    def sprocket_rates(self, v: ArrayLike, omega: ArrayLike, compensate: bool = False) -> FloatArray:
        """Sprocket angular speeds ``[ω_R, ω_L]`` (rad/s); ``compensate=False``: [seed004 eq1] [seed004 eq2]."""
        return self.track_speeds(v, omega, compensate) / self.sprocket_radius

    def derivative_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """World velocity from the body twist."""
        state = np.asarray(state, dtype=np.float64)
        tw = self.body_twist(u)
        c, s = np.cos(state[..., 2]), np.sin(state[..., 2])
        return np.stack([c * tw[..., 0] - s * tw[..., 1], s * tw[..., 0] + c * tw[..., 1], tw[..., 2] + 0.0 * c],
                        axis=-1)

    def jacobian_state_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂f/∂state`` ``(..., 3, 3)``."""
        state = np.asarray(state, dtype=np.float64)
        tw = self.body_twist(u)
        c, s = np.cos(state[..., 2]), np.sin(state[..., 2])
        jac = np.zeros(np.broadcast_shapes(c.shape, tw.shape[:-1]) + (3, 3))
        jac[..., 0, 2] = -s * tw[..., 0] - c * tw[..., 1]
        jac[..., 1, 2] = c * tw[..., 0] - s * tw[..., 1]
        return jac

    def jacobian_input_unchecked(self, state: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂f/∂[v_R, v_L]`` ``(..., 3, 2)`` = ``[[R(θ), 0], [0, 1]] @ twist_matrix``."""
        th = np.asarray(state, dtype=np.float64)[..., 2]
        c, s = np.cos(th), np.sin(th)
        rot = np.zeros(np.broadcast_shapes(th.shape, np.asarray(u).shape[:-1]) + (3, 3))
        rot[..., 0, 0], rot[..., 0, 1] = c, -s
        rot[..., 1, 0], rot[..., 1, 1] = s, c
        rot[..., 2, 2] = 1.0
        return rot @ self.twist_matrix

    def step_unchecked(self, state: ArrayLike, u: ArrayLike, dt: float) -> FloatArray:
        """Exact for constant track speeds (constant body twist)."""
        tw = self.body_twist(u)
        return twist_step(state, tw[..., 0], tw[..., 1], tw[..., 2], dt)

    @property
    def n_constraints(self) -> int:
        """One constraint, ``ẋ sinθ − ẏ cosθ − x_icr θ' = 0`` (the differential one when x_icr = 0): 2 DOF."""
        return 1

    def constraint_matrix(self, state: ArrayLike) -> FloatArray:
        """``[[sinθ, −cosθ, −x_icr]]`` ``(..., 1, 3)``."""
        th = np.asarray(state, dtype=np.float64)[..., 2]
        row = np.stack([np.sin(th), -np.cos(th), np.full_like(th, -self.terrain.x_icr)], axis=-1)
        return row[..., None, :]

    def input_violations(self, u: FloatArray) -> list[tuple[str, NDArray[np.bool_]]]:
        """Track speeds beyond ``max_track_speed``."""
        return [("track speed", np.any(np.abs(u) > self.max_track_speed, axis=-1))]
