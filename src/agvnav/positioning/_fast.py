"""Scalar kernels of the streaming estimators' inner loop (one vehicle, one step at a time).

A streaming estimator handles one odometry increment or one reflection per call, on
3-vectors and 3x3 matrices. NumPy's per-call overhead (~1 us per ufunc) dominated
those calls, so the closed-loop simulator spent most of its time there. The
functions below compute the equations with the ``math`` module and explicit 3x3
arithmetic on flat row-major tuples, as kernels (:func:`agvnav._jit.jit`: compiled by
numba or run as plain Python, the two modes agreeing to rounding). Each equation is
written once: the leading-edge bearing and its Jacobian (:func:`edge_bearing`,
:func:`bearing_jacobian`, seed 000 §2.1) and the odometry noise ``Q`` (:func:`process_noise`,
:func:`steered_noise`, over the odometry package's variance kernel
:func:`agvnav.odometry.increment_variances`, re-exported here) are the
kernels the compiled per-reflection path (:func:`move_state`, :func:`gate_rows`,
:func:`gate_accept`) and the integrity monitor's check
(:mod:`agvnav.positioning._integrity_fast`) call. The vectorised NumPy forms
(:func:`agvnav.positioning.edge_bearing.bearing_model`,
:func:`agvnav.odometry.motion_covariance`) are their test oracles and serve every
batch use; ``tests/positioning/test_fast.py`` checks the kernels against them to 1e-12.

Matrices are flat row-major tuples of 9 floats: ``P[3 * i + j]``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._jit import Kernel, jit
from agvnav.geometry.angles import wrap_angle_kernel, wrap_angle_scalar
from agvnav.odometry.noise_kernels import increment_variances as increment_variances  # re-exported
from agvnav.positioning.gating import GateSpec, grid_rows

Mat3 = tuple[float, ...]

_PI = math.pi


#: :func:`agvnav.geometry.wrap_angle` for one float, to ``[-pi, pi)`` (rad); an alias, no extra call.
wrap = wrap_angle_scalar


@jit
def _sinc(h: float) -> float:
    """``sin(h) / h`` with the series below 1e-4, as ``agvnav.odometry.integrate._sinc``."""
    return 1.0 - h * h / 6.0 if abs(h) < 1e-4 else math.sin(h) / h


@jit
def _dsinc(h: float) -> float:
    """Derivative of ``sin(h) / h``, as ``agvnav.odometry.integrate._dsinc``."""
    return -h / 3.0 if abs(h) < 1e-4 else (h * math.cos(h) - math.sin(h)) / (h * h)


@jit
def twist_step(
    x: float, y: float, psi: float, dd: float, dth: float, dl: float = 0.0
) -> tuple[float, float, float, float, float]:
    """Dead-reckoned pose after the body-twist increment ``(dd, dth, dl)`` (m, rad, m).

    ``dd = integral v_x dt``, ``dth = integral omega dt``, ``dl = integral v_y dt`` (the
    lateral increment, 0 for non-holonomic vehicles). The pose moves by the SE(2)
    exponential of the increment, exact for a constant twist over the step:

        [x', y'] = [x, y] + sinc(dth/2) R(psi + dth/2) [dd, dl],  psi' = psi + dth,

    with ``sinc(h) = sin(h)/h``. For ``dl = 0`` this is the seed-002 arc rule, the chord
    ``dd sin(dth/2)/(dth/2)`` along the mid heading [seed002 eq25] [seed002 eq24], computed
    with the same floating-point operations as :func:`agvnav.odometry.integrate_pose`
    (``rule="arc"``), which it mirrors; :func:`agvnav.kinematics.base.twist_step` is the
    same exponential over arrays.

    Returns the new ``(x, y, psi)`` (psi wrapped to ``[-pi, pi)``) and ``(F02, F12)``,
    the only non-identity entries of the Jacobian ``F = d pose' / d pose``:
    ``F02 = -(y' - y)``, ``F12 = x' - x``.
    """
    k = _sinc(0.5 * dth)
    heading = psi + 0.5 * dth
    c, s = math.cos(heading), math.sin(heading)
    chord = dd * k
    if dl == 0.0:  # seed 002's arc: exactly the operations of the non-holonomic rule
        ex, ey = chord * c, chord * s
    else:
        side = dl * k
        ex, ey = chord * c - side * s, chord * s + side * c
    return x + ex, y + ey, wrap_angle_kernel(psi + dth), -ey, ex


@jit
def process_noise(
    psi: float, dd: float, dth: float, k_d: float, k_dtheta: float, k_theta: float,
    dl: float = 0.0, k_lateral: float = 0.0,
) -> Mat3:
    """Process noise ``Q = G diag(var_d, var_th, var_l) G^T`` of one increment (flat 3x3).

    The odometry model of seed 002 [seed002 eq17] (:func:`agvnav.odometry.increment_variances`,
    its one kernel): independent errors on the increments, ``var_d = K_D |dd|`` and
    ``var_th = K_Dtheta s + K_theta |dth|`` with ``s = hypot(dd, dl)`` the distance travelled,
    extended for holonomic vehicles by a lateral error ``var_l = K_lateral |dl|`` (m^2 per
    metre of sideways travel). ``G`` is the exact Jacobian of :func:`twist_step`'s displacement
    ``sinc(h) R(psi + h) [dd, dl]`` (``h = dth / 2``) with respect to ``(dd, dth, dl)``: its ``dth`` column holds the
    lateral displacement a heading error makes within the step,
    ``(sinc'(h) R a + sinc(h) R_perp a) / 2`` with ``a = [dd, dl]`` (issue 12).

    For ``dl = 0`` this is :func:`agvnav.odometry.motion_covariance` (``rule="arc"``),
    which it mirrors to rounding.
    """
    h = 0.5 * dth
    k, dk = _sinc(h), _dsinc(h)
    heading = psi + h
    c, s = math.cos(heading), math.sin(heading)
    ax, ay = c * dd - s * dl, s * dd + c * dl  # R(heading) [dd, dl]
    tx, ty = 0.5 * (dk * ax - k * ay), 0.5 * (dk * ay + k * ax)  # d displacement / d dth
    var_d, var_th = increment_variances(dd, dth, k_d, k_dtheta, k_theta)
    if dl != 0.0:  # holonomic: the heading error grows with the whole distance travelled
        var_th = increment_variances(math.hypot(dd, dl), dth, k_d, k_dtheta, k_theta)[1]
    var_l = k_lateral * abs(dl)
    kc, ks = k * c, k * s
    q00 = var_d * kc * kc + var_th * tx * tx + var_l * ks * ks
    q01 = var_d * kc * ks + var_th * tx * ty - var_l * ks * kc
    q11 = var_d * ks * ks + var_th * ty * ty + var_l * kc * kc
    q02, q12 = var_th * tx, var_th * ty
    return (q00, q01, q02, q01, q11, q12, q02, q12, var_th)


@jit
def steered_noise(
    psi: float, dd: float, dth: float, front: bool, L: float, slip_k: float, steer_q: float,
    min_roll: float = 0.0,
) -> tuple[Mat3, tuple[float, float, float, float, float, float]]:
    """Process noise ``Q`` (flat 3x3) and calibration Jacobian ``W = G B`` (3x2, row-major) of one steered increment.

    Mirrors :class:`agvnav.odometry.SteeredOdometryNoise` through
    :func:`agvnav.odometry.motion_covariance` and :func:`agvnav.odometry.calibration_jacobian`
    (``rule="arc"``, ``dl = 0``). With ``G`` the Jacobian of :func:`twist_step` with
    respect to ``(dd, dth)``, ``a = G u`` (``u = (dd, dth)``: the slip and wheel-radius
    direction) and ``b = G w`` (``w`` the steering direction, front ``(-L dth, dd / L)``,
    rear ``(0, dd / L + L dth^2 / dd)``):

        Q = slip_k / |s| a a^T + steer_q / |s| b b^T,   W = [a, b]

    with ``|s|`` the driven wheel's distance (front ``hypot(dd, L dth)``, rear
    ``max(|dd|, min_roll |dth|)``, ``min_roll = L / tan(max_steering)``: an increment past the
    steering limit, as the estimator's split around a reflection makes, is taken at the limit,
    and the rear ``w`` uses that ``s`` signed as ``dd``) and ``steer_q = steering_std^2 step_m``.
    At ``s = 0`` with ``dth != 0`` (rear drive, no limit) ``Q`` is Crowley's ``slip_k / L |dth|``
    on the heading and ``W = 0``. Returns ``(Q, (a0, b0, a1, b1, a2, b2))``.
    """
    h = 0.5 * dth
    k, dk = _sinc(h), _dsinc(h)
    heading = psi + h
    c, s = math.cos(heading), math.sin(heading)
    gd0, gd1 = k * c, k * s  # d displacement / d dd
    tx, ty = 0.5 * dd * (dk * c - k * s), 0.5 * dd * (dk * s + k * c)  # d displacement / d dth
    if front:
        dist = math.hypot(dd, L * dth)
        w0, w1 = -L * dth, dd / L
    else:
        dist = max(abs(dd), min_roll * abs(dth))
        if dist == 0.0:  # no wheel roll explains the turn: Crowley's bound of the heading, no calibration term
            return (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, slip_k / L * abs(dth)), (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        sd = -dist if dd < 0.0 else dist
        w0, w1 = 0.0, sd / L + L * dth * dth / sd
    a0, a1, a2 = dd * gd0 + dth * tx, dd * gd1 + dth * ty, dth
    b0, b1, b2 = w0 * gd0 + w1 * tx, w0 * gd1 + w1 * ty, w1
    if dist > 0.0:
        qa, qb = slip_k / dist, steer_q / dist
    else:
        qa = qb = 0.0
    q00 = qa * a0 * a0 + qb * b0 * b0
    q01 = qa * a0 * a1 + qb * b0 * b1
    q02 = qa * a0 * a2 + qb * b0 * b2
    q11 = qa * a1 * a1 + qb * b1 * b1
    q12 = qa * a1 * a2 + qb * b1 * b2
    q22 = qa * a2 * a2 + qb * b2 * b2
    return (q00, q01, q02, q01, q11, q12, q02, q12, q22), (a0, b0, a1, b1, a2, b2)


@jit
def calibration_predict(
    P: Sequence[float], X: Sequence[float], f02: float, f12: float, W: Sequence[float], cvar: Sequence[float]
) -> tuple[Mat3, tuple[float, ...]]:
    """The calibration consider parameters' share of a prediction (:class:`agvnav.positioning.ekf.EkfEstimator`).

    With the pose error ``e' = F e + G (B c + noise)`` and consider parameters ``c`` of fixed
    covariance ``P_cc = diag(cvar)`` (the augmented transition ``[[F, W], [0, I]]``):

        P' = P + (F X) W^T + W (F X)^T + W P_cc W^T,   X' = F X + W P_cc

    where ``P`` is already ``F P F^T + Q`` (:func:`predict_covariance`) and ``X = P_xc``
    (3x2 row-major) the cross-covariance before the step. Returns ``(P', X')``.
    """
    x0, x1, x2, x3, x4, x5 = X
    fx0, fx1 = x0 + f02 * x4, x1 + f02 * x5  # F X: rows 0 and 1 get F[i,2] times row 2
    fx2, fx3 = x2 + f12 * x4, x3 + f12 * x5
    a0, b0, a1, b1, a2, b2 = W
    ce, cb = cvar
    # V = W P_cc, and (F X) W^T + W (F X)^T + V W^T for the upper triangle
    v0, u0, v1, u1, v2, u2 = a0 * ce, b0 * cb, a1 * ce, b1 * cb, a2 * ce, b2 * cb
    r0, s0 = fx0 + 0.5 * v0, fx1 + 0.5 * u0  # (F X + V / 2) row i: the sum below is R W^T + W R^T
    r1, s1 = fx2 + 0.5 * v1, fx3 + 0.5 * u1
    r2, s2 = x4 + 0.5 * v2, x5 + 0.5 * u2
    d00 = 2.0 * (r0 * a0 + s0 * b0)
    d01 = r0 * a1 + s0 * b1 + a0 * r1 + b0 * s1
    d02 = r0 * a2 + s0 * b2 + a0 * r2 + b0 * s2
    d11 = 2.0 * (r1 * a1 + s1 * b1)
    d12 = r1 * a2 + s1 * b2 + a1 * r2 + b1 * s2
    d22 = 2.0 * (r2 * a2 + s2 * b2)
    Pn = (P[0] + d00, P[1] + d01, P[2] + d02, P[1] + d01, P[4] + d11, P[5] + d12, P[2] + d02, P[5] + d12,
          P[8] + d22)
    return Pn, (fx0 + v0, fx1 + u0, fx2 + v1, fx3 + u1, x4 + v2, x5 + u2)


@jit
def calibration_update(X: Sequence[float], K: Sequence[float], H: Sequence[float]) -> tuple[float, ...]:
    """``X' = (I - K H) X`` for the pose / calibration cross-covariance ``X`` (3x2 row-major)."""
    h0, h1, h2 = H
    r0 = h0 * X[0] + h1 * X[2] + h2 * X[4]
    r1 = h0 * X[1] + h1 * X[3] + h2 * X[5]
    k0, k1, k2 = K
    return (X[0] - k0 * r0, X[1] - k0 * r1, X[2] - k1 * r0, X[3] - k1 * r1, X[4] - k2 * r0, X[5] - k2 * r1)


@jit
def predict_covariance(P: Sequence[float], f02: float, f12: float, Q: Sequence[float]) -> Mat3:
    """``P' = F P F^T + Q`` for ``F = I`` except ``F[0,2], F[1,2]``; ``P`` symmetric.

    Mirrors :func:`agvnav.positioning.ekf.ekf_predict` (and the estimator's
    prediction) with the Jacobian of :func:`arc_step`: rows 0 and 1 of ``F P`` are
    ``P[i] + F[i,2] P[2]``, and ``(F P F^T)[i, j] = (F P)[i, j] + (F P)[i, 2] F[j, 2]``.
    Only the upper triangle is computed and mirrored (symmetric by construction,
    where the kernel averages ``A`` and ``A^T``).
    """
    p00, p01, p02, _, p11, p12, _, _, p22 = P
    a00, a01, a02 = p00 + f02 * p02, p01 + f02 * p12, p02 + f02 * p22  # row 0 of F P
    a11, a12 = p11 + f12 * p12, p12 + f12 * p22  # row 1 of F P (a10 = a01 by symmetry)
    c00 = a00 + a02 * f02 + Q[0]
    c01 = a01 + a02 * f12 + Q[1]
    c11 = a11 + a12 * f12 + Q[4]
    c02, c12, c22 = a02 + Q[2], a12 + Q[5], p22 + Q[8]
    return (c00, c01, c02, c01, c11, c12, c02, c12, c22)


def joseph_update(
    x: Sequence[float], P: Sequence[float], innovation: float, H: Sequence[float], R: float
) -> tuple[tuple[float, float, float], Mat3]:
    """Scalar-measurement EKF update in Joseph form for one state; ``P`` symmetric.

    Mirrors :func:`agvnav.positioning.ekf.ekf_update`: ``S = H P H^T + R``,
    ``K = P H^T / S``, ``x' = x + K y`` (heading wrapped),
    ``P' = (I - K H) P (I - K H)^T + R K K^T`` with ``(I - K H) P = P - K (P H^T)^T``;
    only the upper triangle is computed and mirrored.
    """
    p00, p01, p02, _, p11, p12, _, _, p22 = P
    h0, h1, h2 = H
    b0 = p00 * h0 + p01 * h1 + p02 * h2  # P H^T
    b1 = p01 * h0 + p11 * h1 + p12 * h2
    b2 = p02 * h0 + p12 * h1 + p22 * h2
    S = h0 * b0 + h1 * b1 + h2 * b2 + R
    k0, k1, k2 = b0 / S, b1 / S, b2 / S
    xn = (x[0] + k0 * innovation, x[1] + k1 * innovation, wrap(x[2] + k2 * innovation))
    # rows of M = (I - K H) P: M[i, j] = P[i, j] - K[i] b[j] (written out: no loops, same operations)
    m00, m01, m02 = p00 - k0 * b0, p01 - k0 * b1, p02 - k0 * b2
    m10, m11, m12 = p01 - k1 * b0, p11 - k1 * b1, p12 - k1 * b2
    m20, m21, m22 = p02 - k2 * b0, p12 - k2 * b1, p22 - k2 * b2
    # (M (I - K H)^T)[i, j] = M[i, j] - (M H^T)[i] K[j], plus R K[i] K[j]; upper triangle, mirrored
    mh0 = m00 * h0 + m01 * h1 + m02 * h2
    mh1 = m10 * h0 + m11 * h1 + m12 * h2
    mh2 = m20 * h0 + m21 * h1 + m22 * h2
    c00 = m00 - mh0 * k0 + R * k0 * k0
    c01 = m01 - mh0 * k1 + R * k0 * k1
    c02 = m02 - mh0 * k2 + R * k0 * k2
    c11 = m11 - mh1 * k1 + R * k1 * k1
    c12 = m12 - mh1 * k2 + R * k1 * k2
    c22 = m22 - mh2 * k2 + R * k2 * k2
    return xn, (c00, c01, c02, c01, c11, c12, c02, c12, c22)


def gain(P: Sequence[float], H: Sequence[float], R: float) -> tuple[float, float, float]:
    """Kalman gain ``K = P H^T / (H P H^T + R)`` of a scalar measurement on a flat symmetric 3x3 ``P``."""
    p00, p01, p02, _, p11, p12, _, _, p22 = P
    h0, h1, h2 = H
    b0 = p00 * h0 + p01 * h1 + p02 * h2
    b1 = p01 * h0 + p11 * h1 + p12 * h2
    b2 = p02 * h0 + p12 * h1 + p22 * h2
    S = h0 * b0 + h1 * b1 + h2 * b2 + R
    return b0 / S, b1 / S, b2 / S


# ---------------------------------------------------------------------- Schmidt-Kalman consider filter
# The EKF's consider parameters are the 2-D survey errors p_j of the reflectors (true minus
# surveyed position), fixed covariance diag(svar_j, svar_j). Their cross-covariance with the
# pose, P_xp (3 x 2N), is kept factored as ``P_xp = M C^T``: ``M`` a flat 3x3 (every
# left-multiplication -- a prediction's F, an update's (I - K H) -- touches only M, O(1)),
# ``C`` a (2N, 3) array whose rows 2j and 2j+1 belong to reflector j (see
# :class:`agvnav.positioning.ekf.EkfEstimator`).


@jit
def consider_cross(
    M: Sequence[float], cx: Sequence[float], cy: Sequence[float], hp0: float, hp1: float
) -> tuple[float, float, float]:
    """``v = P_xp,j H_p^T`` (3,): the pose / survey-error cross-covariance of one reflector times its row.

    ``P_xp,j = M [cx cy]`` (3 x 2, ``cx``, ``cy`` the reflector's two rows of ``C``),
    ``H_p = (hp0, hp1)`` the bearing's derivative with respect to the reflector position
    (rad/m; ``-(H0, H1)`` of the pose row).
    """
    w0 = cx[0] * hp0 + cy[0] * hp1
    w1 = cx[1] * hp0 + cy[1] * hp1
    w2 = cx[2] * hp0 + cy[2] * hp1
    return (
        M[0] * w0 + M[1] * w1 + M[2] * w2,
        M[3] * w0 + M[4] * w1 + M[5] * w2,
        M[6] * w0 + M[7] * w1 + M[8] * w2,
    )


@jit
def schmidt_update(
    x: Sequence[float], P: Sequence[float], innovation: float, H: Sequence[float], R: float,
    v: Sequence[float], b: float,
) -> tuple[tuple[float, float, float], Mat3, tuple[float, float, float], float]:
    """Scalar Schmidt-Kalman (consider) update of the pose for a measurement that also sees consider parameters.

    The linearised innovation is ``y = H e + H_p p + w`` (``e`` the pose error, ``p`` the
    consider parameters, ``w`` white with variance ``R``). With ``v = P_xp H_p^T`` and
    ``b = H_p P_pp H_p^T``:

        S = H P H^T + 2 H v + b + R,   K = (P H^T + v) / S,   x' = x + K y,
        P' = A P A^T - A v K^T - K v^T A^T + (b + R) K K^T,  A = I - K H

    (the Joseph form of the error ``e' = A e - K (H_p p + w)``; the gain only on ``x``,
    the consider parameters never updated). ``P`` flat symmetric 3x3; only the upper
    triangle of ``P'`` is computed and mirrored. With ``v = 0`` and ``b = 0`` this is
    :func:`joseph_update`. The caller updates ``P_xp' = A P_xp - K H_p P_pp``.

    Returns ``(x', P', K, S)``.
    """
    p00, p01, p02, _, p11, p12, _, _, p22 = P
    h0, h1, h2 = H
    v0, v1, v2 = v
    b0 = p00 * h0 + p01 * h1 + p02 * h2  # P H^T
    b1 = p01 * h0 + p11 * h1 + p12 * h2
    b2 = p02 * h0 + p12 * h1 + p22 * h2
    u0, u1, u2 = b0 + v0, b1 + v1, b2 + v2
    hv = h0 * v0 + h1 * v1 + h2 * v2
    S = h0 * b0 + h1 * b1 + h2 * b2 + 2.0 * hv + b + R
    k0, k1, k2 = u0 / S, u1 / S, u2 / S
    xn = (x[0] + k0 * innovation, x[1] + k1 * innovation, wrap_angle_kernel(x[2] + k2 * innovation))
    # M = A P = P - K (P H^T)^T, rows
    m00, m01, m02 = p00 - k0 * b0, p01 - k0 * b1, p02 - k0 * b2
    m10, m11, m12 = p01 - k1 * b0, p11 - k1 * b1, p12 - k1 * b2
    m20, m21, m22 = p02 - k2 * b0, p12 - k2 * b1, p22 - k2 * b2
    mh0 = m00 * h0 + m01 * h1 + m02 * h2  # (A P) H^T
    mh1 = m10 * h0 + m11 * h1 + m12 * h2
    mh2 = m20 * h0 + m21 * h1 + m22 * h2
    a0, a1, a2 = v0 - k0 * hv, v1 - k1 * hv, v2 - k2 * hv  # A v
    q = b + R
    # (A P A^T)[i, j] = (A P)[i, j] - ((A P) H^T)[i] K[j]; minus (A v)[i] K[j] + K[i] (A v)[j]; plus q K[i] K[j]
    c00 = m00 - mh0 * k0 - 2.0 * a0 * k0 + q * k0 * k0
    c01 = m01 - mh0 * k1 - (a0 * k1 + k0 * a1) + q * k0 * k1
    c02 = m02 - mh0 * k2 - (a0 * k2 + k0 * a2) + q * k0 * k2
    c11 = m11 - mh1 * k1 - 2.0 * a1 * k1 + q * k1 * k1
    c12 = m12 - mh1 * k2 - (a1 * k2 + k1 * a2) + q * k1 * k2
    c22 = m22 - mh2 * k2 - 2.0 * a2 * k2 + q * k2 * k2
    return xn, (c00, c01, c02, c01, c11, c12, c02, c12, c22), (k0, k1, k2), S


@jit
def left_update(M: Sequence[float], K: Sequence[float], H: Sequence[float]) -> Mat3:
    """``(I - K H) M`` for flat 3x3 ``M``, column ``K`` and row ``H`` (3,)."""
    h0, h1, h2 = H
    r0 = h0 * M[0] + h1 * M[3] + h2 * M[6]  # H M
    r1 = h0 * M[1] + h1 * M[4] + h2 * M[7]
    r2 = h0 * M[2] + h1 * M[5] + h2 * M[8]
    k0, k1, k2 = K
    return (
        M[0] - k0 * r0, M[1] - k0 * r1, M[2] - k0 * r2,
        M[3] - k1 * r0, M[4] - k1 * r1, M[5] - k1 * r2,
        M[6] - k2 * r0, M[7] - k2 * r1, M[8] - k2 * r2,
    )


@jit
def shear(M: Sequence[float], f02: float, f12: float) -> Mat3:
    """``F M`` for the prediction Jacobian ``F = I`` except ``F[0,2] = f02``, ``F[1,2] = f12`` (flat 3x3)."""
    m6, m7, m8 = M[6], M[7], M[8]
    return (M[0] + f02 * m6, M[1] + f02 * m7, M[2] + f02 * m8, M[3] + f12 * m6, M[4] + f12 * m7, M[5] + f12 * m8,
            m6, m7, m8)


@jit
def det3(M: Sequence[float]) -> float:
    """Determinant of a flat 3x3."""
    return (M[0] * (M[4] * M[8] - M[5] * M[7]) - M[1] * (M[3] * M[8] - M[5] * M[6])
            + M[2] * (M[3] * M[7] - M[4] * M[6]))


@jit
def solve3(M: Sequence[float], r: Sequence[float], det: float) -> tuple[float, float, float]:
    """``M^-1 r`` by the adjugate (``det = det3(M)``, nonzero; the caller keeps ``M`` well conditioned)."""
    a, b_, c, d, e, f, g, h, i = M
    r0, r1, r2 = r
    return (
        ((e * i - f * h) * r0 - (b_ * i - c * h) * r1 + (b_ * f - c * e) * r2) / det,
        (-(d * i - f * g) * r0 + (a * i - c * g) * r1 - (a * f - c * d) * r2) / det,
        ((d * h - e * g) * r0 - (a * h - b_ * g) * r1 + (a * e - b_ * d) * r2) / det,
    )


def reflector_rows(
    reflector_xy: Iterable[Sequence[float]], radius: Iterable[float]
) -> tuple[tuple[float, float, float], ...]:
    """Per-map constants of the gate, ``(x, y, r)`` per reflector as Python floats.

    Built once per estimator (the map does not change during a run), so the inner
    loop never converts arrays.
    """
    return tuple((float(p[0]), float(p[1]), float(r)) for p, r in zip(reflector_xy, radius, strict=True))


@jit
def edge_bearing(
    px: float, py: float, psi: float, mount_theta: float, rx: float, ry: float, r: float
) -> tuple[float, float, float, float, float]:
    """Leading-edge bearing of one reflector from head centre ``(px, py)`` (seed 000 §2.1).

    ``h = wrap(atan2(dy, dx) - psi - mount_theta - asin(r / d))`` as in
    :func:`agvnav.positioning.edge_bearing.bearing_model`. Returns ``(h, dx, dy, d^2, d)``.
    """
    dx, dy = rx - px, ry - py
    d2 = dx * dx + dy * dy
    d = math.sqrt(d2)
    edge = -math.asin(min(max(r / d, 0.0), 1.0)) if d > 0.0 else -0.5 * _PI
    return wrap_angle_kernel(math.atan2(dy, dx) - psi - mount_theta + edge), dx, dy, d2, d


@jit
def bearing_jacobian(
    dx: float, dy: float, d2: float, d: float, r: float, dpx_dpsi: float, dpy_dpsi: float
) -> tuple[float, float, float]:
    """Row ``dh/d[x, y, psi]`` of :func:`edge_bearing`, as in ``bearing_model`` (d -> inf limits at d = 0).

    ``dpx_dpsi, dpy_dpsi`` are the derivatives of the head position with respect to psi.
    """
    if d > 0.0:
        ratio = min(max(r / d, 0.0), 1.0 - 1e-12)
        edge_gain = r / (d * d * d * math.sqrt(1.0 - ratio * ratio))
        h0, h1 = dy / d2 - edge_gain * dx, -dx / d2 - edge_gain * dy
    else:  # head on the reflector centre
        h0, h1 = 0.0, 0.0
    return h0, h1, h0 * dpx_dpsi + h1 * dpy_dpsi - 1.0


def bearing_row(
    px: float, py: float, psi: float, mount_theta: float, dpx_dpsi: float, dpy_dpsi: float,
    rx: float, ry: float, r: float,
) -> tuple[float, float, float, float, float]:
    """:func:`edge_bearing` and :func:`bearing_jacobian` of one reflector: ``(h, H0, H1, H2, d)``.

    Mirrors :func:`agvnav.positioning.edge_bearing.bearing_model` for one reflector.
    """
    h, dx, dy, d2, d = edge_bearing(px, py, psi, mount_theta, rx, ry, r)
    h0, h1, h2 = bearing_jacobian(dx, dy, d2, d, r, dpx_dpsi, dpy_dpsi)
    return h, h0, h1, h2, d


@jit
def surely_outside(
    innovation: float, d2: float, r: float, R: float, trace_P: float, mount_norm: float, gate: float,
    svar: float = 0.0, consider: bool = False,
) -> bool:
    """True when ``y^2 / S >= gate`` is certain without the Jacobian (a cheap pre-test of the gate).

    ``|dh/d(x, y)|^2 = 1 / (d^2 - r^2)`` for the edge bearing (the centre and edge terms
    are orthogonal) and ``|dh/dpsi| <= |dh/d(x, y)| |mount| + 1``, so
    ``H P H^T <= a = trace(P) |H|^2`` for a covariance ``P`` and ``S <= R + a``. A factor 2 of
    margin keeps rounding from ever rejecting a reflector the exact test would admit. With
    ``consider`` (the Schmidt-Kalman gate of :func:`gate_one`, ``R`` the bearing variance)
    ``S <= R + 2 (a + b)``, ``b = svar / (d^2 - r^2)`` the survey error's share.
    """
    if d2 <= r * r:
        return False
    g2 = 1.0 / (d2 - r * r)
    g = math.sqrt(g2) * mount_norm + 1.0
    a_max = trace_P * (g2 + g * g)
    s_max = R + 2.0 * (a_max + svar * g2) if consider else R + a_max
    return innovation * innovation >= 2.0 * gate * s_max


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
    spec: GateSpec,
    claimed: Sequence[float] | NDArray[np.float64],
    t: float,
    candidates: Iterable[int] | None = None,
    consider: tuple[Sequence[float], Any, Sequence[float]] | None = None,
) -> tuple[int, float, float, int, tuple[float, float, float], float, float]:
    """Chi-square gate of one bearing against the map's reflectors, for one pose.

    Mirrors :func:`agvnav.positioning.bearing_gate.gate_reflection`: for each
    reflector in range and not claimed in this sweep (``t - claimed[j] < spec.sweep``
    excludes it), ``y = wrap(z - h)``, ``S = H P H^T + sigma^2 + (map_std / d)^2``,
    inside when ``y^2 / S < gate``. ``candidates`` restricts the loop to those rows
    (:meth:`agvnav.positioning.gating.BearingIndex.candidates`, a superset of the rows
    inside the gate); None loops over every reflector. Returns
    ``(index, y, nis, n_in_gate, H, S, R)`` of the only reflector inside, or index -1
    (and ``n_in_gate``) when none or several are.

    ``consider = (M, C, svar)``: the Schmidt-Kalman EKF's survey errors as consider
    parameters (:func:`schmidt_update`; ``P_xp = M C^T`` with ``C (N, 6)``, reflector j's
    two columns in ``C[j]``, ``svar[j]`` its survey variance, m² per axis). The innovation
    variance is then the update's own, ``S = H P H^T + 2 H v + b + sigma^2`` with
    ``b = svar_j |H_xy|^2`` (``|H_xy|^2 = 1 / (d^2 - r^2)``, so ``b = (std_j / d)^2`` to
    first order) and ``v = P_xp,j H_p^T``; ``R`` returned is ``sigma^2 + b``. The
    cheap pre-test bounds ``S`` by ``sigma^2 + 2 (a + b)`` with ``a`` the bound on
    ``H P H^T`` (``|H v| <= sqrt(a b)``: the joint covariance is positive semi-definite).
    """
    x, y, psi = pose
    mx, my, mth = mount
    bearing_var, max_range, gate, map_std, sweep = spec.bearing_var, spec.max_range, spec.gate, spec.map_std, spec.sweep
    c, s = math.cos(psi), math.sin(psi)
    px, py = x + c * mx - s * my, y + s * mx + c * my
    dpx, dpy = -s * mx - c * my, c * mx - s * my
    p00, p01, p02, _, p11, p12, _, _, p22 = P
    trace_P, mount_norm = p00 + p11 + p22, math.hypot(mx, my)
    n_in, best = 0, None
    if consider is not None:
        cM, cC, svar = consider
        cM = tuple(float(v) for v in cM)
    for j in range(len(rows)) if candidates is None else candidates:
        if t - claimed[j] < sweep:
            continue
        rx, ry, r = rows[j]
        h, dx, dy, d2, d = edge_bearing(px, py, psi, mth, rx, ry, r)
        if not d <= max_range:
            continue
        innov = wrap(z - h)
        if consider is None:
            md = map_std / d if d > 0.0 else 0.0
            R = bearing_var + md * md
            if surely_outside(innov, d2, r, R, trace_P, mount_norm, gate):  # most reflectors: no Jacobian needed
                continue
        elif surely_outside(innov, d2, r, bearing_var, trace_P, mount_norm, gate, svar[j], True):
            continue
        h0, h1, h2 = bearing_jacobian(dx, dy, d2, d, r, dpx, dpy)
        if consider is not None:
            R = bearing_var + svar[j] * (h0 * h0 + h1 * h1)
        # quadratic_form(H, P) written out: this loop is the estimator's hottest
        S = h0 * h0 * p00 + h1 * h1 * p11 + h2 * h2 * p22 + 2.0 * (h0 * h1 * p01 + h0 * h2 * p02 + h1 * h2 * p12) + R
        if consider is not None:  # + 2 H P_xp,j H_p^T
            cx0, cx1, cx2, cy0, cy1, cy2 = cC[j].tolist()
            v0, v1, v2 = consider_cross(cM, (cx0, cx1, cx2), (cy0, cy1, cy2), -h0, -h1)
            S += 2.0 * (h0 * v0 + h1 * v1 + h2 * v2)
        nis = innov * innov / S
        if nis < gate:
            n_in += 1
            best = (j, innov, nis, 1, (h0, h1, h2), S, R)
    if n_in != 1 or best is None:
        return -1, math.nan, math.inf, n_in, (0.0, 0.0, 0.0), math.nan, math.nan
    return best


