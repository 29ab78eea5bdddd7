"""Ultrasonic ranges to wall lines as scalar EKF measurements (seed 004 landmarks, one range at a time).

Seed 004 corrects dead reckoning with walls measured by ultrasonic rangers:
the side pair gives the heading ([seed004 eq6] [seed004 eq7]), the front sensor the
position along the wall's normal ([seed004 eq8]). Both are the same measurement taken one range at a
time: the distance from a sensor to a known wall line. A filter that fuses
each range by itself needs no pairing, and fuses walls with reflector bearings
(:class:`agvnav.positioning.ekf.EkfEstimator`).

Model. A ranger mounted at ``m = (x_s, y_s, phi)`` on base_link at pose
``x = (p, psi)`` sits at ``s = p + R(psi) [x_s, y_s]`` and beams along
``b = (cos(psi + phi), sin(psi + phi))``. A wall's line is ``n . q = c``, the
unit normal ``n`` pointing to the sensor, so the sensor's distance to the line
is ``d = n . s - c`` (> 0). Then

* ``beam="cone"`` (the nearest echo inside the cone, agvnav.sensors.ultrasonic,
  the default): ``h(x) = d`` while the foot of the perpendicular lies inside
  the cone and on the wall; ``H = [n_x, n_y, n . R'(psi) [x_s, y_s]]``;
* ``beam="ray"`` (range measured along the sensor axis, the reading of seed
  004, [seed004 eq6] to [seed004 eq8]): ``h(x) = d / g`` with ``g = -n . b`` the cosine of the
  incidence; ``H = [n / g, (n . R' m) / g + d (n . b') / g^2]``,
  ``b' = (-sin(psi + phi), cos(psi + phi))``.

[seed004 eq8] (``x = x_lan - US``) is ``h`` for a sensor at base_link facing a wall
across the x axis; [seed004 eq6] [seed004 eq7] are what two such ranges of a side pair imply for
the heading (the EKF gets it from the ``psi`` column of ``H``).

Association: for one reading the candidate walls are those whose line model
holds at the estimated pose (cone: perpendicular inside the half-angle, foot
on the wall ``end_margin`` inside its ends; ray: the axis meets the wall
inside its ends within the sensor's ``max_incidence``); the nearest candidate
echoes first (as the sensor reports the nearest echo), and its innovation must
pass the chi-square gate ``y^2 / S <= gate``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_nonnegative
from agvnav.sensors.ultrasonic import UltrasonicArray, check_wall_segments

__all__ = ["RangeAssociation", "WallRangeMeasurement", "WallRangeModel", "wall_range", "wall_range_jacobian"]

BEAMS = ("cone", "ray")


def _check_beam(beam: str) -> None:
    if beam not in BEAMS:
        raise ValueError(f"beam must be 'cone' or 'ray', got {beam!r}")


def _parts(
    pose: ArrayLike, mount: ArrayLike, normal: ArrayLike, c: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Distance ``d``, ``n . R' m``, ``g = -n . b``, ``n . b'`` and ``n`` for poses ``(..., 3)``."""
    x = np.asarray(pose, dtype=np.float64)
    xs, ys, phi = (float(v) for v in np.asarray(mount, dtype=np.float64).reshape(3))
    n = np.asarray(normal, dtype=np.float64).reshape(2)
    psi = x[..., 2]
    cp, sp = np.cos(psi), np.sin(psi)
    sx, sy = x[..., 0] + cp * xs - sp * ys, x[..., 1] + sp * xs + cp * ys
    d = n[0] * sx + n[1] * sy - c
    n_dm = n[0] * (-sp * xs - cp * ys) + n[1] * (cp * xs - sp * ys)
    cb, sb = np.cos(psi + phi), np.sin(psi + phi)
    g = -(n[0] * cb + n[1] * sb)
    n_db = -n[0] * sb + n[1] * cb
    return d, n_dm, g, n_db, n


def wall_range(
    pose: ArrayLike, mount: ArrayLike, normal: ArrayLike, c: float, beam: str = "cone"
) -> NDArray[np.float64]:
    """Predicted range ``h(x)`` (m) of a ranger at ``mount (3,)`` to the wall line ``n . q = c`` [seed004 eq8].

    Parameters
    ----------
    pose : ``(..., 3)`` base_link poses ``(x, y, psi)`` (m, m, rad).
    mount : ``(3,)`` sensor pose ``(x_s, y_s, phi)`` in base_link (m, m, rad).
    normal, c : unit normal ``(2,)`` of the line, pointing to the sensor, and ``c = n . a`` (m).
    beam : ``"cone"`` (perpendicular distance) or ``"ray"`` (distance along the axis).

    Returns ``(...)`` ranges; see the module docstring for the model.
    """
    _check_beam(beam)
    d, _, g, _, _ = _parts(pose, mount, normal, c)
    return d if beam == "cone" else d / g


