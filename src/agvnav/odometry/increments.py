"""Odometry increments ``(ΔD, Δθ)`` of the vehicle reference point from encoder distances."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_positive
from agvnav.kinematics.base import scalar_inputs_or_flag
from agvnav.kinematics.differential import body_speeds_unchecked, wheel_speeds_unchecked

FloatArray = NDArray[np.float64]


def differential_increments(d_right: ArrayLike, d_left: ArrayLike, track: float) -> tuple[FloatArray, FloatArray]:
    """``ΔD = (ΔD_R + ΔD_L)/2``, ``Δθ = (ΔD_R − ΔD_L)/L`` [seed002 eq16]; distances in m, track L in m.

    The differential-drive equations of :func:`agvnav.kinematics.body_speeds_unchecked` on
    distances instead of speeds. On the wheel distances of a translation T followed by a
    rotation it gives ``ΔD = T`` [seed002 eq19]; on an arc of radius R, ``ΔD = Δθ R`` [seed002 eq22].

    ``track`` must be positive (ValueError). Scalar distances that are NaN/inf raise a
    ValueError naming them; in a batch the bad elements come out NaN (the flag) and never
    touch neighbours.
    """
    track = require_positive("track", track)
    (dr, dl), _ = scalar_inputs_or_flag(d_right=d_right, d_left=d_left)
    return body_speeds_unchecked(dr, dl, track)


def differential_wheel_distances(
    delta_d: ArrayLike, delta_theta: ArrayLike, track: float
) -> tuple[FloatArray, FloatArray]:
    """Inverse of [seed002 eq16]: ``ΔD_R = ΔD ± Δθ L/2`` [seed002 eq18] [seed002 eq21].

    :func:`agvnav.kinematics.wheel_speeds_unchecked` on increments (m, rad); ``track`` L (m)
    must be positive (ValueError).
    """
    track = require_positive("track", track)
    dd = np.asarray(delta_d, dtype=np.float64)
    return wheel_speeds_unchecked(dd, np.asarray(delta_theta, dtype=np.float64), track)


def tricycle_increments(ds_c: ArrayLike, gamma: ArrayLike, wheelbase: float) -> tuple[FloatArray, FloatArray]:
    """Increments of O from the distance rolled by the drive wheel C and the steering angle γ.

    ``ΔD = ds_C cos γ``, ``Δθ = ds_C sin γ / L`` ([seed000 eq8] integrated over
    the step); pass the mid-step γ (mean of the readings at both ends), which
    makes the increments second-order accurate while γ changes.

    ``wheelbase`` must be positive (ValueError). The stacker's steering range is
    −90° < γ < 90° (seed 000 §3.1): a scalar γ at/beyond ±90° or a NaN/inf input raises a
    ValueError naming it; in a batch those elements come out NaN (the flag).
    """
    wheelbase = require_positive("wheelbase", wheelbase)
    (ds, g), ok = scalar_inputs_or_flag(angles={"gamma": gamma}, ds_c=ds_c)
    g = np.where(ok, g, np.nan)
    return ds * np.cos(g), ds * np.sin(g) / wheelbase
