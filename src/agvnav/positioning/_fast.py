"""Scalar fast paths of the streaming estimators' inner loop (one vehicle, one step at a time).

A streaming estimator handles one odometry increment or one reflection per call, on
3-vectors and 3x3 matrices. NumPy's per-call overhead (~1 us per ufunc) dominated
those calls, so the closed-loop simulator spent most of its time there. The
functions below redo *the same equations* with the ``math`` module and explicit
3x3 arithmetic on flat row-major tuples. Each names the vectorised kernel it
mirrors; ``tests/positioning/test_fast.py`` checks every one against that kernel
to 1e-12 (they differ only in the summation order of the matrix products). The
kernels stay the reference and serve every batch use.

Matrices are flat row-major tuples of 9 floats: ``P[3 * i + j]``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

Mat3 = tuple[float, ...]

_PI = math.pi
_TWO_PI = 2.0 * math.pi


def wrap(a: float) -> float:
    """:func:`agvnav.geometry.wrap_angle` for one float: ``(a + pi) mod 2 pi - pi`` (rad)."""
    return (a + _PI) % _TWO_PI - _PI


def _sinc(h: float) -> float:
    """``sin(h) / h`` with the series below 1e-4, as ``agvnav.odometry.integrate._sinc``."""
    return 1.0 - h * h / 6.0 if abs(h) < 1e-4 else math.sin(h) / h


def arc_step(
    x: float, y: float, psi: float, dd: float, dth: float
) -> tuple[float, float, float, float, float]:
    """Dead-reckoned pose by the exact arc rule (seed 002 eq. 25).

    Mirrors :func:`agvnav.odometry.integrate_pose` with ``rule="arc"``. Returns the
    new ``(x, y, psi)`` (psi wrapped) and ``(F02, F12)``, the only non-identity
    entries of :func:`agvnav.odometry.pose_jacobian` (``-chord sin``, ``chord cos``
    of the mid heading).
    """
    chord = dd * _sinc(0.5 * dth)
    heading = psi + 0.5 * dth
    c, s = math.cos(heading), math.sin(heading)
    return x + chord * c, y + chord * s, wrap(psi + dth), -chord * s, chord * c


def process_noise(psi: float, dd: float, dth: float, k_d: float, k_dtheta: float, k_theta: float) -> Mat3:
    """``Q = J diag(K_D|dD|, K_Dtheta|dD| + K_theta|dtheta|) J^T`` (seed 002 eq. 17, corrected).

    Mirrors :func:`agvnav.odometry.motion_covariance`: ``J = [[c, 0], [s, 0], [0, 1]]`` at
    the mid heading ``psi + dtheta / 2``.
    """
    heading = psi + 0.5 * dth
    c, s = math.cos(heading), math.sin(heading)
    var_d = k_d * abs(dd)
    var_th = k_dtheta * abs(dd) + k_theta * abs(dth)
    cd, sd = c * var_d, s * var_d
    return (cd * c, cd * s, 0.0, sd * c, sd * s, 0.0, 0.0, 0.0, var_th)


def predict_covariance(P: Sequence[float], f02: float, f12: float, Q: Sequence[float]) -> Mat3:
    """``P' = F P F^T + Q``, symmetrised, for ``F = I`` except ``F[0,2], F[1,2]``.

    Mirrors :func:`agvnav.positioning.ekf.ekf_predict` (and the estimator's
    prediction) with the Jacobian of :func:`arc_step`: row ``i`` of ``F P`` is
    ``P[i] + F[i,2] P[2]``, and ``(F P F^T)[i, j] = (F P)[i, j] + (F P)[i, 2] F[j, 2]``.
    """
    f = (f02, f12, 0.0)
    fp = [P[3 * i + j] + f[i] * P[6 + j] for i in range(3) for j in range(3)]
    full = [fp[3 * i + j] + fp[3 * i + 2] * f[j] + Q[3 * i + j] for i in range(3) for j in range(3)]
    return _symmetrise(full)


def _symmetrise(A: Sequence[float]) -> Mat3:
    """``(A + A^T) / 2`` of a flat 3x3."""
    return tuple(0.5 * (A[3 * i + j] + A[3 * j + i]) for i in range(3) for j in range(3))


def joseph_update(
    x: Sequence[float], P: Sequence[float], innovation: float, H: Sequence[float], R: float
) -> tuple[tuple[float, float, float], Mat3]:
    """Scalar-measurement EKF update in Joseph form for one state.

    Mirrors :func:`agvnav.positioning.ekf.ekf_update`: ``S = H P H^T + R``,
    ``K = P H^T / S``, ``x' = x + K y`` (heading wrapped),
    ``P' = (I - K H) P (I - K H)^T + R K K^T``, symmetrised.
    """
    pht = [P[3 * i] * H[0] + P[3 * i + 1] * H[1] + P[3 * i + 2] * H[2] for i in range(3)]
    S = H[0] * pht[0] + H[1] * pht[1] + H[2] * pht[2] + R
    K = [v / S for v in pht]
    xn = (x[0] + K[0] * innovation, x[1] + K[1] * innovation, wrap(x[2] + K[2] * innovation))
    A = [(1.0 if i == j else 0.0) - K[i] * H[j] for i in range(3) for j in range(3)]
    AP = [A[3 * i] * P[j] + A[3 * i + 1] * P[3 + j] + A[3 * i + 2] * P[6 + j] for i in range(3) for j in range(3)]
    full = [
        AP[3 * i] * A[3 * j] + AP[3 * i + 1] * A[3 * j + 1] + AP[3 * i + 2] * A[3 * j + 2] + R * K[i] * K[j]
        for i in range(3)
        for j in range(3)
    ]
    return xn, _symmetrise(full)


def reflector_rows(reflector_xy: Sequence[Sequence[float]], radius: Sequence[float]) -> tuple[tuple[float, float, float], ...]:
    """Per-map constants of the gate, ``(x, y, r)`` per reflector as Python floats.

    Built once per estimator (the map does not change during a run), so the inner
    loop never converts arrays.
    """
    return tuple((float(p[0]), float(p[1]), float(r)) for p, r in zip(reflector_xy, radius, strict=True))


def bearing_row(
    px: float, py: float, psi: float, mount_theta: float, dpx_dpsi: float, dpy_dpsi: float,
    rx: float, ry: float, r: float,
) -> tuple[float, float, float, float, float]:
    """Leading-edge bearing of one reflector from head centre ``(px, py)`` and its Jacobian row.

    Mirrors :func:`agvnav.positioning.identification.bearing_model` for one reflector
    (seed 000 §2.1): ``h = wrap(atan2(dy, dx) - psi - mount_theta - asin(r / d))``;
    ``dpx_dpsi, dpy_dpsi`` are the derivatives of the head position with respect to
    psi. Returns ``(h, H0, H1, H2, d)``.
    """
    dx, dy = rx - px, ry - py
    d2 = dx * dx + dy * dy
    d = math.sqrt(d2)
    if d > 0.0:
        edge = -math.asin(min(max(r / d, 0.0), 1.0))
        ratio = min(max(r / d, 0.0), 1.0 - 1e-12)
        edge_gain = r / (d**3 * math.sqrt(1.0 - ratio**2))
        h0, h1 = dy / d2 - edge_gain * dx, -dx / d2 - edge_gain * dy
    else:  # head on the reflector centre: the kernel's d -> inf limits
        edge, h0, h1 = -0.5 * _PI, 0.0, 0.0
    h = wrap(math.atan2(dy, dx) - psi - mount_theta + edge)
    return h, h0, h1, h0 * dpx_dpsi + h1 * dpy_dpsi - 1.0, d


def quadratic_form(H: Sequence[float], P: Sequence[float]) -> float:
    """``H P H^T`` for a row ``H (3,)`` and a flat symmetric 3x3 ``P``."""
    h0, h1, h2 = H
    return (
        h0 * h0 * P[0] + h1 * h1 * P[4] + h2 * h2 * P[8]
        + 2.0 * (h0 * h1 * P[1] + h0 * h2 * P[2] + h1 * h2 * P[5])
    )


def gate_one(
    z: float,
    pose: Sequence[float],
    P: Sequence[float],
    mount: Sequence[float],
    rows: Sequence[tuple[float, float, float]],
    bearing_var: float,
    max_range: float,
    allowed: Sequence[bool],
    gate: float,
    map_std: float,
) -> tuple[int, float, float, int, tuple[float, float, float], float, float]:
    """Chi-square gate of one bearing against every reflector, for one pose.

    Mirrors :func:`agvnav.positioning.identification.gate_reflection`: for each
    reflector in range and ``allowed`` (not claimed in this sweep), ``y = wrap(z - h)``,
    ``S = H P H^T + sigma^2 + (map_std / d)^2``, inside when ``y^2 / S < gate``.
    Returns ``(index, y, nis, n_in_gate, H, S, R)`` of the only reflector inside, or
    index -1 (and ``n_in_gate``) when none or several are.
    """
    x, y, psi = pose
    mx, my, mth = mount
    c, s = math.cos(psi), math.sin(psi)
    px, py = x + c * mx - s * my, y + s * mx + c * my
    dpx, dpy = -s * mx - c * my, c * mx - s * my
    n_in, best = 0, None
    for j, (rx, ry, r) in enumerate(rows):
        if not allowed[j]:
            continue
        h, h0, h1, h2, d = bearing_row(px, py, psi, mth, dpx, dpy, rx, ry, r)
        if not d <= max_range:
            continue
        R = bearing_var + (map_std / d if d > 0.0 else 0.0) ** 2
        S = quadratic_form((h0, h1, h2), P) + R
        innov = wrap(z - h)
        nis = innov * innov / S
        if nis < gate:
            n_in += 1
            best = (j, innov, nis, 1, (h0, h1, h2), S, R)
    if n_in != 1 or best is None:
        return -1, math.nan, math.inf, n_in, (0.0, 0.0, 0.0), math.nan, math.nan
    return best