# ---------------------------------------------------------------------- the per-reflection path (issue 11)
# A reflection took ~40 Python calls (prediction to its instant, gate, Schmidt update). The kernels
# below do that work in two calls (:mod:`agvnav._jit`), calling the kernels above for every equation.
#
# A compiled call costs about 30 ns per argument to type and unbox (more for a tuple of mixed
# types), so the per-run constants travel packed in one float array (:func:`gate_constants`,
# :func:`move_constants`) and the map in one ``(6, N)`` table (:func:`gate_table`).

#: Slots of :func:`gate_constants` (one float array per estimator).
_G_BVAR, _G_RANGE, _G_GATE, _G_MAP_STD, _G_SWEEP, _G_MNORM = 0, 1, 2, 3, 4, 5
_G_MX, _G_MY, _G_MTH, _G_X0, _G_Y0, _G_CELL, _G_RMAX, _G_NX, _G_NY, _G_GRID = 6, 7, 8, 9, 10, 11, 12, 13, 14, 15
_G_CONSIDER, _G_UVAR, _G_MIN_DET, _G_MAX_ENTRY, _G_CALIBRATED = 16, 17, 18, 19, 20


def gate_constants(
    spec: GateSpec, mount: Sequence[float], grid: tuple[float, float, float, int, int, float] | None,
    bearing_var: float, min_det: float = 0.0, max_entry: float = 0.0, calibrated: bool = False,
) -> NDArray[np.float64]:
    """The per-run constants of :func:`gate_rows` and :func:`gate_accept`, packed in one float array.

    ``spec`` the gate (:class:`~agvnav.positioning.gating.GateSpec`), ``mount`` the head pose
    in base_link (m, m, rad), ``grid`` the index's ``(x0, y0, cell, nx, ny, r_max)`` (m; None
    without an index), ``bearing_var`` the update's ``sigma^2`` (rad²), ``min_det`` and
    ``max_entry`` the fold limits of the consider factor ``M`` and ``calibrated`` whether
    ``P_xc`` is carried (:class:`~agvnav.positioning.ekf.EkfEstimator`).
    """
    mx, my, mth = (float(v) for v in mount)
    mount_norm = math.hypot(mx, my)
    x0, y0, cell, nx, ny, r_max = (0.0, 0.0, 1.0, 1, 1, 0.0) if grid is None else grid
    return np.array([
        spec.bearing_var, spec.max_range, spec.gate, spec.map_std, spec.sweep, mount_norm,
        mx, my, mth, x0, y0, cell, r_max, nx, ny, 0.0 if grid is None else 1.0,
        1.0 if spec.consider else 0.0, bearing_var, min_det, max_entry, 1.0 if calibrated else 0.0,
    ], dtype=np.float64)


