"""A planar safety laser scanner: exact ranges to wall segments and circles (issue 18).

The scanner sends beams at angles ``alpha_j = -fov/2 + j * step`` from its x axis
(``j = 0 .. n-1``); each beam reports the distance to the first surface it meets,
found exactly (no sampling of the geometry):

* segment ``a + u (b - a)``, ``0 <= u <= 1``, against the ray ``p + r d``, ``r >= 0``:
  ``r = ((a - p) x e) / (d x e)`` and ``u = ((a - p) x d) / (d x e)``, with ``e = b - a``
  and ``x`` the 2-D cross product (parallel rays, ``d x e = 0``, never hit);
* circle ``|q - c| = rho``: the smallest root ``r >= 0`` of
  ``r^2 + 2 r d.(p - c) + |p - c|^2 - rho^2 = 0`` (0 when the scanner is inside).

One compiled call (:func:`ray_ranges`) casts every beam of a window's scans against every
surface within the scanner's reach (a broad phase per scan passes over the farther ones).
A hit beyond ``max_range`` (or none) reads
``inf``; a valid hit gets Gaussian range noise of ``noise_std`` from the caller's
generator (one draw per beam, in scan then beam order, whether it hit or not, so the
random stream does not depend on the geometry). Each scan is taken at one instant
(a real head sweeps in ~40 ms; at 1 m/s the body moves 4 cm meanwhile, which the
fields' margin absorbs).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._jit import jit
from agvnav.geometry.angles import wrap_angle_kernel

__all__ = ["SafetyScanner", "ScanResult", "cast_rays", "ray_ranges", "scan_poses"]


def cast_rays(
    origins: ArrayLike,
    angles: ArrayLike,
    segments: ArrayLike,
    circles: ArrayLike | None = None,
    max_range: float = math.inf,
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Exact range of every ray to the nearest segment or circle (see the module docstring).

    Parameters
    ----------
    origins : ``(k, 2)`` ray origins (m).
    angles : ``(k, n)`` or ``(n,)`` ray directions in the map frame (rad).
    segments : ``(M, 2, 2)`` segments (m); may be empty.
    circles : ``(C, 3)`` circles ``(x, y, radius)`` (m); None or empty: none.
    max_range : hits farther than this (m) are not reported.

    Returns
    -------
    ranges : ``(k, n)`` distance to the first hit (m), ``inf`` where none within ``max_range``.
    hit : ``(k, n)`` index of the surface hit: ``0 .. M-1`` a segment, ``M .. M+C-1`` a circle, -1 none.
    """
    p = np.ascontiguousarray(origins, dtype=np.float64).reshape(-1, 2)
    a = np.asarray(angles, dtype=np.float64)
    a = np.broadcast_to(a, (p.shape[0], a.shape[-1])) if a.ndim == 1 else a
    if a.shape[0] != p.shape[0]:
        raise ValueError(f"angles {a.shape} do not match origins {p.shape}")
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    circ = np.zeros((0, 3)) if circles is None else np.ascontiguousarray(circles, dtype=np.float64).reshape(-1, 3)
    edges = np.ascontiguousarray(np.concatenate([seg[:, 0, :], seg[:, 1, :] - seg[:, 0, :]], axis=1))
    ranges, hit = ray_ranges(p, np.ascontiguousarray(a), edges, circ, float(max_range))
    return np.asarray(ranges, dtype=np.float64), np.asarray(hit, dtype=np.int64)


