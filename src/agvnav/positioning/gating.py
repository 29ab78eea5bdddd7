"""Which reflectors can a bearing come from? A vectorised pre-selection for large maps.

The streaming estimators identify each anonymous reflection with a chi-square gate on
its bearing innovation (:func:`agvnav.positioning._fast.gate_one`, mirroring
:func:`~agvnav.positioning.bearing_gate.gate_reflection`). Evaluated reflector by
reflector in Python, that gate costs about 2 us per reflector and per reflection, and
the reflections per second grow with the number of reflectors too: the cost of a run
grows as N^2 (issue 11: 46x real time at N = 64, 5x at N = 256).

:class:`BearingIndex` finds the few reflectors whose predicted leading-edge bearing lies
close enough to the measured one to possibly pass the gate -- within a bound on
``sqrt(gate S)`` of the reflector's predicted edge, i.e. a few sigma plus the reflector's
angular radius ``asin(r / d)`` (the test of :func:`near_rows`, one compiled pass over the
map). Only those go through the exact scalar gate, so the accepted association is the one
the full loop gives (a test compares both on random maps).

Sub-linear in the map (issue 11: ``near_rows`` at N = 256 costs ~7 us per reflection on the
2-core development machine, ~70 reflections per step; :func:`grid_rows` ~3.2 us on the same
queries of bench speed's ``reflectors_256``): :func:`grid_rows` applies the same per-reflector test
(:func:`near_one`) only to the reflectors of the cells of a uniform grid that a strip along
the beam covers, and returns exactly the rows :func:`near_rows` returns (tested). The strip:
a reflector that passes at distance ``d > D`` from the head, ``D >= 2 r_max``, has
``|w| < window(d) <= sqrt(a4) + (k sqrt(b4) + (pi / 2) r_max) / d`` with ``k = 2 / sqrt(3)``
(``d / sqrt(d^2 - r^2) <= k``); with ``D = max(2 r_max, 2 (k sqrt(b4) + (pi / 2) r_max))``
that is below ``sqrt(a4) + 1/2``, so while ``sqrt(a4) < 1`` the angle stays below ``pi / 2``
and the reflector lies ahead of the head, ``0 <= a = d cos w <= L`` along the beam (``L`` the
range, or the farthest corner of the map), and beside it ``|d sin w| <= d window(d) <=
L sqrt(a4) + k sqrt(b4) + (pi / 2) r_max = W``. Every reflector that passes therefore lies in
the disc ``d <= D`` or in the strip ``[0, L] x [-W, W]`` along the beam; the grid covers the
disc with one square and the strip with squares of half-side ``W + c / 2`` centred every
``c`` along the beam (``c`` the cell side), both widened by a relative 1e-9. The strip is
narrower near the head: with ``d <= a + |lat|``, ``|lat| < d sqrt(a4) + K`` (``K = k sqrt(b4) +
(pi / 2) r_max``) gives ``|lat| < (a sqrt(a4) + K) / (1 - sqrt(a4))``, so the square at ``a_k``,
which covers the points with ``|a - a_k| <= c / 2``, takes the smaller of ``W`` and that bound
at ``a_k + c / 2`` (a wedge; issue 11: about half the cells of the strip on bench speed's
256-reflector lab). Wider gates
(``sqrt(a4) >= 1``, e.g. the first fixes) or strips that would cover the map take the
plain pass.

The bound: the innovation is ``y = wrap(c + asin(r / d))`` with ``c = wrap(z - atan2(R - P)
+ psi_P)`` the innovation of the reflector's centre, so ``|y| >= |c| - asin(r / d)`` and
``asin(r / d) <= (pi / 2) r / d``. For the edge bearing of a reflector of radius ``r`` at
distance ``d``, ``|dh/d(x, y)|^2 = g = 1 / (d^2 - r^2)`` and
``|dh/dpsi| <= sqrt(g) |mount| + 1``. Splitting ``H = a + b`` into its position and
heading parts, ``H P H^T <= 2 a P a^T + 2 b P b^T`` (``P`` positive semi-definite), so

    S = H P H^T + R <= 2 g tr(P_xy) + 2 (sqrt(g) |mount| + 1)^2 P_psipsi + sigma^2 + map_std^2 g
                    <= (sigma^2 + 4 P_psipsi) + g (map_std^2 + 2 tr(P_xy) + 4 |mount|^2 P_psipsi) = S_max

(``R = sigma^2 + (map_std / d)^2`` and ``(u + v)^2 <= 2 u^2 + 2 v^2``). A reflector is
dropped only when ``|c| >= 2 sqrt(gate S_max) + (pi / 2) r / d``: then ``y^2 >= 4 gate S``,
a factor 4 of margin over the exact test ``y^2 < gate S``, far above any difference
between the last bits of NumPy's and the ``math`` module's functions. A head inside a
reflector (``d <= r``) always stays a candidate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._jit import jit
from agvnav.geometry.angles import wrap_angle_kernel

__all__ = ["INDEX_MIN_REFLECTORS", "BearingIndex", "GateSpec", "grid_rows", "near_one", "near_rows"]


#: Maps with at least this many reflectors use :class:`BearingIndex`; below it the plain
#: loop over every reflector (about 1.1 us per reflector) is cheaper than the ~25 NumPy
#: calls of the vectorised pass it once was (about 17 us, nearly flat in N): measured
#: crossover on the 2-core development machine, 16 reflectors. The pass is now one compiled
#: loop (:func:`near_rows`), cheaper still, but a process that runs its kernels interpreted
#: (:mod:`agvnav._jit`: short runs on small maps) would pay ~1 us per reflector in it.
INDEX_MIN_REFLECTORS = 16


@dataclass(frozen=True)
class GateSpec:
    """The constants of the bearing gate of one estimator.

    Attributes
    ----------
    bearing_var:
        Variance (rad²) of one bearing (encoder quantisation and noise).
    max_range:
        Reflectors farther than this from the head (m) are never predicted visible.
    gate:
        Chi-square threshold (1 dof) on ``y^2 / S``.
    map_std:
        Survey error std (m) of a reflector position; adds ``(map_std / d)^2`` to ``R``.
    sweep:
        A reflector claimed less than ``sweep`` seconds ago cannot be claimed again (s).
    consider:
        The gate of the Schmidt-Kalman EKF (survey errors as consider parameters,
        :func:`agvnav.positioning._fast.schmidt_update`): ``S`` holds the cross term
        ``2 H P_xp H_p^T`` too, bounded by ``S <= sigma^2 + 2 (H P H^T + b) <= 2 S_max``
        (``|H P_xp H_p^T| <= sqrt(H P H^T b)``, ``b = (map_std / d)^2`` at most), so
        :meth:`BearingIndex.candidates` doubles its bound (the factor 4 of margin stays).
    """

    bearing_var: float
    max_range: float
    gate: float
    map_std: float
    sweep: float
    consider: bool = False


@dataclass(frozen=True, eq=False)
class _Grid:
    """A uniform grid over the reflector centres, cells in compressed rows (CSR).

    Cell ``(ix, iy)`` (``ix = floor((x - x0) / cell)`` clipped to ``[0, nx)``, likewise ``iy``) is
    ``iy * nx + ix``; its reflector rows, ascending, are ``rows[start[k]:start[k + 1]]``.
    """

    start: NDArray[np.int64]
    rows: NDArray[np.int64]
    x0: float
    y0: float
    cell: float
    nx: int
    ny: int

    @classmethod
    def of(cls, rx: NDArray[np.float64], ry: NDArray[np.float64]) -> _Grid:
        """About one reflector per cell of a map spread over an area: cell side ``sqrt(area / N)``.

        The fastest of 0.5-3 times that side on bench speed's 256-reflector lab (3.2 us per query).
        """
        n = rx.shape[0]
        if n == 0:
            return cls(np.zeros(2, np.int64), np.zeros(0, np.int64), 0.0, 0.0, 1.0, 1, 1)
        x0, y0 = float(rx.min()), float(ry.min())
        ex, ey = float(rx.max()) - x0, float(ry.max()) - y0
        floor = max(ex, ey, 1e-6) / max(n, 1)
        cell = max(math.sqrt(max(ex, floor) * max(ey, floor) / n), max(ex, ey) / 64.0, 1e-6)
        nx, ny = int(ex / cell) + 1, int(ey / cell) + 1
        ix = np.clip(np.floor((rx - x0) / cell).astype(np.int64), 0, nx - 1)
        iy = np.clip(np.floor((ry - y0) / cell).astype(np.int64), 0, ny - 1)
        key = iy * nx + ix
        rows = np.argsort(key, kind="stable").astype(np.int64)  # by cell, rows ascending inside a cell
        start = np.searchsorted(key[rows], np.arange(nx * ny + 1)).astype(np.int64)
        return cls(start, rows, x0, y0, cell, nx, ny)


class BearingIndex:
    """Pre-selection of the reflectors that may lie inside one bearing's gate (a grid, :func:`grid_rows`).

    Parameters
    ----------
    reflector_xy, radius:
        ``(N, 2)`` reflector centres (m) in ``map`` and ``(N,)`` radii (m).
    mount:
        ``(3,)`` head pose in base_link (m, m, rad).
    spec:
        The gate constants (:class:`GateSpec`).
    """

    def __init__(self, reflector_xy: ArrayLike, radius: ArrayLike, mount: ArrayLike, spec: GateSpec) -> None:
        xy = np.asarray(reflector_xy, dtype=np.float64).reshape(-1, 2)
        self._rx = np.ascontiguousarray(xy[:, 0])
        self._ry = np.ascontiguousarray(xy[:, 1])
        self._r = np.asarray(radius, dtype=np.float64).reshape(-1)
        if self._r.shape != self._rx.shape:
            raise ValueError(f"radius must have shape ({xy.shape[0]},), got {self._r.shape}")
        self._r2 = self._r * self._r
        self._half_pi_r = 0.5 * math.pi * self._r
        mx, my, mth = (float(v) for v in np.asarray(mount, dtype=np.float64).reshape(3))
        self._mount = (mx, my, mth)
        self._mount_norm = math.hypot(mx, my)
        self._spec = spec
        self._grid = _Grid.of(self._rx, self._ry)
        self._r_max = float(self._r.max()) if self._r.size else 0.0

    def grid_constants(self) -> tuple[float, float, float, int, int, float]:
        """``(x0, y0, cell, nx, ny, r_max)`` of the grid (m, m, m, -, -, m).

        For :func:`~agvnav.positioning._fast.gate_constants`.
        """
        g = self._grid
        return g.x0, g.y0, g.cell, g.nx, g.ny, self._r_max

    def grid_cells(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """``(start, rows)``: the grid's cells in compressed rows (:class:`_Grid`), for the compiled gate."""
        return self._grid.start, self._grid.rows

    def candidates(self, z: float, pose: tuple[float, ...], P: tuple[float, ...]) -> list[int]:
        """Rows (ascending) of the reflectors in range that the gate of bearing ``z`` may admit.

        ``z`` is the head-frame bearing (rad), ``pose`` the base_link pose ``(x, y, psi)``
        (m, m, rad) and ``P`` its covariance, flat row-major (9,). A superset of the
        reflectors with ``y^2 / S < gate`` (see the module docstring for the bound).
        """
        spec = self._spec
        x, y, psi = pose
        mx, my, mth = self._mount
        c, s = math.cos(psi), math.sin(psi)
        var_xy, var_psi = P[0] + P[4], P[8]
        a4 = 4.0 * spec.gate * (spec.bearing_var + 4.0 * var_psi)  # 4 gate S_max = a4 + b4 g
        b4 = 4.0 * spec.gate * (spec.map_std**2 + 2.0 * var_xy + 4.0 * self._mount_norm**2 * var_psi)
        if spec.consider:  # the consider gate's S is bounded by 2 S_max (GateSpec)
            a4, b4 = 2.0 * a4, 2.0 * b4
        g = self._grid
        rows = grid_rows(
            g.start, g.rows, g.x0, g.y0, g.cell, g.nx, g.ny,
            self._rx, self._ry, self._r2, self._half_pi_r, x + c * mx - s * my, y + s * mx + c * my,
            z + psi + mth, a4, b4, spec.max_range, self._r_max,
        )
        return rows.tolist()