def gate_table(
    rows: Sequence[tuple[float, float, float]], svar: ArrayLike | None = None
) -> NDArray[np.float64]:
    """``(6, N)`` the map for :func:`gate_rows`: ``x, y, r, r^2, (pi / 2) r`` (m, m², m), ``svar`` (m², 0 without)."""
    xyr = np.array(rows, dtype=np.float64).reshape(-1, 3)
    r = xyr[:, 2]
    sv = np.zeros(r.shape[0]) if svar is None else np.asarray(svar, dtype=np.float64).reshape(-1)
    return np.ascontiguousarray(np.stack([xyr[:, 0], xyr[:, 1], r, r * r, 0.5 * math.pi * r, sv]))


#: Slots of :func:`move_constants`.
_M_KD, _M_KDTH, _M_KTH, _M_KLAT, _M_STEERED, _M_FRONT, _M_L, _M_SLIP, _M_STEERQ, _M_MINROLL = range(10)
_M_CONSIDER, _M_CALIBRATED, _M_CE, _M_CB = 10, 11, 12, 13


def move_constants(
    noise: tuple[float, float, float, float], steered: tuple[bool, float, float, float, float] | None,
    consider: bool, calibrated: bool, cvar: tuple[float, float],
) -> NDArray[np.float64]:
    """The per-run constants of :func:`move_state`, packed: ``noise = (k_d, k_dtheta, k_theta, k_lateral)``
    (:func:`process_noise`), ``steered = (front, L, slip_k, steer_q, min_roll)`` (:func:`steered_noise`)
    or None, and the consider flags with ``cvar`` (:func:`calibration_predict`)."""
    front, L, slip_k, steer_q, min_roll = (False, 1.0, 0.0, 0.0, 0.0) if steered is None else steered
    return np.array([
        *noise, 0.0 if steered is None else 1.0, 1.0 if front else 0.0, L, slip_k, steer_q, min_roll,
        1.0 if consider else 0.0, 1.0 if calibrated else 0.0, *cvar,
    ], dtype=np.float64)