def wall_range_jacobian(
    pose: ArrayLike, mount: ArrayLike, normal: ArrayLike, c: float, beam: str = "cone"
) -> NDArray[np.float64]:
    """``H = dh/dx`` ``(..., 3)`` of :func:`wall_range` (m/m, m/m, m/rad)."""
    _check_beam(beam)
    d, n_dm, g, n_db, n = _parts(pose, mount, normal, c)
    if beam == "cone":
        return np.stack(np.broadcast_arrays(n[0] + 0.0 * d, n[1] + 0.0 * d, n_dm), axis=-1)
    return np.stack([n[0] / g, n[1] / g, n_dm / g + d * n_db / g**2], axis=-1)


@dataclass(frozen=True)
class RangeAssociation:
    """One range matched to a wall: ``wall`` index, innovation ``y = r - h`` (m), ``H (3,)``,
    measurement variance ``R`` (m²), ``S = H P H^T + R`` (m²) and ``nis = y² / S``."""

    wall: int
    innovation: float
    H: tuple[float, float, float]
    R: float
    S: float
    nis: float


@dataclass(frozen=True)
class WallRangeMeasurement:
    """The range (m) of an ultrasonic ranger at ``mount`` to the wall line ``n . q = c`` [seed004 eq8].

    ``normal`` points to the sensor; ``beam`` ``"cone"`` (perpendicular distance) or
    ``"ray"`` (along the axis); ``R = range_var`` (m²). No consider parameter (walls are
    taken as exact). [seed004 eq6] [seed004 eq7]: a side pair's two ranges fix the heading
    through the ``psi`` column of ``H``.
    """

    mount: tuple[float, float, float]
    normal: tuple[float, float]
    c: float
    range_var: float
    beam: str = "cone"
    index: int = -1
    gate: float = math.inf
    name: str = "wall_range"
    consider_index: int = -1

    def h(self, x: Sequence[float]) -> float:
        """Predicted range (m)."""
        return float(wall_range(np.asarray(x), self.mount, self.normal, self.c, self.beam))

    def jacobian(self, x: Sequence[float]) -> tuple[float, float, float]:
        """``dh/d[x, y, psi]`` (m/m, m/m, m/rad)."""
        H = wall_range_jacobian(np.asarray(x), self.mount, self.normal, self.c, self.beam)
        return float(H[0]), float(H[1]), float(H[2])

    def noise(self, x: Sequence[float]) -> float:
        """``sigma_r^2`` (m²) at the reading's range."""
        return self.range_var

    def residual(self, z: float, h: float) -> float:
        """``z - h`` (m)."""
        return z - h

    def consider_jacobian(self, x: Sequence[float]) -> tuple[float, float]:
        """No consider parameter: ``(0, 0)``."""
        return 0.0, 0.0


