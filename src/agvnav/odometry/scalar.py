"""Scalar fast paths of the odometry increments for one vehicle in a hot loop.

Same equations as the vectorised kernels of :mod:`agvnav.odometry.increments` in
``math``, without NumPy's per-call overhead; ``tests/odometry/test_odometry_fast.py`` checks
each against the kernel (or the vehicle model) it mirrors.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from agvnav.kinematics.differential import body_speeds_unchecked


def tricycle_increments_scalar(ds_c: float, gamma: float, wheelbase: float) -> tuple[float, float]:
    """Scalar fast path of :func:`agvnav.odometry.tricycle_increments` ([seed000 eq8] over a step).

    ``ΔD = ds_C cos γ``, ``Δθ = ds_C sin γ / L`` (m, rad). Like the kernel, refuses a
    steering angle at or beyond ±90° (seed 000 §3.1) or a NaN/inf input (ValueError).
    """
    if not (math.isfinite(ds_c) and abs(gamma) < 0.5 * math.pi):
        raise ValueError(f"tricycle increments need finite ds_c and |gamma| < 90 deg, got {ds_c!r}, {gamma!r}")
    return ds_c * math.cos(gamma), ds_c * math.sin(gamma) / wheelbase


def track_increments(ds_right: float, ds_left: float, twist_matrix: Sequence[Sequence[float]]) -> tuple[float, float]:
    """``(ΔD, Δθ)`` of a tracked/differential base from the track distances (m) of one step.

    [seed004 eq3] [seed004 eq4] [seed004 eq5] generalised to the ICR slip model: the
    increments are the rows ``v_x`` and ``omega`` of the model's twist matrix ``T (3, 2)`` (of
    :attr:`agvnav.kinematics.TrackedVehicle.twist_matrix`) applied to ``[ds_R, ds_L]``.
    With no slip and the ICRs at the tracks it is [seed002 eq16]
    (:func:`differential_increments_scalar`).
    """
    t0, t2 = twist_matrix[0], twist_matrix[2]
    return t0[0] * ds_right + t0[1] * ds_left, t2[0] * ds_right + t2[1] * ds_left


def differential_increments_scalar(d_right: float, d_left: float, track: float) -> tuple[float, float]:
    """Scalar fast path of :func:`agvnav.odometry.differential_increments` [seed002 eq16].

    ``ΔD = (ΔD_R + ΔD_L)/2`` (m), ``Δθ = (ΔD_R − ΔD_L)/L`` (rad) from the wheel distances
    ``d_right``, ``d_left`` (m) of one step, through the one differential-drive formulation
    :func:`agvnav.kinematics.body_speeds_unchecked`. Like the kernel, refuses a non-positive
    track or a NaN/inf distance (ValueError).
    """
    if not (math.isfinite(d_right) and math.isfinite(d_left)):
        raise ValueError(f"differential increments need finite d_right, d_left, got {d_right!r}, {d_left!r}")
    if not 0.0 < track < math.inf:
        raise ValueError(f"track must be a positive finite length (m), got {track!r}")
    return body_speeds_unchecked(d_right, d_left, track)