@jit
def move_state(
    odom: tuple[float, ...], pose: tuple[float, ...], P: Mat3, M: Mat3, X: tuple[float, ...],
    dd: float, dth: float, dl: float, mc: NDArray[np.float64],
) -> tuple[tuple[float, float, float], tuple[float, ...], Mat3, Mat3, tuple[float, ...]]:
    """One odometry increment ``(dd, dth, dl)`` (m, rad, m) of the estimator's whole state, in one call.

    The streaming estimator's ``_move``: the odometric pose and the pose moved by
    :func:`twist_step` [seed002 eq25], ``P' = F P F^T + Q`` (:func:`predict_covariance`
    [seed002 eq14]) with ``Q`` from :func:`process_noise` [seed002 eq17] or, for a steered
    wheel and ``dl == 0``, :func:`steered_noise`; for a consider filter ``M <- F M``
    (:func:`shear`) and, when calibrated, :func:`calibration_predict` of ``X = P_xc``.
    ``mc`` is :func:`move_constants`. A pose that is not finite (initialising) moves only
    ``odom``. Returns ``(odom', pose', P', M', X')``.
    """
    ox, oy, opsi, _, _ = twist_step(odom[0], odom[1], odom[2], dd, dth, dl)
    odom_n = (ox, oy, opsi)
    x, y, psi = pose[0], pose[1], pose[2]
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(psi)):
        return odom_n, pose, P, M, X
    nx, ny, npsi, f02, f12 = twist_step(x, y, psi, dd, dth, dl)
    use_steered = mc[_M_STEERED] != 0.0 and dl == 0.0
    if use_steered:
        Q, W = steered_noise(psi, dd, dth, mc[_M_FRONT] != 0.0, mc[_M_L], mc[_M_SLIP], mc[_M_STEERQ],
                             mc[_M_MINROLL])
    else:
        Q = process_noise(psi, dd, dth, mc[_M_KD], mc[_M_KDTH], mc[_M_KTH], dl, mc[_M_KLAT])
        W = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    Pn = predict_covariance(P, f02, f12, Q)
    pose_n = (nx, ny, npsi)
    if mc[_M_CONSIDER] == 0.0:
        return odom_n, pose_n, Pn, M, X
    Mn = shear(M, f02, f12)
    if not (use_steered and mc[_M_CALIBRATED] != 0.0):
        return odom_n, pose_n, Pn, Mn, X
    Pc, Xn = calibration_predict(Pn, X, f02, f12, W, (mc[_M_CE], mc[_M_CB]))
    return odom_n, pose_n, Pc, Mn, Xn


