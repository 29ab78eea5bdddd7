"""Which reflectors can a bearing come from? A vectorised pre-selection for large maps.

The streaming estimators identify each anonymous reflection with a chi-square gate on
its bearing innovation (:func:`agvnav.positioning._fast.gate_one`, mirroring
:func:`~agvnav.positioning.identification.gate_reflection`). Evaluated reflector by
reflector in Python, that gate costs about 2 us per reflector and per reflection, and
the reflections per second grow with the number of reflectors too: the cost of a run
grows as N^2 (issue 11: 46x real time at N = 64, 5x at N = 256).

:class:`BearingIndex` finds, with one compiled pass over the map (:func:`near_rows`), the few
reflectors whose predicted leading-edge bearing lies close enough to the measured one to
possibly pass the gate -- within a bound on ``sqrt(gate S)`` of the reflector's predicted
edge, i.e. a few sigma plus the reflector's angular radius ``asin(r / d)``. Only those go
through the exact scalar gate, so the accepted association is the one the full loop
gives (a test compares both on random maps).

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

__all__ = ["INDEX_MIN_REFLECTORS", "BearingIndex", "GateSpec", "near_rows"]


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


class BearingIndex:
    """Vectorised pre-selection of the reflectors that may lie inside one bearing's gate.

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
        rows = near_rows(
            self._rx, self._ry, self._r2, self._half_pi_r, x + c * mx - s * my, y + s * mx + c * my,
            z + psi + mth, a4, b4, spec.max_range,
        )
        return rows.tolist()


@jit
def near_rows(
    rx: NDArray[np.float64], ry: NDArray[np.float64], r2: NDArray[np.float64], half_pi_r: NDArray[np.float64],
    hx: float, hy: float, beam: float, a4: float, b4: float, max_range: float,
) -> NDArray[np.int64]:
    """Rows (ascending) of the reflectors within ``max_range`` (m) of the head ``(hx, hy)`` (m) whose
    centre lies within the gate bound of the absolute bearing ``beam`` (rad; see the module docstring).

    ``r2`` the squared radii (m^2), ``half_pi_r`` ``(pi / 2) r`` (m), ``4 gate S_max = a4 + b4 g``
    with ``g = 1 / (d^2 - r^2)``. A compiled loop over the map (:mod:`agvnav._jit`): one pass,
    no per-call NumPy temporaries (it was ~20 NumPy calls per reflection).
    """
    n = rx.shape[0]
    out = np.empty(n, np.int64)
    c = 0
    for j in range(n):
        dx, dy = rx[j] - hx, ry[j] - hy
        d2 = dx * dx + dy * dy
        d = math.sqrt(d2)
        if not d <= max_range:
            continue
        e = d2 - r2[j]
        if e > 0.0:
            window = math.sqrt(a4 + b4 / max(e, 1e-300)) + half_pi_r[j] / max(d, 1e-300)
            w = wrap_angle_kernel(beam - math.atan2(dy, dx))
            if not abs(w) < window:
                continue
        out[c] = j  # inside a reflector (e <= 0) it always stays a candidate
        c += 1
    return out[:c]