@jit
def near_one(
    j: int, rx: NDArray[np.float64], ry: NDArray[np.float64], r2: NDArray[np.float64],
    half_pi_r: NDArray[np.float64], hx: float, hy: float, beam: float, a4: float, b4: float, max_range: float,
    ux: float, uy: float,
) -> bool:
    """Whether reflector ``j`` is within ``max_range`` (m) of the head ``(hx, hy)`` (m) and its centre
    within the gate bound of the absolute bearing ``beam`` (rad; see the module docstring).

    ``r2`` the squared radii (m^2), ``half_pi_r`` ``(pi / 2) r`` (m), ``4 gate S_max = a4 + b4 g``
    with ``g = 1 / (d^2 - r^2)``, ``(ux, uy) = (cos beam, sin beam)``. A head inside a reflector
    (``d^2 <= r^2``) keeps it. The angle test ``|w| < window`` (``w`` the centre's angle off the
    beam) is first tried without the arctangent: ``|w| >= |sin w| = |u x (dx, dy)| / d``, so a
    cross product beyond ``d window`` (widened by a relative 1e-9 and 1e-12 rad, far above its
    rounding) rejects exactly the reflectors the exact test would reject (issue 11: most of those
    the grid's strip visits lie well beside the beam).
    """
    dx, dy = rx[j] - hx, ry[j] - hy
    d2 = dx * dx + dy * dy
    d = math.sqrt(d2)
    if not d <= max_range:
        return False
    e = d2 - r2[j]
    if e > 0.0:
        window = math.sqrt(a4 + b4 / max(e, 1e-300)) + half_pi_r[j] / max(d, 1e-300)
        if abs(ux * dy - uy * dx) > d * (window * (1.0 + 1e-9) + 1e-12):
            return False
        w = wrap_angle_kernel(beam - math.atan2(dy, dx))
        if not abs(w) < window:
            return False
    return True  # inside a reflector (e <= 0) it always stays a candidate


