"""Which map reflector made an anonymous reflection: the chi-square gate on one bearing, and a sweep's labels.

The goniometer reports only ``(t, bearing)`` (seed 000 §2.1). With a predicted pose and
its covariance, each reflection is matched to the reflector whose predicted bearing
(:func:`agvnav.positioning.edge_bearing.bearing_model`) lies inside a chi-square gate on
the innovation, and a reflector already claimed in the current sweep cannot be claimed
again (:func:`gate_reflection`); a whole sweep is labelled at once by a global
nearest-neighbour assignment inside the gate (:func:`associate_sweep`). The streaming
estimator's association part (:mod:`agvnav.positioning.association`) runs the same gate
compiled (:func:`agvnav.positioning._fast.gate_rows`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import angle_diff
from agvnav.positioning.edge_bearing import bearing_model, measurement_variance

__all__ = ["CHI2_1DOF_999", "Association", "associate_sweep", "gate_reflection"]

#: chi-square quantile, 1 degree of freedom, probability 0.999 (gate on one bearing innovation).
CHI2_1DOF_999 = 10.827566170662733


@dataclass(frozen=True)
class Association:
    """Outcome of gating one reflection (see :func:`gate_reflection`).

    ``index`` is the map reflector row (-1 when rejected); ``nis`` the normalised innovation
    squared of the chosen reflector (inf when none); ``n_in_gate`` how many reflectors fell
    inside the gate (2 or more means the reflection was rejected as ambiguous); ``H`` the
    bearing Jacobian row, ``S`` the innovation variance and ``R`` the measurement variance.
    """

    index: int
    innovation: float
    nis: float
    n_in_gate: int
    H: NDArray[np.float64] = field(repr=False)
    S: float
    R: float

def gate_reflection(
    bearing: float,
    pose: ArrayLike,
    covariance: ArrayLike,
    mount: ArrayLike,
    reflector_xy: ArrayLike,
    radius: ArrayLike,
    bearing_var: float,
    *,
    max_range: float = np.inf,
    excluded: ArrayLike | None = None,
    gate: float = CHI2_1DOF_999,
    map_std: float = 0.0,
) -> Association:
    """Match one anonymous bearing to a map reflector with a chi-square innovation gate.

    For every reflector within ``max_range`` of the head the innovation
    ``y = wrap(z - h(x))`` and its variance ``S = H P H^T + sigma^2`` are formed; the
    reflection is accepted when exactly one reflector has ``y^2 / S < gate`` (chi-square,
    1 dof). Two or more reflectors in the gate means the prediction cannot tell them apart:
    the reflection is rejected rather than risk a wrong label. ``excluded`` (bool ``(N,)``)
    removes reflectors already claimed in the current sweep, so one sweep never gives the
    same reflector twice. ``map_std`` (m) is the survey error of a reflector position; it
    adds ``(map_std / d)^2`` to the measurement variance (returned as ``R``).
    """
    xy = np.asarray(reflector_xy, dtype=np.float64)
    P = np.asarray(covariance, dtype=np.float64)
    h, H, d = bearing_model(pose, mount, xy, radius)
    y = angle_diff(float(bearing), h)
    R = measurement_variance(bearing_var, map_std, d)
    S = np.einsum("ni,ij,nj->n", H, P, H) + R
    nis = y * y / S
    ok = d <= max_range
    if excluded is not None:
        ok &= ~np.asarray(excluded, dtype=bool)
    in_gate = ok & (nis < gate)
    n_in = int(np.count_nonzero(in_gate))
    if n_in != 1:
        return Association(-1, float("nan"), float("inf"), n_in, np.zeros(3), float("nan"), float("nan"))
    j = int(np.flatnonzero(in_gate)[0])
    return Association(j, float(y[j]), float(nis[j]), 1, H[j], float(S[j]), float(R[j]))


def associate_sweep(
    bearings: ArrayLike,
    pose: ArrayLike,
    covariance: ArrayLike,
    mount: ArrayLike,
    reflector_xy: ArrayLike,
    radius: ArrayLike,
    bearing_var: float,
    *,
    max_range: float = np.inf,
    gate: float = CHI2_1DOF_999,
    map_std: float = 0.0,
) -> NDArray[np.int64]:
    """Label all bearings ``(k,)`` of one sweep at once: ``(k,)`` reflector rows, -1 = rejected.

    A global nearest-neighbour assignment (Hungarian algorithm on the NIS) inside the
    chi-square gate, so no two reflections of the sweep claim the same reflector and
    spurious reflections that fit no reflector are left unlabelled.

    ``scipy.optimize`` (``linear_sum_assignment``) is imported here, on the first call,
    not with the module: it is about 60 % of the start-up time of ``agvnav.cli``, and
    only the start-up pose search needs it.
    """
    from scipy.optimize import linear_sum_assignment  # noqa: PLC0415 - heavy third-party import, deferred (issue 11)

    z = np.atleast_1d(np.asarray(bearings, dtype=np.float64))
    xy = np.asarray(reflector_xy, dtype=np.float64)
    h, H, d = bearing_model(pose, mount, xy, radius)
    R = measurement_variance(bearing_var, map_std, d)
    S = np.einsum("ni,ij,nj->n", H, np.asarray(covariance, dtype=np.float64), H) + R
    nis = angle_diff(z[:, None], h[None, :]) ** 2 / S[None, :]
    allowed = (nis < gate) & (d <= max_range)[None, :]
    labels = np.full(z.shape, -1, dtype=np.int64)
    if not np.any(allowed):
        return labels
    cost = np.where(allowed, nis, 1e9)
    rows, cols = linear_sum_assignment(cost)
    keep = allowed[rows, cols]
    labels[rows[keep]] = cols[keep]
    return labels