class WallRangeModel:
    """Known walls and the rangers that measure them: association and linearisation of one range.

    Parameters
    ----------
    walls : ``(M, 2, 2)`` wall segments (m) in ``map``.
    rangers : the :class:`~agvnav.sensors.ultrasonic.UltrasonicArray` (names, mounts, cone, noise).
    beam : ``"cone"`` (default, the simulated rangers) or ``"ray"`` (see the module docstring).
    end_margin : the modelled point must lie this far (m) inside the wall's ends.
    max_range : readings beyond this (m) are not used (default: each sensor's ``max_range``).
    """

    def __init__(
        self,
        walls: ArrayLike,
        rangers: UltrasonicArray,
        *,
        beam: str = "cone",
        end_margin: float = 0.05,
        max_range: float | None = None,
    ) -> None:
        if rangers is None:
            raise ValueError("wall ranges need the rangers (an UltrasonicArray) as well as the walls")
        _check_beam(beam)
        self.walls = check_wall_segments(walls) if np.size(walls) else np.zeros((0, 2, 2))
        self.rangers = rangers
        self.beam = beam
        self.end_margin = require_nonnegative("end_margin", end_margin)
        self.max_range = None if max_range is None else float(require_finite("max_range", max_range))
        a, b = self.walls[:, 0], self.walls[:, 1]
        self._length = np.hypot(*(b - a).T)
        self._tangent = (b - a) / np.where(self._length > 0.0, self._length, 1.0)[:, None]
        self._normal = np.stack([-self._tangent[:, 1], self._tangent[:, 0]], axis=-1)
        self._c = np.einsum("ij,ij->i", self._normal, a)

    def check_names(self, names: Sequence[str]) -> None:
        """ValueError naming any reading whose sensor is not in the array."""
        unknown = sorted(set(names) - set(self.rangers.names))
        if unknown:
            raise ValueError(f"unknown rangers {unknown}; the array has {list(self.rangers.names)}")

    def candidates(self, name: str, pose: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """Walls whose line model holds for sensor ``name`` at ``pose (3,)``, and their predicted ranges (m)."""
        sensor = self.rangers[name]
        x = np.asarray(pose, dtype=np.float64).reshape(3)
        xs, ys, phi = sensor.mount
        cp, sp = math.cos(x[2]), math.sin(x[2])
        s = np.array([x[0] + cp * xs - sp * ys, x[1] + sp * xs + cp * ys])
        b = np.array([math.cos(x[2] + phi), math.sin(x[2] + phi)])
        signed = self._normal @ s - self._c
        flip = np.where(signed < 0.0, -1.0, 1.0)
        d, n = signed * flip, self._normal * flip[:, None]
        g = -(n @ b)  # cosine of the angle between the axis and the way to the wall
        if self.beam == "cone":
            h = d
            point = s - d[:, None] * n
            ok = g >= math.cos(sensor.half_angle)
        else:
            h = d / np.where(g > 0.0, g, np.inf)
            point = s + h[:, None] * b
            ok = g >= math.cos(sensor.max_incidence)
        along = np.einsum("ij,ij->i", point - self.walls[:, 0], self._tangent)
        ok &= (d > 0.0) & (along >= self.end_margin) & (along <= self._length - self.end_margin)
        index = np.flatnonzero(ok)
        return index, h[index]

    def measurement(
        self, name: str, r: float, x: Sequence[float], gate: float = math.inf
    ) -> WallRangeMeasurement | None:
        """The measurement model of reading ``r`` (m) of sensor ``name``: its nearest modelled wall at pose ``x``.

        None when the reading is out of the sensor's range or no wall's line model holds.
        The chi-square ``gate`` is the model's (:meth:`~agvnav.positioning.ekf_core.EkfCore.update`).
        """
        sensor = self.rangers[name]
        limit = sensor.max_range if self.max_range is None else self.max_range
        if not (math.isfinite(r) and sensor.min_range <= r <= limit):
            return None
        index, h = self.candidates(name, x)
        if index.size == 0:
            return None
        j = int(index[int(np.argmin(h))])
        pose = np.asarray(x, dtype=np.float64).reshape(3)
        n = self._normal[j]
        if float(n @ self._sensor_xy(name, pose) - self._c[j]) < 0.0:
            n = -n
        mount = tuple(float(v) for v in sensor.mount)
        return WallRangeMeasurement((mount[0], mount[1], mount[2]), (float(n[0]), float(n[1])),
                                    float(n @ self.walls[j, 0]), float(sensor.noise_std_at(r)) ** 2, self.beam, j,
                                    gate)

    def associate(
        self, name: str, r: float, x: Sequence[float], P: Sequence[float], gate: float
    ) -> RangeAssociation | None:
        """The nearest modelled wall for reading ``r`` (m) of sensor ``name`` if it passes the gate, else None.

        ``x`` the state ``(3,)``, ``P`` its covariance (flat row-major 9 or ``(3, 3)``),
        ``gate`` the chi-square threshold on ``y² / S``.
        """
        model = self.measurement(name, r, x, gate)
        if model is None:
            return None
        pose = (float(x[0]), float(x[1]), float(x[2]))
        H = np.array(model.jacobian(pose))
        innovation = model.residual(r, model.h(pose))
        S = float(H @ np.asarray(P, dtype=np.float64).reshape(3, 3) @ H) + model.range_var
        nis = innovation**2 / S
        if not nis <= gate:
            return None
        return RangeAssociation(model.index, innovation, (float(H[0]), float(H[1]), float(H[2])), model.range_var, S,
                                nis)

    def _sensor_xy(self, name: str, pose: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(self.rangers[name].sensor_pose(pose), dtype=np.float64)[:2]