@jit
def gate_rows(
    z: float, t: float, pose: tuple[float, ...], P: Mat3, M: Mat3, C: NDArray[np.float64],
    claimed: NDArray[np.float64], sight: NDArray[np.bool_], tab: NDArray[np.float64], gc: NDArray[np.float64],
    g_start: NDArray[np.int64], g_rows: NDArray[np.int64],
) -> tuple[int, float, float, int, float, float, float, float, float]:
    """:func:`gate_one` with the :class:`~agvnav.positioning.gating.BearingIndex` pre-selection, compiled.

    Bearing ``z`` (rad) at ``t`` (s) against the map ``tab`` (:func:`gate_table`) for the pose
    ``(x, y, psi)`` and its covariance ``P`` (flat), with the constants ``gc``
    (:func:`gate_constants`: the :class:`~agvnav.positioning.gating.GateSpec`, the head
    mount, the index's grid). ``claimed (N,)`` the claim times (s), ``sight (N,)`` the
    reflectors in sight (all True without walls), and for the consider gate ``M`` and ``C``
    as :func:`gate_one`'s ``consider``. With an index the candidates are
    :func:`~agvnav.positioning.gating.grid_rows` of its grid (``g_start``, ``g_rows``), as
    :meth:`BearingIndex.candidates` computes them. Returns
    ``(index, y, nis, n_in_gate, H0, H1, H2, S, R)``: :func:`gate_one`'s result, flat.
    """
    bearing_var, max_range, gate, map_std = gc[_G_BVAR], gc[_G_RANGE], gc[_G_GATE], gc[_G_MAP_STD]
    sweep, mount_norm = gc[_G_SWEEP], gc[_G_MNORM]
    mx, my, mth = gc[_G_MX], gc[_G_MY], gc[_G_MTH]
    consider = gc[_G_CONSIDER] != 0.0
    rx, ry, r, svar = tab[0], tab[1], tab[2], tab[5]
    x, y, psi = pose
    c, s = math.cos(psi), math.sin(psi)
    px, py = x + c * mx - s * my, y + s * mx + c * my
    dpx, dpy = -s * mx - c * my, c * mx - s * my
    p00, p01, p02, p11, p12, p22 = P[0], P[1], P[2], P[4], P[5], P[8]
    trace_P = p00 + p11 + p22
    use_grid = gc[_G_GRID] != 0.0
    if use_grid:  # BearingIndex.candidates
        var_xy, var_psi = P[0] + P[4], P[8]
        a4 = 4.0 * gate * (bearing_var + 4.0 * var_psi)
        b4 = 4.0 * gate * (map_std * map_std + 2.0 * var_xy + 4.0 * mount_norm * mount_norm * var_psi)
        if consider:
            a4, b4 = 2.0 * a4, 2.0 * b4
        cand = grid_rows(g_start, g_rows, gc[_G_X0], gc[_G_Y0], gc[_G_CELL], int(gc[_G_NX]), int(gc[_G_NY]),
                         rx, ry, tab[3], tab[4], x + c * mx - s * my, y + s * mx + c * my, z + psi + mth,
                         a4, b4, max_range, gc[_G_RMAX])
        m = cand.shape[0]
    else:
        cand = g_rows
        m = rx.shape[0]
    n_in = 0
    best_j, best_y, best_nis, best_S, best_R = -1, math.nan, math.inf, math.nan, math.nan
    best_h0 = best_h1 = best_h2 = 0.0
    for i in range(m):
        j = cand[i] if use_grid else i
        if not sight[j]:
            continue
        if t - claimed[j] < sweep:
            continue
        rj = r[j]
        h, dx, dy, d2, d = edge_bearing(px, py, psi, mth, rx[j], ry[j], rj)
        if not d <= max_range:
            continue
        innov = wrap_angle_kernel(z - h)
        R = 0.0
        if not consider:
            md = map_std / d if d > 0.0 else 0.0
            R = bearing_var + md * md
            if surely_outside(innov, d2, rj, R, trace_P, mount_norm, gate, 0.0, False):
                continue
        elif surely_outside(innov, d2, rj, bearing_var, trace_P, mount_norm, gate, svar[j], True):
            continue
        h0, h1, h2 = bearing_jacobian(dx, dy, d2, d, rj, dpx, dpy)
        if consider:
            R = bearing_var + svar[j] * (h0 * h0 + h1 * h1)
        S = h0 * h0 * p00 + h1 * h1 * p11 + h2 * h2 * p22 + 2.0 * (h0 * h1 * p01 + h0 * h2 * p02 + h1 * h2 * p12) + R
        if consider:  # + 2 H P_xp,j H_p^T
            v0, v1, v2 = consider_cross(M, (C[j, 0], C[j, 1], C[j, 2]), (C[j, 3], C[j, 4], C[j, 5]), -h0, -h1)
            S += 2.0 * (h0 * v0 + h1 * v1 + h2 * v2)
        nis = innov * innov / S
        if nis < gate:
            n_in += 1
            best_j, best_y, best_nis, best_S, best_R = j, innov, nis, S, R
            best_h0, best_h1, best_h2 = h0, h1, h2
    if n_in != 1:
        return -1, math.nan, math.inf, n_in, 0.0, 0.0, 0.0, math.nan, math.nan
    return best_j, best_y, best_nis, 1, best_h0, best_h1, best_h2, best_S, best_R