@jit
def near_rows(
    rx: NDArray[np.float64], ry: NDArray[np.float64], r2: NDArray[np.float64], half_pi_r: NDArray[np.float64],
    hx: float, hy: float, beam: float, a4: float, b4: float, max_range: float,
) -> NDArray[np.int64]:
    """Rows (ascending) of the reflectors that pass :func:`near_one`, one compiled pass over the map.

    Arguments as :func:`near_one`. The reference of :func:`grid_rows` (which returns the same rows)
    and its fallback for wide gates.
    """
    n = rx.shape[0]
    out = np.empty(n, np.int64)
    c = 0
    ux, uy = math.cos(beam), math.sin(beam)
    for j in range(n):
        if near_one(j, rx, ry, r2, half_pi_r, hx, hy, beam, a4, b4, max_range, ux, uy):
            out[c] = j
            c += 1
    return out[:c]


#: ``2 / sqrt(3)``: ``d / sqrt(d^2 - r^2)`` at most, for ``d >= 2 r`` (module docstring).
_K0 = 2.0 / math.sqrt(3.0)
_SLACK = 1e-9  # relative widening of the disc and the strip: far above rounding, far below a cell


@jit
def _visit_box(
    start: NDArray[np.int64], rows: NDArray[np.int64], x0: float, y0: float, cell: float, nx: int, ny: int,
    cx: float, cy: float, half: float, seen: NDArray[np.bool_], out: NDArray[np.int64], c: int,
    rx: NDArray[np.float64], ry: NDArray[np.float64], r2: NDArray[np.float64], half_pi_r: NDArray[np.float64],
    hx: float, hy: float, beam: float, a4: float, b4: float, max_range: float, ux: float, uy: float,
) -> int:
    """:func:`near_one` on the rows of the cells not yet ``seen`` that overlap the square ``c +- half``;
    appends the rows that pass to ``out`` from index ``c`` and returns the new count."""
    ix_lo, ix_hi = math.floor((cx - half - x0) / cell), math.floor((cx + half - x0) / cell)
    iy_lo, iy_hi = math.floor((cy - half - y0) / cell), math.floor((cy + half - y0) / cell)
    if ix_hi < 0 or iy_hi < 0 or ix_lo > nx - 1 or iy_lo > ny - 1:
        return c
    for iy in range(max(iy_lo, 0), min(iy_hi, ny - 1) + 1):
        for ix in range(max(ix_lo, 0), min(ix_hi, nx - 1) + 1):
            k = iy * nx + ix
            if seen[k]:
                continue
            seen[k] = True
            for m in range(start[k], start[k + 1]):
                j = rows[m]
                if near_one(j, rx, ry, r2, half_pi_r, hx, hy, beam, a4, b4, max_range, ux, uy):
                    out[c] = j
                    c += 1
    return c


