"""Clothoids (Euler spirals) evaluated exactly, and arc chains that let any follower track a curve.

A clothoid's curvature varies linearly with arclength,
``kappa(s) = kappa0 + c s`` (``c``: sharpness, 1/m^2), so its heading is
``theta(s) = theta0 + kappa0 s + c s^2 / 2``. Route layouts use it between a
line and an arc so that the steering angle need not jump at the joint
[seed003 §3.4]. Its points are Fresnel integrals: completing the square,
``theta = phi + sign(c) (pi/2) t^2`` with ``t = (s + kappa0/c) sqrt(|c|/pi)`` and
``phi = theta0 - kappa0^2 / (2c)``, hence

``x(s) = x0 + sqrt(pi/|c|) [cos(phi) dC - sign(c) sin(phi) dS]``,
``y(s) = y0 + sqrt(pi/|c|) [sin(phi) dC + sign(c) cos(phi) dS]``,

``dC = C(t) - C(t0)``, ``dS = S(t) - S(t0)`` (``scipy.special.fresnel``), exact
to the Fresnel routines' precision. For a nearly circular spiral the arguments
grow without bound (``kappa0 / sqrt(pi |c|)``) and the phase loses digits; beyond
``|t| = 20`` the same integral is evaluated by composite Gauss-Legendre
quadrature instead (also to about 1e-12 m).

The path followers of :mod:`agvnav.guidance` project onto lines and arcs;
:func:`arc_chain` turns any sampled curve into an exactly G1 chain of short
arcs with the curve's mean curvature between samples, and states its measured
deviation from the samples (:attr:`ArcChain.max_error_m`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import fresnel

from agvnav.geometry.angles import wrap_angle
from agvnav.guidance.paths import ArcSegment, LineSegment, Segment

__all__ = ["ArcChain", "Clothoid", "arc_chain"]

#: Fresnel arguments beyond this lose precision (phase ``pi t^2 / 2`` too large): Gauss-Legendre is used.
_FRESNEL_T_MAX = 20.0

#: Gauss-Legendre nodes and weights on [-1, 1] for the ill-conditioned (nearly circular) case.
_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)


@dataclass(frozen=True)
class Clothoid:
    """An Euler spiral from ``(x0, y0)`` with heading ``theta0`` (rad) and curvature ``kappa0`` (1/m).

    ``sharpness`` c (1/m^2): curvature change per metre; ``length`` (m, > 0).
    """

    x0: float
    y0: float
    theta0: float
    kappa0: float
    sharpness: float
    length: float

    def __post_init__(self) -> None:
        for name in ("x0", "y0", "theta0", "kappa0", "sharpness", "length"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"clothoid {name} must be finite, got {getattr(self, name)!r}")
        if self.length <= 0.0:
            raise ValueError(f"clothoid length must be positive (m), got {self.length!r}")

    @classmethod
    def from_curvatures(
        cls, x0: float, y0: float, theta0: float, kappa0: float, kappa1: float, length: float
    ) -> Clothoid:
        """The clothoid whose curvature goes from ``kappa0`` to ``kappa1`` (1/m) over ``length`` (m)."""
        if not (math.isfinite(length) and length > 0.0):
            raise ValueError(f"clothoid length must be positive (m), got {length!r}")
        return cls(x0, y0, theta0, kappa0, (kappa1 - kappa0) / length, length)

    @property
    def kappa1(self) -> float:
        """Curvature at the end (1/m)."""
        return self.kappa0 + self.sharpness * self.length

    def curvature_at(self, s: ArrayLike) -> NDArray[np.float64]:
        """Curvature (1/m) at arclength ``s`` (m, clipped to [0, length])."""
        u = np.clip(np.asarray(s, dtype=np.float64), 0.0, self.length)
        return np.asarray(self.kappa0 + self.sharpness * u)

    def heading_at(self, s: ArrayLike) -> NDArray[np.float64]:
        """Tangent heading (rad, wrapped) at arclength ``s`` (m): ``theta0 + kappa0 s + c s^2/2``."""
        u = np.clip(np.asarray(s, dtype=np.float64), 0.0, self.length)
        return np.asarray(wrap_angle(self.theta0 + self.kappa0 * u + 0.5 * self.sharpness * u * u))

    def point_at(self, s: ArrayLike) -> NDArray[np.float64]:
        """Point (..., 2) (m) at arclength ``s`` (m, clipped), from the Fresnel integrals (module doc)."""
        u = np.clip(np.asarray(s, dtype=np.float64), 0.0, self.length)
        c = self.sharpness
        scale = math.sqrt(abs(c) / math.pi)
        if abs(c) < 1e-12 or max(abs(self.kappa0), abs(self.kappa1)) / (math.pi * scale) > _FRESNEL_T_MAX:
            return self._quadrature_point(u)
        sg = 1.0 if c > 0 else -1.0
        phi = self.theta0 - self.kappa0**2 / (2.0 * c)
        t0 = (self.kappa0 / c) * scale
        t = (u + self.kappa0 / c) * scale
        s_t, c_t = fresnel(t)
        s_0, c_0 = fresnel(t0)
        d_c, d_s = c_t - c_0, s_t - s_0
        k = 1.0 / scale
        x = self.x0 + k * (math.cos(phi) * d_c - sg * math.sin(phi) * d_s)
        y = self.y0 + k * (math.sin(phi) * d_c + sg * math.cos(phi) * d_s)
        return np.stack([x, y], axis=-1)

    def _quadrature_point(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        """Nearly circular clothoids (large Fresnel arguments): composite Gauss-Legendre of (cos, sin) theta.

        Pieces of at most 0.25 rad of turn each; 24 nodes per piece integrate the
        smooth integrand to machine precision.
        """
        turn = abs(self.kappa0) * self.length + 0.5 * abs(self.sharpness) * self.length**2
        m = max(1, math.ceil(turn / 0.25))
        edges = np.linspace(0.0, 1.0, m + 1)
        frac = (0.5 * (_GL_X + 1.0))[None, :] * np.diff(edges)[:, None] + edges[:-1, None]  # (m, 24) in [0, 1]
        w = (0.5 * _GL_W)[None, :] * np.diff(edges)[:, None]
        uu = u[..., None, None] * frac  # (..., m, 24)
        th = self.theta0 + self.kappa0 * uu + 0.5 * self.sharpness * uu * uu
        x = self.x0 + u * np.sum(w * np.cos(th), axis=(-2, -1))
        y = self.y0 + u * np.sum(w * np.sin(th), axis=(-2, -1))
        return np.stack([x, y], axis=-1)

    def sample(self, step: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Points (k, 2) and tangent headings (k,) at most ``step`` m apart, both ends included."""
        s = np.linspace(0.0, self.length, max(2, math.ceil(self.length / step) + 1))
        return self.point_at(s), self.heading_at(s)


