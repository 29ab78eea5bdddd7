"""The rotating laser goniometer of seed 000 (§2.1, §4.1) as a sensor model.

A laser head fixed to the vehicle frame turns at ``rate_hz`` (8 Hz in seed 000
§4.1). Its beam sweeps the horizon; when it meets a reflector an incremental
encoder (65535 pulses per revolution, 0.095 mrad) gives the beam angle relative
to the frame *at the start of the reflection* (seed 000 §2.1). For a cylindrical
reflector of radius ``r`` at distance ``d`` from the head centre P that is the
tangent edge the beam meets first, offset from the centre bearing by
``asin(r/d)`` against the rotation. The vehicle keeps moving during the sweep,
so each reflector is seen at its own instant; :meth:`Goniometer.scan` solves
those instants exactly by root finding in the moving frame.

Frames and conventions (docs/ARCHITECTURE.md): ``pose_at(t)`` gives the true
``base_link`` pose in ``map``; the head centre P sits at ``mount = (x, y, theta)``
in ``base_link``; a reported bearing is the encoder angle in the head frame
(x-axis rotated by ``mount[2]`` from ``base_link``), CCW positive, in [-pi, pi).

Modelling choices beyond the seed (which only states the start-of-reflection
rule): occlusion is tested on the line from P to the near surface of the
cylinder, and a partly hidden cylinder counts as fully visible or fully hidden;
the range limits apply to the beam length to the tangent point; spurious
reflections ("shiny surfaces") are a Poisson process in time whose bearing is
the encoder reading at that instant; timestamp jitter is Gaussian, clipped into
the scan window. The same seed *and the same windows* reproduce a scan bit for bit.

Cost: one call evaluates the pose on the quarter-revolution grid once and ~2 more
times for all its crossings together; the offsets, the bracket search and the
line-of-sight tests run in the compiled kernels of :mod:`agvnav.sensors.beam` (one
formulation, looping over reflectors and walls without NumPy per-call overhead),
so a simulator should scan once per control step rather than in finer slices.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_finite, require_nonnegative, require_positive
from agvnav.geometry.angles import wrap_angle, wrap_angle_scalar
from agvnav.geometry.hermite import HermitePoses
from agvnav.kinematics.twist import TwistPoses
from agvnav.sensors.beam import (
    HERMITE,
    TWIST,
    chord_brackets,
    chord_step,
    grid_crossings,
    line_of_sight,
    offsets_at,
    scan_motion,
    seen_in_order,
)
from agvnav.world.map import WorldMap

__all__ = [
    "Goniometer",
    "Reflections",
    "leading_edge_bearing",
    "reflector_centre_bearing",
]

TWO_PI = 2.0 * math.pi
#: Grid intervals per head revolution used to bracket the crossings (each interval
#: then holds at most one crossing per reflector, and the beam-edge offset moves by
#: about pi/2 < pi across it, so its wrapped value is continuous on the bracket).
_BRACKETS_PER_REV = 4
_ANGLE_TOL = 1e-10  # rad: root-finding tolerance on the beam-edge offset (1e-6 of a 65535 encoder step)
_MAX_ITER = 60
_CHORD_ITER = 6

PoseFunction = Callable[[NDArray[np.float64]], ArrayLike]
_EPS = float(np.finfo(np.float64).eps)


@dataclass(frozen=True, eq=False)
class _MapArrays:
    """Per-map constants of the scan, sliced once: reflector columns and wall start/direction.

    The map never changes during a run; slicing it on every scan cost more than the
    arithmetic on a handful of reflectors and walls.
    """

    world: WorldMap
    rx: NDArray[np.float64]  # (N,) reflector centres x, y (m) and radii (m)
    ry: NDArray[np.float64]
    r: NDArray[np.float64]
    wall_x0: NDArray[np.float64]  # (M,) wall segment starts (m) and directions (m)
    wall_y0: NDArray[np.float64]
    wall_vx: NDArray[np.float64]
    wall_vy: NDArray[np.float64]

    @classmethod
    def of(cls, world: WorldMap) -> _MapArrays:
        xy, seg = world.reflector_xy, world.wall_segments
        return cls(
            world, xy[:, 0].copy(), xy[:, 1].copy(), world.reflector_radius,
            seg[:, 0, 0].copy(), seg[:, 0, 1].copy(),
            seg[:, 1, 0] - seg[:, 0, 0], seg[:, 1, 1] - seg[:, 0, 1],
        )

    def sight(self) -> tuple[Any, ...]:
        """The reflector and wall columns (arrays) for :func:`~agvnav.sensors.beam.line_of_sight`."""
        return (self.rx, self.ry, self.r, self.wall_x0, self.wall_y0, self.wall_vx, self.wall_vy)


@dataclass(frozen=True, eq=False)
class Reflections:
    """Anonymous reflections of one scan, in time order.

    Attributes
    ----------
    t:
        ``(k,)`` reported instants (s), non-decreasing.
    bearing:
        ``(k,)`` encoder bearing (rad, head frame, [-pi, pi)), quantised.
    reflector_index:
        ``(k,)`` int: ground truth row in ``WorldMap.reflector_xy`` (-1 for a
        spurious reflection). For tests and evaluation only: positioning never reads it.
    """

    t: NDArray[np.float64]
    bearing: NDArray[np.float64]
    reflector_index: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def __post_init__(self) -> None:
        t = np.array(self.t, dtype=np.float64).reshape(-1)
        bearing = np.array(self.bearing, dtype=np.float64).reshape(-1)
        index = np.array(self.reflector_index, dtype=np.int64).reshape(-1)
        if index.size == 0 and t.size:
            index = np.full(t.size, -1, dtype=np.int64)
        if not (t.shape == bearing.shape == index.shape):
            raise ValueError(f"t, bearing and reflector_index must have equal lengths, got "
                             f"{t.shape}, {bearing.shape}, {index.shape}")
        if t.size > 1 and np.any(np.diff(t) < 0.0):
            raise ValueError("reflection times must be non-decreasing")
        for name, arr in (("t", t), ("bearing", bearing), ("reflector_index", index)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        return int(self.t.size)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Reflections):
            return NotImplemented
        return all(np.array_equal(getattr(self, k), getattr(other, k)) for k in ("t", "bearing", "reflector_index"))

    __hash__ = None  # type: ignore[assignment]

    @classmethod
    def empty(cls) -> Reflections:
        """No reflections (a shared immutable instance)."""
        return _EMPTY

    @classmethod
    def _trusted(
        cls, t: NDArray[np.float64], bearing: NDArray[np.float64], index: NDArray[np.int64]
    ) -> Reflections:
        """Wrap arrays the sensor built itself (time-ordered, right dtypes), skipping the checks."""
        out = object.__new__(cls)
        for name, arr in (("t", t), ("bearing", bearing), ("reflector_index", index)):
            arr.setflags(write=False)
            object.__setattr__(out, name, arr)
        return out

    @classmethod
    def concatenate(cls, parts: Sequence[Reflections]) -> Reflections:
        """Join consecutive scans (each time-ordered, windows in increasing order)."""
        if not parts:
            return cls.empty()
        return cls(
            np.concatenate([p.t for p in parts]),
            np.concatenate([p.bearing for p in parts]),
            np.concatenate([p.reflector_index for p in parts]),
        )


_EMPTY = Reflections(np.zeros(0), np.zeros(0), np.zeros(0, dtype=np.int64))


def leading_edge_bearing(
    head_pose: ArrayLike, reflector_xy: ArrayLike, radius: ArrayLike, direction: int = 1
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Bearing of the edge of a cylindrical reflector that a rotating beam meets first.

    Seed 000 §2.1: the encoder angle is taken at the *start* of the reflection. For a
    head turning CCW (``direction=+1``) the first point touched is the tangent edge at
    ``centre_bearing - asin(r/d)``; for a CW head, ``centre_bearing + asin(r/d)``.

    Parameters
    ----------
    head_pose:
        ``(..., 3)`` pose of the head frame in ``map`` (m, rad).
    reflector_xy:
        ``(..., 2)`` reflector centres (m).
    radius:
        ``(...)`` reflector radii (m).
    direction:
        +1 for a CCW head, -1 for CW.

    Returns
    -------
    bearing, distance, valid:
        ``(...)`` edge bearing in the head frame (rad, [-pi, pi)), head-to-centre
        distance (m), and ``valid`` (False when the head is inside the cylinder,
        ``d <= r``; the bearing is then NaN).
    """
    pose = np.asarray(head_pose, dtype=np.float64)
    xy = np.asarray(reflector_xy, dtype=np.float64)
    r = np.asarray(radius, dtype=np.float64)
    dx, dy = xy[..., 0] - pose[..., 0], xy[..., 1] - pose[..., 1]
    d = np.hypot(dx, dy)
    valid = d > r
    half_width = np.arcsin(np.where(valid, r / np.where(valid, d, 1.0), 0.0))
    bearing = wrap_angle(np.arctan2(dy, dx) - pose[..., 2] - direction * half_width)
    return np.where(valid, bearing, np.nan), d, valid