@jit
def grid_rows(
    start: NDArray[np.int64], rows: NDArray[np.int64], x0: float, y0: float, cell: float, nx: int, ny: int,
    rx: NDArray[np.float64], ry: NDArray[np.float64], r2: NDArray[np.float64], half_pi_r: NDArray[np.float64],
    hx: float, hy: float, beam: float, a4: float, b4: float, max_range: float, r_max: float,
) -> NDArray[np.int64]:
    """:func:`near_rows`'s rows (ascending, the same ones), testing only the reflectors near the beam.

    The grid (``start``, ``rows``: cells in CSR, origin ``(x0, y0)`` (m), side ``cell`` (m),
    ``nx * ny`` cells; see :class:`BearingIndex`) is searched in the disc of radius ``D`` around
    the head and the strip of half-width ``W`` along the beam (the module docstring derives both
    from ``a4``, ``b4`` and the largest radius ``r_max`` (m)); other arguments as :func:`near_one`.
    Falls back to :func:`near_rows` when the gate is too wide for the strip or the strip would
    cover about as many cells as the grid has.
    """
    sa, sb = math.sqrt(a4), math.sqrt(b4)
    n_cells = nx * ny
    if not sa < 1.0:
        return near_rows(rx, ry, r2, half_pi_r, hx, hy, beam, a4, b4, max_range)
    far = 0.0  # the farthest corner of the grid from the head: no reflector lies beyond
    for gx in (x0, x0 + nx * cell):
        for gy in (y0, y0 + ny * cell):
            far = max(far, math.sqrt((gx - hx) * (gx - hx) + (gy - hy) * (gy - hy)))
    length = min(max_range, far)
    lateral = _K0 * sb + 0.5 * math.pi * r_max
    disc = max(2.0 * r_max, 2.0 * lateral) * (1.0 + _SLACK) + _SLACK
    half = (length * sa + lateral) * (1.0 + _SLACK) + _SLACK + 0.5 * cell
    n_steps = int(length / cell) + 2  # squares every cell from a = 0 to a >= length
    if not n_steps * (2.0 * half / cell + 2.0) < n_cells:  # cells the strip covers (consecutive squares overlap)
        return near_rows(rx, ry, r2, half_pi_r, hx, hy, beam, a4, b4, max_range)
    seen = np.zeros(n_cells, np.bool_)
    out = np.empty(rx.shape[0], np.int64)
    ux, uy = math.cos(beam), math.sin(beam)
    c = _visit_box(start, rows, x0, y0, cell, nx, ny, hx, hy, disc, seen, out, 0,
                   rx, ry, r2, half_pi_r, hx, hy, beam, a4, b4, max_range, ux, uy)
    for k in range(n_steps):
        a = k * cell
        # the strip narrows towards the head: beside a <= a_hi it is (a_hi sa + lateral) / (1 - sa) wide
        a_hi = min(a + 0.5 * cell, length)
        wedge = min(length * sa + lateral, (a_hi * sa + lateral) / (1.0 - sa))
        half_k = wedge * (1.0 + _SLACK) + _SLACK + 0.5 * cell
        c = _visit_box(start, rows, x0, y0, cell, nx, ny, hx + a * ux, hy + a * uy, half_k, seen, out, c,
                       rx, ry, r2, half_pi_r, hx, hy, beam, a4, b4, max_range, ux, uy)
    return np.sort(out[:c])