@jit
def schmidt_accept(
    pose: tuple[float, ...], P: Mat3, M: Mat3, X: tuple[float, ...], C: NDArray[np.float64], j: int,
    svar_j: float, innovation: float, H: tuple[float, float, float], bearing_var: float, calibrated: bool,
    min_det: float, max_entry: float,
) -> tuple[tuple[float, float, float], Mat3, tuple[float, float, float], Mat3, tuple[float, ...], bool]:
    """The EKF's Schmidt-Kalman update of one identified bearing (:meth:`EkfEstimator._accept`), compiled.

    :func:`consider_cross`, :func:`schmidt_update`, :func:`calibration_update` (when
    ``calibrated``), ``M <- (I - K H) M`` (:func:`left_update`) and reflector ``j``'s row of
    ``C`` (updated in place) with ``M^-1 K`` (:func:`solve3`), the same operations as the
    method. When the new ``M`` needs folding (``|det M| < min_det`` or an entry above
    ``max_entry``), ``C`` is left untouched and the last item is True: the caller folds
    (a NumPy product over the map, rare) and writes row ``j`` itself. Returns
    ``(pose', P', K, M', X', fold)``.
    """
    h0, h1 = H[0], H[1]
    cx0, cx1, cx2, cy0, cy1, cy2 = C[j, 0], C[j, 1], C[j, 2], C[j, 3], C[j, 4], C[j, 5]
    v = consider_cross(M, (cx0, cx1, cx2), (cy0, cy1, cy2), -h0, -h1)
    xn, Pn, K, _ = schmidt_update(pose, P, innovation, H, bearing_var, v, svar_j * (h0 * h0 + h1 * h1))
    Xn = calibration_update(X, K, H) if calibrated else X
    Mn = left_update(M, K, H)
    det = det3(Mn)
    ok = abs(det) >= min_det
    for w in Mn:
        ok = ok and abs(w) <= max_entry
    if not ok:
        return xn, Pn, K, Mn, Xn, True
    s0, s1, s2 = solve3(Mn, K, det)  # M^-1 K
    ax, ay = h0 * svar_j, h1 * svar_j
    C[j, 0], C[j, 1], C[j, 2] = cx0 + s0 * ax, cx1 + s1 * ax, cx2 + s2 * ax
    C[j, 3], C[j, 4], C[j, 5] = cy0 + s0 * ay, cy1 + s1 * ay, cy2 + s2 * ay
    return xn, Pn, K, Mn, Xn, False