@jit
def ray_ranges(origins: NDArray[np.float64], angles: NDArray[np.float64], edges: NDArray[np.float64],
               circles: NDArray[np.float64], max_range: float) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """:func:`cast_rays`' kernel: rays from ``origins (k, 2)`` at ``angles (k, n)`` (rad) against segments
    ``edges (M, 4)`` = ``a_x, a_y, e_x, e_y`` (start and ``b - a``, m) and ``circles (C, 3)`` (m).

    Broad phase per origin: a segment or circle farther than ``max_range`` (m) from it cannot give a
    reported echo and is passed over. Each ray then takes the nearest hit of the module docstring's
    equations, the first surface in index order on a tie (segments before circles).
    """
    k, n = angles.shape
    m, c = edges.shape[0], circles.shape[0]
    ranges = np.full((k, n), np.inf)
    hit = np.full((k, n), -1, dtype=np.int64)
    near_seg = np.empty(m, dtype=np.int64)
    near_circ = np.empty(c, dtype=np.int64)
    for i in range(k):
        px, py = origins[i, 0], origins[i, 1]
        ns = 0
        for q in range(m):
            wx, wy, ex, ey = edges[q, 0] - px, edges[q, 1] - py, edges[q, 2], edges[q, 3]
            ee = ex * ex + ey * ey
            u = 0.0 if ee == 0.0 else min(max(-(wx * ex + wy * ey) / ee, 0.0), 1.0)
            dx, dy = wx + u * ex, wy + u * ey
            if math.sqrt(dx * dx + dy * dy) <= max_range:
                near_seg[ns] = q
                ns += 1
        nc = 0
        for q in range(c):
            if math.hypot(circles[q, 0] - px, circles[q, 1] - py) - circles[q, 2] <= max_range:
                near_circ[nc] = q
                nc += 1
        for j in range(n):
            dx, dy = math.cos(angles[i, j]), math.sin(angles[i, j])
            best, found = np.inf, -1
            for qq in range(ns):
                q = near_seg[qq]
                wx, wy, ex, ey = edges[q, 0] - px, edges[q, 1] - py, edges[q, 2], edges[q, 3]
                denom = dx * ey - dy * ex  # d x e
                if denom == 0.0:
                    continue
                r = (wx * ey - wy * ex) / denom  # (a - p) x e / (d x e)
                u = (wx * dy - wy * dx) / denom  # (a - p) x d / (d x e)
                if r >= 0.0 and u >= 0.0 and u <= 1.0 and r < best:
                    best, found = r, q
            for qq in range(nc):
                q = near_circ[qq]
                fx, fy = px - circles[q, 0], py - circles[q, 1]  # p - c
                c0 = fx * fx + fy * fy - circles[q, 2] ** 2
                b = dx * fx + dy * fy  # d.(p - c)
                disc = b * b - c0
                if disc < 0.0:
                    continue
                sq = math.sqrt(disc)
                r = -b - sq if -b - sq >= 0.0 else (0.0 if -b + sq >= 0.0 else np.inf)  # inside: 0; behind: none
                if r < best:
                    best, found = r, m + q
            if best <= max_range:
                ranges[i, j], hit[i, j] = best, found
    return ranges, hit


@dataclass(frozen=True)
class ScanResult:
    """Scans taken at instants ``t (k,)``: ranges, surfaces hit, and the hit points in base_link.

    ``ranges (k, n)`` (m, ``inf`` no echo), ``hit (k, n)`` (surface index as :func:`cast_rays`,
    -1 none; truth, for the metrics only), ``points (k, n, 2)`` the echoes in base_link (m;
    NaN for no echo).
    """

    t: NDArray[np.float64]
    ranges: NDArray[np.float64]
    hit: NDArray[np.int64]
    points: NDArray[np.float64]


#: CPU (s) one ray against one surface costs when :func:`ray_ranges` runs as plain Python (measured: 0.8 us;
#: compiled, a few ns), for the choice of the kernels' mode of a run (:func:`agvnav.jit.set_compiled_for_run`).
INTERPRETED_S_PER_RAY_SURFACE = 8e-7


