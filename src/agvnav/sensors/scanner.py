"""A planar safety laser scanner: exact ranges to wall segments and circles (issue 18).

The scanner sends beams at angles ``alpha_j = -fov/2 + j * step`` from its x axis
(``j = 0 .. n-1``); each beam reports the distance to the first surface it meets,
found exactly (no sampling of the geometry):

* segment ``a + u (b - a)``, ``0 <= u <= 1``, against the ray ``p + r d``, ``r >= 0``:
  ``r = ((a - p) x e) / (d x e)`` and ``u = ((a - p) x d) / (d x e)``, with ``e = b - a``
  and ``x`` the 2-D cross product (parallel rays, ``d x e = 0``, never hit);
* circle ``|q - c| = rho``: the smallest root ``r >= 0`` of
  ``r^2 + 2 r d.(p - c) + |p - c|^2 - rho^2 = 0`` (0 when the scanner is inside).

Both are vectorised over scans ``(k,)``, beams ``(n,)`` and surfaces, so one call
casts every beam of a window's scans. A hit beyond ``max_range`` (or none) reads
``inf``; a valid hit gets Gaussian range noise of ``noise_std`` from the caller's
generator (one draw per beam, in scan then beam order, whether it hit or not, so the
random stream does not depend on the geometry). Each scan is taken at one instant
(a real head sweeps in ~40 ms; at 1 m/s the body moves 4 cm meanwhile, which the
fields' margin absorbs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import compose

__all__ = ["SafetyScanner", "ScanResult", "cast_rays"]


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
    p = np.asarray(origins, dtype=np.float64).reshape(-1, 2)
    a = np.asarray(angles, dtype=np.float64)
    a = np.broadcast_to(a, (p.shape[0], a.shape[-1])) if a.ndim == 1 else a
    if a.shape[0] != p.shape[0]:
        raise ValueError(f"angles {a.shape} do not match origins {p.shape}")
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    circ = np.zeros((0, 3)) if circles is None else np.asarray(circles, dtype=np.float64).reshape(-1, 3)
    dx, dy = np.cos(a), np.sin(a)  # (k, n)
    k, n = a.shape
    best = np.full((k, n), np.inf)
    hit = np.full((k, n), -1, dtype=np.int64)
    if seg.shape[0]:
        ax, ay = seg[:, 0, 0], seg[:, 0, 1]
        ex, ey = seg[:, 1, 0] - ax, seg[:, 1, 1] - ay  # (M,)
        wx = ax[None, :] - p[:, 0:1]  # (k, M): a - p
        wy = ay[None, :] - p[:, 1:2]
        denom = dx[:, :, None] * ey - dy[:, :, None] * ex  # (k, n, M): d x e
        safe = np.where(denom != 0.0, denom, 1.0)
        r = (wx[:, None, :] * ey - wy[:, None, :] * ex) / safe  # (a - p) x e / (d x e)
        u = (wx[:, None, :] * dy[:, :, None] - wy[:, None, :] * dx[:, :, None]) / safe  # (a - p) x d / (d x e)
        ok = (denom != 0.0) & (r >= 0.0) & (u >= 0.0) & (u <= 1.0)
        r = np.where(ok, r, np.inf)
        j = np.argmin(r, axis=-1)
        rmin = np.take_along_axis(r, j[..., None], axis=-1)[..., 0]
        better = rmin < best
        best = np.where(better, rmin, best)
        hit = np.where(better, j, hit)
    if circ.shape[0]:
        fx = p[:, 0:1] - circ[None, :, 0]  # (k, C): p - c
        fy = p[:, 1:2] - circ[None, :, 1]
        c0 = fx * fx + fy * fy - circ[None, :, 2] ** 2  # (k, C)
        b = dx[:, :, None] * fx[:, None, :] + dy[:, :, None] * fy[:, None, :]  # (k, n, C): d.(p - c)
        disc = b * b - c0[:, None, :]
        sq = np.sqrt(np.maximum(disc, 0.0))
        near, far = -b - sq, -b + sq
        r = np.where(near >= 0.0, near, np.where(far >= 0.0, 0.0, np.inf))  # inside: 0; behind: no hit
        r = np.where(disc >= 0.0, r, np.inf)
        j = np.argmin(r, axis=-1)
        rmin = np.take_along_axis(r, j[..., None], axis=-1)[..., 0]
        better = rmin < best
        best = np.where(better, rmin, best)
        hit = np.where(better, seg.shape[0] + j, hit)
    far_away = best > max_range
    return np.where(far_away, np.inf, best), np.where(far_away, -1, hit)


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

    @property
    def angles(self) -> NDArray[np.float64]:
        """Beam angles ``(n,)`` in the scanner frame (rad), from ``-fov/2``."""
        full = self.fov >= 2.0 * math.pi - 1e-12
        n = math.floor(self.fov / self.step + 1e-9) + (0 if full else 1)
        return np.asarray(-0.5 * self.fov + self.step * np.arange(n), dtype=np.float64)

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
        pose = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        head = compose(pose, np.asarray(self.mount, dtype=np.float64))
        beams = self.angles
        ranges, hit = cast_rays(head[:, :2], head[:, 2:3] + beams[None, :], segments, circles, self.max_range)
        noise = rng.standard_normal(ranges.shape) * self.noise_std
        echo = np.isfinite(ranges)
        ranges = np.where(echo, np.maximum(ranges + noise, 0.0), np.inf)
        ranges = np.where(ranges > self.max_range, np.inf, ranges)
        hit = np.where(np.isfinite(ranges), hit, -1)
        mx, my, mth = self.mount
        ang = mth + beams[None, :]
        rr = np.where(np.isfinite(ranges), ranges, np.nan)
        points = np.stack([mx + rr * np.cos(ang), my + rr * np.sin(ang)], axis=-1)
        return ranges, hit, points