@jit
def gate_accept(
    z: float, t: float, pose: tuple[float, ...], P: Mat3, M: Mat3, X: tuple[float, ...],
    C: NDArray[np.float64], claimed: NDArray[np.float64], sight: NDArray[np.bool_], tab: NDArray[np.float64],
    gc: NDArray[np.float64], g_start: NDArray[np.int64], g_rows: NDArray[np.int64],
) -> Any:
    """:func:`gate_rows` (the consider gate) and, when it identifies a reflector, :func:`schmidt_accept`: one call.

    Arguments as :func:`gate_rows`, with ``X = P_xc`` (3x2 row-major); ``gc`` also holds the
    update's ``sigma^2``, the fold limits and whether ``P_xc`` is carried
    (:func:`gate_constants`). Returns the gate's ``(index, y, nis, n_in_gate, H0, H1, H2, S, R)``
    and :func:`schmidt_accept`'s ``(pose', P', K, M', X', fold)`` (the inputs unchanged and
    ``K = 0`` when the gate identified none). The claim time is left to the caller.
    """
    res = gate_rows(z, t, pose, P, M, C, claimed, sight, tab, gc, g_start, g_rows)
    j = res[0]
    if j < 0:
        return res, pose, P, (0.0, 0.0, 0.0), M, X, False
    xn, Pn, K, Mn, Xn, fold = schmidt_accept(
        pose, P, M, X, C, j, tab[5, j], res[1], (res[4], res[5], res[6]), gc[_G_UVAR], gc[_G_CALIBRATED] != 0.0,
        gc[_G_MIN_DET], gc[_G_MAX_ENTRY],
    )
    return res, xn, Pn, K, Mn, Xn, fold


#: The per-reflection kernels as :class:`~agvnav._jit.Kernel` objects, for their
#: :meth:`~agvnav._jit.Kernel.bound` callable in the estimators' hot path (typed: ``jit`` keeps the
#: function's signature for callers, so ``.bound`` is reached through these names).
MOVE_STATE: Kernel = cast(Kernel, move_state)
GATE_ACCEPT: Kernel = cast(Kernel, gate_accept)