def reflector_centre_bearing(
    edge_bearing: ArrayLike, distance: ArrayLike, radius: ArrayLike, direction: int = 1
) -> NDArray[np.float64]:
    """Positioning-side correction from the reported edge bearing to the reflector centre.

    Inverts :func:`leading_edge_bearing`: ``centre = edge + direction * asin(r/d)``
    (rad, wrapped to [-pi, pi)); without it a CCW head biases every centre bearing by
    ``-asin(r/d)`` (4 mrad at 10 m for r = 4 cm). ``distance`` (m) is the head-to-centre
    distance, from the predicted pose. Vectorised; elements with ``d <= r`` or a
    non-finite input are NaN (flagged, never raising).
    """
    edge = np.asarray(edge_bearing, dtype=np.float64)
    d = np.asarray(distance, dtype=np.float64)
    r = np.asarray(radius, dtype=np.float64)
    valid = np.isfinite(edge) & np.isfinite(d) & np.isfinite(r) & (d > r) & (r >= 0.0)
    ratio = np.where(valid, r / np.where(valid, d, 1.0), 0.0)
    centre = wrap_angle(np.where(valid, edge, 0.0) + direction * np.arcsin(ratio))
    return np.where(valid, centre, np.nan)


@dataclass(frozen=True)
class Goniometer:
    """Rotating laser head with an incremental encoder (seed 000 §2.1, §4.1).

    Parameters
    ----------
    rate_hz:
        Head rotation frequency f (Hz, > 0); seed 000 §4.1: 8 Hz.
    pulses_per_rev:
        Encoder pulses per revolution N (> 0); seed 000 §4.1: 65535 (0.095 mrad).
    mount:
        ``(x, y, theta)`` of the head centre P and head x-axis in ``base_link`` (m, rad).
    min_range, max_range:
        Beam range limits (m), measured from P to the tangent point of the cylinder.
    p_miss:
        Probability in [0, 1] that a visible reflector gives no reflection.
    spurious_rate:
        Expected spurious reflections ("shiny surfaces") per revolution; a Poisson
        process in time whose bearing is the head angle at that instant.
    jitter_std:
        Standard deviation (s) of Gaussian timestamp jitter; the bearing is unaffected.
    phase:
        Head angle (rad) at t = 0.
    direction:
        +1 CCW (default), -1 CW.
    """

    rate_hz: float = 8.0
    pulses_per_rev: int = 65535
    mount: tuple[float, float, float] = (0.0, 0.0, 0.0)
    min_range: float = 0.0
    max_range: float = 30.0
    p_miss: float = 0.0
    spurious_rate: float = 0.0
    jitter_std: float = 0.0
    phase: float = 0.0
    direction: int = 1
    _maps: dict = field(default_factory=dict, init=False, repr=False, compare=False)
    _beam: tuple = field(default=(), init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "rate_hz", require_positive("rate_hz", self.rate_hz))
        n = self.pulses_per_rev
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n <= 0:
            raise ValueError(f"pulses_per_rev must be a positive integer, got {n!r}")
        object.__setattr__(self, "pulses_per_rev", int(n))
        mount = require_finite("mount", self.mount)
        if mount.shape != (3,):
            raise ValueError(f"mount must be (x, y, theta), got shape {mount.shape}")
        object.__setattr__(self, "mount", tuple(float(v) for v in mount))
        lo = require_nonnegative("min_range", self.min_range)
        hi = require_positive("max_range", self.max_range)
        if lo > hi:
            raise ValueError(f"min_range ({lo}) must not exceed max_range ({hi})")
        object.__setattr__(self, "min_range", lo)
        object.__setattr__(self, "max_range", hi)
        p = require_nonnegative("p_miss", self.p_miss)
        if p > 1.0:
            raise ValueError(f"p_miss must be in [0, 1], got {self.p_miss!r}")
        object.__setattr__(self, "p_miss", p)
        object.__setattr__(self, "spurious_rate", require_nonnegative("spurious_rate", self.spurious_rate))
        object.__setattr__(self, "jitter_std", require_nonnegative("jitter_std", self.jitter_std))
        phase = float(require_finite("phase", self.phase))
        object.__setattr__(self, "phase", phase)
        if self.direction not in (1, -1):
            raise ValueError(f"direction must be +1 (CCW) or -1 (CW), got {self.direction!r}")
        object.__setattr__(self, "direction", int(self.direction))
        mx, my, mth = self.mount  # the beam kernels' constants, once (see _consts)
        beam = (mx, my, self.phase + mth, self.direction * TWO_PI * self.rate_hz, self.direction)
        object.__setattr__(self, "_beam", beam)

    @property
    def resolution(self) -> float:
        """Encoder angular resolution 2*pi/N (rad); seed 000 §4.1: 0.095 mrad."""
        return TWO_PI / self.pulses_per_rev

    @property
    def noisy(self) -> bool:
        """True if :meth:`scan` draws random numbers (misses, spurious, jitter)."""
        return self.p_miss > 0.0 or self.spurious_rate > 0.0 or self.jitter_std > 0.0

    def head_angle(self, t: ArrayLike) -> NDArray[np.float64]:
        """True (unquantised) head angle phi(t) = phase + direction*2*pi*f*t, in [0, 2*pi) (rad).

        Computed in revolutions (fractional part) to keep precision over hours.
        """
        u = self.phase / TWO_PI + self.direction * self.rate_hz * np.asarray(t, dtype=np.float64)
        return TWO_PI * (u - np.floor(u))

    def encoder_bearing(self, t: ArrayLike) -> NDArray[np.float64]:
        """Encoder reading at instants ``t`` (s): floor of the head angle to whole pulses (rad, [-pi, pi))."""
        n = self.pulses_per_rev
        count = np.floor(self.head_angle(t) * (n / TWO_PI)) % n
        return wrap_angle(count * self.resolution)

    def head_pose(self, pose: ArrayLike) -> NDArray[np.float64]:
        """Head frame pose ``(..., 3)`` in ``map`` from the ``base_link`` pose ``(..., 3)`` (no wrap)."""
        q = np.asarray(pose, dtype=np.float64)
        mx, my, mth = self.mount
        c, s = np.cos(q[..., 2]), np.sin(q[..., 2])
        return np.stack([q[..., 0] + c * mx - s * my, q[..., 1] + s * mx + c * my, q[..., 2] + mth], axis=-1)

    def scan(
        self,
        world: WorldMap,
        pose_at: PoseFunction,
        t0: float,
        t1: float,
        rng: np.random.Generator | None = None,
    ) -> Reflections:
        """Reflections whose instant falls in the window ``(t0, t1]`` (s), in time order.

        For every reflector the instant t* at which the beam, turning in the moving
        vehicle frame, meets the reflector's leading edge solves

            wrap(direction * (psi(t) + theta_m + phi(t) - alpha_edge(t))) = 0,

        with ``alpha_edge`` the absolute direction of the leading tangent edge seen
        from P(t) (seed 000 §2.1). The window is split into brackets of a quarter
        revolution (one pose evaluation per bracket end); a bracket holds a crossing
        when the wrapped offset passes 2*pi. All crossings are then refined together,
        vectorised over reflectors, by chord iterations (Illinois regula falsi as the
        fallback) to 1e-10 rad, i.e. 2e-12 s. A crossing is reported if the beam range
        is within [min_range, max_range], the line of sight is not cut by a wall or
        another reflector, and it survives ``p_miss``. Spurious reflections
        and timestamp jitter are added; jittered times are clipped into the window so
        consecutive scans stay time-ordered.

        Parameters
        ----------
        world:
            Reflectors and walls.
        pose_at:
            ``pose_at(t (k,)) -> (k, 3)``: true ``base_link`` pose in ``map``, continuous in t.
        t0, t1:
            Window (s), ``t1 >= t0``. Consecutive windows sharing ends never report a
            reflection twice.
        rng:
            Source of every random draw; required when :attr:`noisy`.

        Returns
        -------
        Reflections
        """
        found = self._scan_arrays(world, pose_at, t0, t1, rng)
        return _EMPTY if found is None else Reflections._trusted(*found)

    def scan_rows(
        self,
        world: WorldMap,
        pose_at: PoseFunction,
        t0: float,
        t1: float,
        rng: np.random.Generator | None = None,
    ) -> NDArray[np.float64]:
        """:meth:`scan` as rows ``(k, 3)`` = ``(t (s), bearing (rad), reflector_index)``, in time order.

        The same reflections, the same random draws and the same checks as :meth:`scan`
        (bit-identical), without the :class:`Reflections` record: what the closed loop's
        sensor role hands the engine (issue 11). No reflection: a ``(0, 3)`` array.
        """
        found = self._scan_arrays(world, pose_at, t0, t1, rng)
        return _NO_ROWS if found is None else _rows(*found)

    def _scan_arrays(
        self, world: WorldMap, pose_at: PoseFunction, t0: float, t1: float, rng: np.random.Generator | None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]] | None:
        """:meth:`scan`'s ``(t, bearing, index)`` arrays, or None when the window holds no reflection.

        None without drawing anything in the common case of a short window with no true
        reflection and no clutter: nothing to quantise or draw.
        """
        t0, t1 = self._check_scan(world, t0, t1, rng)
        if t1 == t0:
            return None
        t_true, index = self._true_reflections(world, pose_at, t0, t1)
        if t_true.size == 0 and self.spurious_rate == 0.0:
            return None
        return self._add_noise(t_true, index, t0, t1, rng)

    def _check_scan(
        self, world: WorldMap, t0: float, t1: float, rng: np.random.Generator | None
    ) -> tuple[float, float]:
        """The window ``(t0, t1)`` as floats after :meth:`scan`'s checks (ValueError naming the problem)."""
        if not isinstance(world, WorldMap):
            raise ValueError(f"world must be a WorldMap, got {type(world).__name__}")
        t0, t1 = float(t0), float(t1)
        if not (math.isfinite(t0) and math.isfinite(t1)):
            raise ValueError(f"t0 and t1 must be finite, got {t0!r}, {t1!r}")
        if t1 < t0:
            raise ValueError(f"t1 ({t1}) must be >= t0 ({t0})")
        if self.noisy and not isinstance(rng, np.random.Generator):
            raise ValueError("rng must be a numpy.random.Generator when p_miss, spurious_rate or jitter_std > 0")
        return t0, t1

    # -- exact crossings -------------------------------------------------

    def _map_arrays(self, world: WorldMap) -> _MapArrays:
        """:class:`_MapArrays` of ``world``, built on first use (a few maps at most are kept)."""
        cached = self._maps.get(id(world))
        if cached is None or cached.world is not world:
            if len(self._maps) >= 8:
                self._maps.clear()
            cached = self._maps[id(world)] = _MapArrays.of(world)
        return cached

    def _consts(self) -> tuple[float, float, float, float, int]:
        """Per-scan constants of the beam kernels: mount offset ``(mx, my)`` (m), beam phase
        ``phase + mount_theta`` (rad), ``direction * 2 pi f`` (rad/s) and the direction
        (computed once in ``__post_init__``: the goniometer is frozen)."""
        return self._beam

    def _offsets(
        self, pose_at: PoseFunction, t: NDArray[np.float64],
        target: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    ) -> tuple[NDArray[np.float64], ...]:
        """Unwrapped offsets (rad), head x, y (m) and distances (m) at ``t (c,)``, one reflector per instant."""
        mx, my, phase, omega, direction = self._consts()
        rx, ry, r = target
        return offsets_at(t, _call_pose(pose_at, t), rx, ry, r, mx, my, phase, omega, direction)

    def _true_reflections(
        self, world: WorldMap, pose_at: PoseFunction, t0: float, t1: float
    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Exact, unquantised instants and reflector rows of the visible crossings in (t0, t1]."""
        m = self._map_arrays(world)
        if m.rx.shape[0] == 0:
            return np.zeros(0), np.zeros(0, dtype=np.int64)
        n_int = max(1, math.ceil((t1 - t0) * self.rate_hz * _BRACKETS_PER_REV))
        grid = _bracket_grid(t0, t1, n_int)
        consts = self._consts()
        motion = _motion_table(pose_at)
        if motion is not None:  # the whole scan in one kernel call, same numbers
            rx, ry, r, w0x, w0y, wvx, wvy = m.sight()
            status, t_seen, r_seen = scan_motion(
                *motion, grid, rx, ry, r, *consts, w0x, w0y, wvx, wvy,
                self.min_range, self.max_range, self.rate_hz, _ANGLE_TOL, _EPS, _CHORD_ITER,
            )
            if status == 0:
                return t_seen, r_seen  # else (rare): the generic path below, Illinois or the error
        rx, ry, r = m.sight()[:3]
        interval, refl, f_lo, f_hi = grid_crossings(grid, _call_pose(pose_at, grid), rx, ry, r, *consts)
        if interval.size == 0:
            return np.zeros(0), np.zeros(0, dtype=np.int64)
        t_star, hx, hy, d = self._refine(m, pose_at, grid, interval, f_lo, f_hi, refl)
        rx, ry, r, w0x, w0y, wvx, wvy = m.sight()
        seen = line_of_sight(refl, hx, hy, d, rx, ry, r, w0x, w0y, wvx, wvy, self.min_range, self.max_range)
        return seen_in_order(t_star, refl, np.asarray(seen))

    def _refine(
        self,
        m: _MapArrays,
        pose_at: PoseFunction,
        grid: NDArray[np.float64],
        interval: NDArray[np.int64],
        f_lo: NDArray[np.float64],
        f_hi: NDArray[np.float64],
        refl: NDArray[np.int64],
    ) -> tuple[NDArray[np.float64], ...]:
        """Crossing instants in the brackets ``[grid[interval], grid[interval + 1]]`` (``f_lo < 0 <= f_hi``).

        All crossings at once. Common path: chord iterations ``t <- t - f(t) / slope`` with the bracket's
        secant slope (:func:`~agvnav.sensors.beam.chord_brackets`, :func:`~agvnav.sensors.beam.chord_step`).
        The offset is dominated by the head term 2*pi*f*t, so the
        slope is right to ~1e-4 and two pose evaluations reach 1e-10 rad. If that
        fails (a reflector within centimetres of a fast-moving head), a bracketed
        Illinois iteration takes over. Returns the instants, the head position there
        ``x (c,), y (c,)`` and the head-to-centre distances (m).
        """
        lo, hi, slope, t, trx, try_, tr, h_max = chord_brackets(grid, interval, f_lo, f_hi, refl, m.rx, m.ry, m.r)
        tol = self._tolerance(float(h_max[0]))
        mx, my, phase, omega, direction = self._consts()
        for _ in range(_CHORD_ITER):
            done, t, hx, hy, d = chord_step(t, _call_pose(pose_at, t), trx, try_, tr, mx, my, phase, omega, direction,
                                            slope, lo, hi, tol)
            if done:  # every |wrap(offset)| <= tol (wrap: continuous on the bracket, see _BRACKETS_PER_REV)
                return t, hx, hy, d
        return self._illinois(pose_at, lo, hi, f_lo, f_hi, (trx, try_, tr), tol)

    def _tolerance(self, t_max: float) -> float:
        """Root tolerance (rad): 1e-10, or the float noise of instants up to ``|t| = t_max`` (s) if larger
        (t ~ 1 h: ~2e-11 rad)."""
        return max(_ANGLE_TOL, 8.0 * _EPS * t_max * TWO_PI * self.rate_hz)

    def _illinois(
        self,
        pose_at: PoseFunction,
        lo: NDArray[np.float64],
        hi: NDArray[np.float64],
        f_lo: NDArray[np.float64],
        f_hi: NDArray[np.float64],
        target: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
        tol: float,
    ) -> tuple[NDArray[np.float64], ...]:
        """Vectorised Illinois (modified regula falsi) on the brackets: slower, always converges."""
        side = np.zeros(lo.shape, dtype=np.int8)
        t = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        for _ in range(_MAX_ITER):
            raw, hx, hy, d = self._offsets(pose_at, t, target)
            f = wrap_angle(raw)
            if np.all(np.abs(f) <= tol):
                break
            upper = f >= 0.0
            hi, f_hi = np.where(upper, t, hi), np.where(upper, f, f_hi)
            lo, f_lo = np.where(upper, lo, t), np.where(upper, f_lo, f)
            f_lo = np.where(upper & (side == 1), 0.5 * f_lo, f_lo)  # halve the stale end
            f_hi = np.where(~upper & (side == -1), 0.5 * f_hi, f_hi)
            side = np.where(upper, 1, -1).astype(np.int8)
            t_new = np.clip(hi - f_hi * (hi - lo) / (f_hi - f_lo), lo, hi)
            if np.array_equal(t_new, t):
                break
            t = t_new
        else:
            _, hx, hy, d = self._offsets(pose_at, t, target)
        return t, hx, hy, d

    def _encoder_bearing_few(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """:meth:`encoder_bearing`, element by element in ``math`` for the few instants of one scan.

        Same operations in the same order as :meth:`head_angle` and :meth:`encoder_bearing`
        (bit-identical, tested); NumPy's per-call overhead dominated for a handful of values.
        """
        if t.size > 8:
            return self.encoder_bearing(t)
        n, res = self.pulses_per_rev, self.resolution
        u0, rate = self.phase / TWO_PI, self.direction * self.rate_hz
        out = []
        for ti in t.tolist():
            u = u0 + rate * ti
            count = math.floor(TWO_PI * (u - math.floor(u)) * (n / TWO_PI)) % n
            out.append(wrap_angle_scalar(count * res))
        return np.array(out, dtype=np.float64)

    # -- noise -------------------------------------------------------------

    def _add_noise(
        self,
        t_true: NDArray[np.float64],
        index: NDArray[np.int64],
        t0: float,
        t1: float,
        rng: np.random.Generator | None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
        """Missed detections, spurious reflections and timestamp jitter; quantised bearings.

        Returns the reported instants (s), bearings (rad) and true reflector rows, in time
        order. Random draws in a fixed order (misses, spurious count, spurious instants,
        jitter) so one seed reproduces the output bit for bit (a draw of no values, e.g. the
        instants of zero spurious reflections, leaves the generator as it was, so it is skipped).
        """
        shuffled = False
        if self.p_miss > 0.0 and t_true.size:
            keep = rng.random(t_true.size) >= self.p_miss  # type: ignore[union-attr]
            t_true, index = t_true[keep], index[keep]
        if self.spurious_rate > 0.0:
            n_spur = int(rng.poisson(self.spurious_rate * self.rate_hz * (t1 - t0)))  # type: ignore[union-attr]
            if n_spur:
                t_spur = t1 - (t1 - t0) * rng.random(n_spur)  # type: ignore[union-attr]  # in (t0, t1]
                t_true = np.concatenate([t_true, t_spur])
                index = np.concatenate([index, np.full(n_spur, -1, dtype=np.int64)])
                shuffled = True
        bearing = self._encoder_bearing_few(t_true)
        t_report = t_true
        if self.jitter_std > 0.0 and t_true.size:
            jitter = rng.normal(0.0, self.jitter_std, t_true.size)  # type: ignore[union-attr]
            t_report = np.clip(t_true + jitter, t0, t1)
            shuffled = True
        if not shuffled or t_report.size < 2:  # already in time order (the crossings come sorted)
            return t_report, bearing, index
        order = np.argsort(t_report, kind="stable")
        return t_report[order], bearing[order], index[order]


_NO_ROWS = np.zeros((0, 3))  # shared, as Reflections.empty() is: nothing in it to change


def _rows(t: NDArray[np.float64], bearing: NDArray[np.float64], index: NDArray[np.int64]) -> NDArray[np.float64]:
    """``(k, 3)`` rows ``(t, bearing, index)`` (np.column_stack, without its dispatch cost on a few rows)."""
    rows = np.empty((t.shape[0], 3))
    rows[:, 0], rows[:, 1], rows[:, 2] = t, bearing, index
    return rows


def _bracket_grid(t0: float, t1: float, n_int: int) -> NDArray[np.float64]:
    """``np.linspace(t0, t1, n_int + 1)`` built from Python floats (same values: ``i * step + t0``, end exact)."""
    if n_int == 1:
        return np.array([t0, t1])
    step = (t1 - t0) / n_int
    return np.array([i * step + t0 for i in range(n_int)] + [t1])


_NO_TWISTS = np.zeros((0, 3))


def _motion_table(pose_at: PoseFunction) -> tuple[int, NDArray[np.float64], NDArray[np.float64], float, float] | None:
    """The motion table :func:`~agvnav.sensors.beam.scan_motion` evaluates itself, when ``pose_at`` is one."""
    if isinstance(pose_at, HermitePoses):
        return HERMITE, pose_at.table, _NO_TWISTS, pose_at.t0, pose_at.dt
    if isinstance(pose_at, TwistPoses):
        return TWIST, pose_at.states, pose_at.twists, pose_at.t0, pose_at.h
    return None


def _call_pose(pose_at: PoseFunction, t: NDArray[np.float64]) -> NDArray[np.float64]:
    """``pose_at(t)`` as a finite ``(k, 3)`` array, else ValueError."""
    pose = np.asarray(pose_at(t), dtype=np.float64)
    if pose.shape != (t.size, 3):
        raise ValueError(f"pose_at(t) must return shape ({t.size}, 3), got {pose.shape}")
    if not np.isfinite(pose).all():  # the method: np.all's dispatch costs more on 3x3
        raise ValueError("pose_at(t) returned NaN or inf")
    return pose
