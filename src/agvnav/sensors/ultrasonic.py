"""Ultrasonic range sensors (HY-SRF05-like) measuring walls, for seed 004.

Seed 004 (§II) mounts HY-SRF05 ultrasonic rangers on a tracked robot: pairs
on the sides measure wall landmarks alongside ([seed004 eq6] [seed004 eq7]), a front one
the wall ahead at a corner [seed004 eq8]. It quotes an optimal range of 3-60 cm. The model:

* **Cone beam.** The echo comes from the nearest wall point inside a cone of
  half-angle ``half_angle`` about the sensor axis. Default 15°: HY-SRF05 /
  SRF05 datasheets quote a "measuring angle" of about 15° and the SRF05 beam
  plot has its main lobe within roughly ±15-20°; reading 15° as the
  half-angle is our assumption.
* **Exact geometry, vectorised.** For every segment the part inside the
  angular sector is found by clipping the segment against the two half-planes
  bounding the cone (a Liang-Barsky clip); the distance from the sensor along
  that sub-segment is convex, so its minimum is at the clipped foot of the
  perpendicular. No rays are cast.
* **Incidence.** A smooth wall reflects specularly: the echo of the nearest
  point travels along the ray to it, and if that ray meets the wall more than
  ``max_incidence`` (default 20°, assumed) away from the wall normal the echo
  misses the receiver. Such a wall is silent *and* ignored for occlusion (the
  mirror path is not modelled); a farther wall that does echo is reported.
* **Range limits.** ``min_range`` 0.02 m (HY-SRF05 blind zone, below the
  seed's 3 cm) and ``max_range`` 4.0 m (datasheet maximum, ~4-4.5 m). Closer
  or farther echoes are invalid readings. The seed's optimal band ends at
  ``optimal_max`` = 0.60 m: beyond it the noise grows.
* **Noise.** Gaussian, standard deviation ``noise_std`` (default 3 mm, the
  datasheet resolution) inside the optimal band, growing by
  ``noise_growth`` (m per m) beyond it; and a random dropout ``p_miss``.
* **Update rate** ``rate_hz`` (default 20 Hz: the datasheet asks for at least
  50 ms between pings). The time of flight (< 25 ms at 4 m) is neglected.
* **Mounting pose** ``mount = (x, y, theta)`` in ``base_link``; a sensor
  mounted strictly inside the vehicle body footprint is refused.

All ranges are measured from the sensor (transducer face) along the ray to
the echoing point, in metres; angles in radians (REP-103).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_nonnegative, require_positive
from agvnav.geometry import compose

__all__ = [
    "ConeEcho",
    "UltrasonicArray",
    "UltrasonicReadings",
    "UltrasonicSensor",
    "check_wall_segments",
    "cone_echo",
    "seed_004_layout",
]

#: Default half-angle of a ranger's beam cone (rad): 15 degrees.
HALF_ANGLE_RAD = math.radians(15.0)
#: Default largest incidence on a wall (rad) that still echoes back: 20 degrees.
MAX_INCIDENCE_RAD = math.radians(20.0)


@dataclass(frozen=True)
class ConeEcho:
    """Noise-free result of :func:`cone_echo`, all of shape ``(...)``.

    ``range`` (m, inf when nothing echoes), ``segment`` (index of the echoing
    segment, -1 if none), ``incidence`` (rad, angle between the echo ray and
    the wall normal; nan if none), ``valid`` (an echo within the range limits).
    """

    range: NDArray[np.float64]
    segment: NDArray[np.int64]
    incidence: NDArray[np.float64]
    valid: NDArray[np.bool_]


def check_wall_segments(segments: ArrayLike, min_length: float = 1e-9) -> NDArray[np.float64]:
    """Validate wall segments ``(M, 2, 2)`` (m) for the scalar/API path.

    Raises ValueError naming the first segment that is not finite or has zero
    length (shorter than ``min_length``).
    """
    seg = require_finite("wall segments", segments)
    if seg.ndim != 3 or seg.shape[1:] != (2, 2):
        raise ValueError(f"wall segments must have shape (M, 2, 2), got {seg.shape}")
    lengths = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=-1)
    bad = np.nonzero(lengths < min_length)[0]
    if bad.size:
        raise ValueError(f"wall segment {int(bad[0])} has zero length: {seg[bad[0]].tolist()}")
    return seg


def _clip_to_cone(
    ax: NDArray, ay: NDArray, dx: NDArray, dy: NDArray, sin_h: NDArray, cos_h: NDArray
) -> tuple[NDArray, NDArray]:
    """Parameter interval [t_lo, t_hi] of ``a + t d`` (t in [0, 1]) inside the cone (empty if t_lo > t_hi).

    The cone (half-angle < 90°, apex at the origin, axis +x) is the intersection
    of the half-planes ``x sin h - y cos h >= 0`` and ``x sin h + y cos h >= 0``.
    """
    t_lo = np.zeros(np.broadcast_shapes(ax.shape, sin_h.shape))
    t_hi = np.ones_like(t_lo)
    for sign in (-1.0, 1.0):
        g0 = ax * sin_h + sign * ay * cos_h
        slope = dx * sin_h + sign * dy * cos_h
        with np.errstate(divide="ignore", invalid="ignore"):
            root = -g0 / slope
        t_lo = np.where(slope > 0, np.maximum(t_lo, root), t_lo)
        t_hi = np.where(slope < 0, np.minimum(t_hi, root), np.where((slope == 0) & (g0 < 0), -1.0, t_hi))
    return t_lo, t_hi


def cone_echo(
    sensor_pose: ArrayLike,
    segments: ArrayLike,
    half_angle: ArrayLike = HALF_ANGLE_RAD,
    max_incidence: ArrayLike = MAX_INCIDENCE_RAD,
    min_range: ArrayLike = 0.02,
    max_range: ArrayLike = 4.0,
) -> ConeEcho:
    """Range to the nearest echoing wall inside the beam cone (noise-free).

    Parameters
    ----------
    sensor_pose : ``(..., 3)`` pose of the transducer in ``map`` (m, rad); its
        heading is the beam axis.
    segments : ``(M, 2, 2)`` wall segments in ``map`` (m). Zero-length segments
        never echo (flagged, not raised: this is the batch kernel).
    half_angle : cone half-angle (rad, in (0, pi/2)), broadcast to ``(...)``.
    max_incidence : largest angle (rad) between the echo ray and the wall
        normal that still returns an echo.
    min_range, max_range : valid range window (m).

    Returns
    -------
    ConeEcho with fields of shape ``(...)``. ``range`` is finite whenever some
    wall echoes (even outside the window); ``valid`` says it is inside it.

    Notes
    -----
    Exact: per segment, the sub-segment inside the sector is clipped, then
    the closest point of it to the apex is the perpendicular foot clamped to
    it (distance is convex along a line). Cost O(batch * M), no loops.
    """
    pose = np.asarray(sensor_pose, dtype=np.float64)
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    h = np.asarray(half_angle, dtype=np.float64)[..., None]
    c, s = np.cos(pose[..., 2])[..., None], np.sin(pose[..., 2])[..., None]
    px, py = pose[..., 0][..., None], pose[..., 1][..., None]
    # segment end points in the sensor frame, shape (..., M) per component
    ux, uy = seg[:, 0, 0] - px, seg[:, 0, 1] - py
    ax, ay = c * ux + s * uy, c * uy - s * ux
    wx, wy = seg[:, 1, 0] - seg[:, 0, 0], seg[:, 1, 1] - seg[:, 0, 1]
    dx, dy = c * wx + s * wy, c * wy - s * wx
    dd = wx * wx + wy * wy  # (M,)
    t_lo, t_hi = _clip_to_cone(ax, ay, dx, dy, np.sin(h), np.cos(h))
    with np.errstate(divide="ignore", invalid="ignore"):
        t_foot = np.where(dd > 0, -(ax * dx + ay * dy) / dd, 0.0)
        t = np.clip(t_foot, t_lo, np.maximum(t_lo, t_hi))
        qx, qy = ax + t * dx, ay + t * dy
        dist = np.hypot(qx, qy)
        normal_part = np.abs(qx * dy - qy * dx) / np.sqrt(dd)
        cos_inc = np.where(dist > 0, normal_part / dist, 1.0)
    incidence = np.arccos(np.clip(cos_inc, 0.0, 1.0))
    echoes = (t_lo <= t_hi) & (dd > 0) & (incidence <= np.asarray(max_incidence)[..., None] + 1e-12)
    masked = np.concatenate([np.where(echoes, dist, np.inf), np.full(dist.shape[:-1] + (1,), np.inf)], axis=-1)
    nearest = np.argmin(masked, axis=-1)  # the appended inf column makes M = 0 work
    rng = np.take_along_axis(masked, nearest[..., None], axis=-1)[..., 0]
    found = np.isfinite(rng)
    padded = np.concatenate([incidence, masked[..., -1:]], axis=-1)
    inc = np.take_along_axis(padded, nearest[..., None], axis=-1)[..., 0]
    valid = found & (rng >= min_range) & (rng <= max_range)
    return ConeEcho(
        range=rng,
        segment=np.where(found, nearest, -1).astype(np.int64),
        incidence=np.where(found, inc, np.nan),
        valid=valid,
    )


@dataclass(frozen=True)
class UltrasonicReadings:
    """Readings of one sensor: ``t (k,)`` (s), ``range (k,)`` (m, nan when invalid),
    ``valid (k,)``; ``segment (k,)`` is the ground-truth echoing wall (tests only)."""

    t: NDArray[np.float64]
    range: NDArray[np.float64]
    valid: NDArray[np.bool_]
    segment: NDArray[np.int64]


@dataclass(frozen=True)
class UltrasonicSensor:
    """One HY-SRF05-like ranger; see the module docstring for the model and defaults.

    ``mount`` is ``(x, y, theta)`` in ``base_link`` (m, rad); ``phase`` (s) is
    the time of its first ping (stagger sensors to avoid crosstalk).
    """

    mount: tuple[float, float, float] = (0.0, 0.0, 0.0)
    half_angle: float = HALF_ANGLE_RAD
    max_incidence: float = MAX_INCIDENCE_RAD
    min_range: float = 0.02
    max_range: float = 4.0
    optimal_max: float = 0.60
    noise_std: float = 0.003
    noise_growth: float = 0.01
    p_miss: float = 0.0
    rate_hz: float = 20.0
    phase: float = 0.0

    def __post_init__(self) -> None:
        mount = require_finite("mount", self.mount)
        if mount.shape != (3,):
            raise ValueError(f"mount must be (x, y, theta), got shape {mount.shape}")
        object.__setattr__(self, "mount", tuple(float(v) for v in mount))
        if not 0.0 < self.half_angle < math.pi / 2:
            raise ValueError(f"half_angle must be in (0, pi/2) rad, got {self.half_angle!r}")
        if not 0.0 <= self.max_incidence <= math.pi / 2:
            raise ValueError(f"max_incidence must be in [0, pi/2] rad, got {self.max_incidence!r}")
        require_nonnegative("min_range", self.min_range)
        require_positive("max_range", self.max_range)
        if not self.min_range < self.optimal_max <= self.max_range:
            raise ValueError("need min_range < optimal_max <= max_range")
        require_nonnegative("noise_std", self.noise_std)
        require_nonnegative("noise_growth", self.noise_growth)
        if not 0.0 <= self.p_miss <= 1.0:
            raise ValueError(f"p_miss must be in [0, 1], got {self.p_miss!r}")
        require_positive("rate_hz", self.rate_hz)
        require_finite("phase", self.phase)

    def sensor_pose(self, pose: ArrayLike) -> NDArray[np.float64]:
        """Transducer pose ``(..., 3)`` in ``map`` for base_link poses ``(..., 3)``."""
        return compose(pose, np.asarray(self.mount))

    def echo(self, pose: ArrayLike, segments: ArrayLike) -> ConeEcho:
        """Noise-free echo for base_link poses ``(..., 3)`` and walls ``(M, 2, 2)``."""
        return cone_echo(
            self.sensor_pose(pose), segments, self.half_angle, self.max_incidence, self.min_range, self.max_range
        )

    def noise_std_at(self, true_range: ArrayLike) -> NDArray[np.float64]:
        """Range noise standard deviation (m) at a true range (m)."""
        r = np.asarray(true_range, dtype=np.float64)
        return self.noise_std + self.noise_growth * np.maximum(r - self.optimal_max, 0.0)

    def measure(
        self, pose: ArrayLike, segments: ArrayLike, rng: np.random.Generator
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64]]:
        """Noisy readings ``(range, valid, segment)`` of shape ``(...)`` for poses ``(..., 3)``.

        ``range`` is nan where invalid (no echo, out of window, or dropout).
        Draws exactly two standard variates per pose, so results depend only on
        the generator state.
        """
        e = self.echo(pose, segments)
        shape = e.range.shape
        noise = rng.standard_normal(shape)
        drop = rng.random(shape) < self.p_miss
        finite = np.where(np.isfinite(e.range), e.range, 0.0)
        noisy = finite + self.noise_std_at(finite) * noise
        valid = e.valid & ~drop & (noisy >= self.min_range) & (noisy <= self.max_range)
        return np.where(valid, noisy, np.nan), valid, e.segment

    def ping_times(self, t0: float, t1: float) -> NDArray[np.float64]:
        """Ping instants in the half-open window ``(t0, t1]`` (s): ``phase + k / rate_hz``.

        Same window convention as the goniometer and the simulator's steps, so
        back-to-back windows never repeat or lose a ping.
        """
        period = 1.0 / self.rate_hz
        k0 = math.floor((t0 - self.phase) / period + 1e-9) + 1
        k1 = math.floor((t1 - self.phase) / period + 1e-9) + 1
        return self.phase + period * np.arange(k0, k1, dtype=np.float64)

    def scan(
        self,
        segments: ArrayLike,
        pose_at: Callable[[NDArray[np.float64]], NDArray[np.float64]],
        t0: float,
        t1: float,
        rng: np.random.Generator,
    ) -> UltrasonicReadings:
        """All readings in ``(t0, t1]``; ``pose_at(t (k,)) -> (k, 3)`` is the true pose."""
        t = self.ping_times(t0, t1)
        if t.size == 0:
            empty = np.zeros(0)
            return UltrasonicReadings(empty, empty, empty.astype(bool), empty.astype(np.int64))
        r, valid, seg = self.measure(np.asarray(pose_at(t), dtype=np.float64).reshape(-1, 3), segments, rng)
        return UltrasonicReadings(t, r, valid, seg)

    def check_mount(self, body_length: float, body_width: float, name: str = "sensor") -> None:
        """Raise ValueError if the mount lies strictly inside the body rectangle.

        The body is ``body_length`` x ``body_width`` (m) centred on base_link.
        A sensor on the outline must face outwards (not into the body).
        """
        x, y, theta = self.mount
        hx, hy = body_length / 2.0, body_width / 2.0
        tol = 1e-9
        if abs(x) < hx - tol and abs(y) < hy - tol:
            raise ValueError(
                f"{name} mount ({x:.3f}, {y:.3f}) lies inside the vehicle body "
                f"({body_length:.3f} x {body_width:.3f} m); place it on or outside the outline"
            )
        outward = np.array([np.sign(x) * (abs(x) >= hx - tol), np.sign(y) * (abs(y) >= hy - tol)])
        axis = np.array([math.cos(theta), math.sin(theta)])
        if np.all(outward * axis <= 0.0):
            raise ValueError(f"{name} at ({x:.3f}, {y:.3f}) points into the vehicle body")


@dataclass(frozen=True)
class UltrasonicArray:
    """Named sensors on one vehicle body (``body_length`` x ``body_width``, m, centred on base_link).

    Construction validates every mount (ValueError naming the sensor).
    """

    sensors: Mapping[str, UltrasonicSensor]
    body_length: float = 0.45
    body_width: float = 0.40
    names: tuple[str, ...] = field(init=False)
    _params: dict[str, NDArray[np.float64]] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        require_positive("body_length", self.body_length)
        require_positive("body_width", self.body_width)
        if not self.sensors:
            raise ValueError("an ultrasonic array needs at least one sensor")
        for name, sensor in self.sensors.items():
            sensor.check_mount(self.body_length, self.body_width, name=f"sensor {name!r}")
        object.__setattr__(self, "names", tuple(self.sensors))
        attrs = ("half_angle", "max_incidence", "min_range", "max_range", "optimal_max", "noise_std",
                 "noise_growth", "p_miss")
        params = {a: np.array([getattr(self.sensors[n], a) for n in self.names]) for a in attrs}
        params["mount"] = np.array([self.sensors[n].mount for n in self.names])
        object.__setattr__(self, "_params", params)

    def __getitem__(self, name: str) -> UltrasonicSensor:
        return self.sensors[name]

    def sensor_poses(self, pose: ArrayLike) -> NDArray[np.float64]:
        """Transducer poses ``(..., S, 3)`` in ``map`` for base_link poses ``(..., 3)``, in ``names`` order."""
        return compose(np.asarray(pose, dtype=np.float64)[..., None, :], self._params["mount"])

    def echo(self, pose: ArrayLike, segments: ArrayLike) -> ConeEcho:
        """Noise-free echoes of all sensors at once, fields ``(..., S)`` in ``names`` order."""
        return cone_echo(
            self.sensor_poses(pose),
            segments,
            self._per_sensor("half_angle"),
            self._per_sensor("max_incidence"),
            self._per_sensor("min_range"),
            self._per_sensor("max_range"),
        )

    def measure(self, pose: ArrayLike, segments: ArrayLike, rng: np.random.Generator) -> dict[str, float]:
        """One noisy reading (m, nan when invalid) per sensor for one base_link pose ``(3,)``.

        Same model as :meth:`UltrasonicSensor.measure`, batched over the
        sensors: one normal and one uniform draw per sensor, in ``names`` order.
        """
        p = require_finite("pose", pose).reshape(3)
        seg = check_wall_segments(segments) if np.size(segments) else np.zeros((0, 2, 2))
        e = self.echo(p, seg)
        noise = rng.standard_normal(len(self.names))
        drop = rng.random(len(self.names)) < self._per_sensor("p_miss")
        finite = np.where(np.isfinite(e.range), e.range, 0.0)
        std = self._per_sensor("noise_std") + self._per_sensor("noise_growth") * np.maximum(
            finite - self._per_sensor("optimal_max"), 0.0
        )
        noisy = finite + std * noise
        valid = e.valid & ~drop & (noisy >= self._per_sensor("min_range")) & (noisy <= self._per_sensor("max_range"))
        return dict(zip(self.names, np.where(valid, noisy, np.nan).tolist(), strict=True))

    def _per_sensor(self, attr: str) -> NDArray[np.float64]:
        return self._params[attr]


def seed_004_layout(
    spacing: float = 0.30,
    body_length: float = 0.45,
    body_width: float = 0.40,
    sensor: UltrasonicSensor | None = None,
) -> UltrasonicArray:
    """The seed-004 robot (45 x 40 cm) with a side pair on each side and a front sensor.

    Names: ``right_front``, ``right_rear``, ``left_front``, ``left_rear`` (on the
    side faces, ``spacing`` m apart along x, beams perpendicular to the body:
    the ``dist`` of [seed004 eq6] [seed004 eq7]) and ``front`` (centre of the front face,
    for [seed004 eq8]). The 0.30 m spacing is an assumption (the seed gives no value).
    Pings are staggered by a quarter period to avoid crosstalk.
    """
    base = sensor or UltrasonicSensor()
    require_positive("spacing", spacing)
    if spacing > body_length:
        raise ValueError(f"spacing {spacing!r} m exceeds the body length {body_length!r} m")
    hx, hy, q = body_length / 2.0, body_width / 2.0, 0.25 / base.rate_hz
    mounts = {
        "right_front": ((spacing / 2, -hy, -math.pi / 2), 0.0),
        "right_rear": ((-spacing / 2, -hy, -math.pi / 2), q),
        "left_front": ((spacing / 2, hy, math.pi / 2), 0.0),
        "left_rear": ((-spacing / 2, hy, math.pi / 2), q),
        "front": ((hx, 0.0, 0.0), 2 * q),
    }
    sensors = {name: replace(base, mount=m, phase=ph) for name, (m, ph) in mounts.items()}
    return UltrasonicArray(sensors, body_length, body_width)