@dataclass(frozen=True)
class ArcChain:
    """Line and arc segments that follow a sampled curve, and their largest measured deviation (m)."""

    segments: tuple[Segment, ...]
    max_error_m: float


def arc_chain(
    points: ArrayLike,
    headings: ArrayLike,
    direction: int = 1,
    start: ArrayLike | None = None,
    start_heading: float | None = None,
) -> ArcChain:
    """Chain of arcs following a sampled curve: exact heading changes between samples, G1 everywhere.

    Piece ``i`` turns by the sampled heading change ``dtheta`` over the arclength
    ``l = chord (dtheta/2) / sin(dtheta/2)`` of the circle through both samples
    tangent at the first (a line when ``dtheta`` is negligible): its curvature is
    the mean curvature of the curve between the samples. Each piece starts where
    and with the heading the previous one ended, so the chain is exactly G1; its
    position drifts slowly from the curve (for a clothoid of sharpness ``c`` and
    length ``L`` cut every ``h`` m, by about ``|c| L h^2 / 12``). ``max_error_m``
    is the largest measured distance between a chain joint and its sample.

    Parameters
    ----------
    points : (k, 2) samples of the curve (m), k >= 2, in the direction of increasing ``s``.
    headings : (k,) tangent headings at the samples (rad).
    direction : +1 driven forward, -1 in reverse (the segments' ``direction``).
    start : (2,) start of the chain (m; default the first sample), so chains join without gaps.
    start_heading : heading (rad) the chain starts with (default the first sample's).
    """
    p = np.asarray(points, dtype=np.float64)
    h = np.asarray(headings, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 2 or h.shape != (p.shape[0],):
        raise ValueError(f"points must be (k, 2) with k >= 2 and headings (k,), got {p.shape} and {h.shape}")
    pos = p[0].copy() if start is None else np.asarray(start, dtype=np.float64).copy()
    heading = float(h[0]) if start_heading is None else float(start_heading)
    segs: list[Segment] = []
    err = float(np.hypot(*(pos - p[0])))
    for i in range(p.shape[0] - 1):
        chord = float(np.hypot(*(p[i + 1] - p[i])))
        seg = _piece(pos, heading, chord, float(wrap_angle(h[i + 1] - h[i])), direction)
        if seg is None:
            continue
        segs.append(seg)
        pos, heading = np.asarray(seg.end, dtype=np.float64), float(seg.end_heading)
        err = max(err, float(np.hypot(*(pos - p[i + 1]))))
    if not segs:
        raise ValueError("the sampled curve has no length")
    return ArcChain(tuple(segs), err)


def _piece(pos: NDArray[np.float64], heading: float, chord: float, dtheta: float, direction: int) -> Segment | None:
    """One arc (or line) of :func:`arc_chain`; None for a vanishing piece."""
    if chord < 1e-9:
        return None
    if abs(dtheta) < 1e-9:
        return LineSegment(pos, heading, chord, direction)
    length = chord * (0.5 * dtheta) / math.sin(0.5 * dtheta)
    return ArcSegment(pos, heading, length / abs(dtheta), dtheta, direction)