@dataclass(frozen=True)
class SafetyScanner:
    """A planar range scanner on the vehicle (see the module docstring).

    Parameters
    ----------
    mount : ``(x, y, theta)`` of the scanner in base_link (m, m, rad).
    fov : field of view (rad), centred on the scanner's x axis, ``0 < fov <= 2 pi``.
    step : angle between beams (rad).
    max_range : farthest echo (m).
    noise_std : range noise standard deviation (m).
    rate_hz : scans per second; scans fall at ``t = (i + phase) / rate_hz``.
    phase : fraction of a period of the first scan.
    """

    mount: tuple[float, float, float] = (0.0, 0.0, 0.0)
    fov: float = math.radians(270.0)
    step: float = math.radians(0.5)
    max_range: float = 10.0
    noise_std: float = 0.01
    rate_hz: float = 25.0
    phase: float = 0.0

    def __post_init__(self) -> None:
        if len(self.mount) != 3 or not all(math.isfinite(v) for v in self.mount):
            raise ValueError(f"mount must be three finite numbers (m, m, rad), got {self.mount!r}")
        if not (0.0 < self.fov <= 2.0 * math.pi + 1e-12):
            raise ValueError(f"fov must be in (0, 2 pi] rad, got {self.fov!r}")
        for name in ("step", "max_range", "rate_hz"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be a positive finite number, got {value!r}")
        if not (math.isfinite(self.noise_std) and self.noise_std >= 0.0):
            raise ValueError(f"noise_std must be >= 0 and finite, got {self.noise_std!r}")
        if not (0.0 <= self.phase < 1.0):
            raise ValueError(f"phase must be in [0, 1), got {self.phase!r}")

    @functools.cached_property
    def angles(self) -> NDArray[np.float64]:
        """Beam angles ``(n,)`` in the scanner frame (rad), from ``-fov/2`` (computed once)."""
        full = self.fov >= 2.0 * math.pi - 1e-12
        n = math.floor(self.fov / self.step + 1e-9) + (0 if full else 1)
        return np.asarray(-0.5 * self.fov + self.step * np.arange(n), dtype=np.float64)

    def interpreted_cost_s(self, sim_seconds: float, surfaces: int) -> float:
        """Extra CPU (s) its rays against ``surfaces`` cost over ``sim_seconds`` (s) run as plain Python rather
        than compiled (:data:`INTERPRETED_S_PER_RAY_SURFACE`)."""
        return sim_seconds * self.rate_hz * self.angles.size * max(surfaces, 1) * INTERPRETED_S_PER_RAY_SURFACE

    def scan_times(self, t0: float, t1: float) -> NDArray[np.float64]:
        """Scan instants in the half-open window ``(t0, t1]`` (s)."""
        i0 = math.floor(t0 * self.rate_hz - self.phase + 1e-9) + 1
        i1 = math.floor(t1 * self.rate_hz - self.phase + 1e-9)
        return (np.arange(i0, i1 + 1, dtype=np.float64) + self.phase) / self.rate_hz

    def measure(
        self,
        poses: ArrayLike,
        segments: ArrayLike,
        circles: ArrayLike | None,
        rng: np.random.Generator,
    ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
        """Noisy ranges from base_link poses ``(k, 3)`` against ``segments``/``circles`` (one set for all).

        Returns ``ranges (k, n)`` (m, ``inf`` no echo), ``hit (k, n)`` and ``points (k, n, 2)``
        (echoes in base_link, NaN for no echo).
        """
        pose = np.ascontiguousarray(poses, dtype=np.float64).reshape(-1, 3)
        beams = self.angles
        seg = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
        circ = np.zeros((0, 3)) if circles is None else np.ascontiguousarray(circles, dtype=np.float64).reshape(-1, 3)
        edges = np.ascontiguousarray(np.concatenate([seg[:, 0, :], seg[:, 1, :] - seg[:, 0, :]], axis=1))
        noise = rng.standard_normal((pose.shape[0], beams.size)) * self.noise_std
        ranges, hit, points = scan_poses(pose, *self.mount, beams, edges, circ, float(self.max_range), noise)
        return np.asarray(ranges), np.asarray(hit), np.asarray(points)


@jit
def scan_poses(poses: NDArray[np.float64], mx: float, my: float, mth: float, beams: NDArray[np.float64],
               edges: NDArray[np.float64], circles: NDArray[np.float64], max_range: float,
               noise: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """:meth:`SafetyScanner.measure`'s kernel: scans from base_link ``poses (k, 3)`` with the scanner mounted at
    ``(mx, my, mth)`` (m, rad), beams ``(n,)`` (rad, scanner frame), surfaces as :func:`ray_ranges`, the range
    noise ``(k, n)`` (m) drawn by the caller. A hit's range plus its noise (floored at 0) beyond ``max_range``
    is no echo. Returns ``ranges (k, n)`` (m, ``inf`` no echo), ``hit (k, n)`` and the echoes in base_link
    ``points (k, n, 2)`` (m, NaN for no echo)."""
    k, n = poses.shape[0], beams.shape[0]
    origins = np.empty((k, 2))
    angles = np.empty((k, n))
    for i in range(k):
        c, s = math.cos(poses[i, 2]), math.sin(poses[i, 2])
        origins[i, 0] = poses[i, 0] + c * mx - s * my
        origins[i, 1] = poses[i, 1] + s * mx + c * my
        head = wrap_angle_kernel(poses[i, 2] + mth)
        for j in range(n):
            angles[i, j] = head + beams[j]
    ranges, hit = ray_ranges(origins, angles, edges, circles, max_range)
    points = np.full((k, n, 2), np.nan)
    for i in range(k):
        for j in range(n):
            if ranges[i, j] == np.inf:
                continue
            r = max(ranges[i, j] + noise[i, j], 0.0)
            if r > max_range:
                ranges[i, j], hit[i, j] = np.inf, -1
                continue
            ranges[i, j] = r
            points[i, j, 0] = mx + r * math.cos(mth + beams[j])
            points[i, j, 1] = my + r * math.sin(mth + beams[j])
    return ranges, hit, points
