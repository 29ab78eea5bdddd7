"""Metrics of a closed-loop run, computed from the recorded series.

The *initial transient* is defined objectively (and the same way for every
controller, so the benchmark compares like with like):

- the settling band is ``band = max(band_fraction * |eps_c(0)|, band_floor_m)``
  (defaults 10 % of the initial lateral error and 5 mm);
- the transient ends at the **first** sample where ``|eps_c| <= band``.

"First enters" rather than "enters and stays" is deliberate: with "stays", the
maximum error after the transient could never exceed the band, so the figure the
seed quotes (max ``|eps_c|`` of 16.5 mm after correcting the initial 110 mm,
seed 000 §4.3, Fig. 11) would be decided by the band, not by the controller.
Here any overshoot, and the disturbance when the path curvature jumps, count
against the post-transient figures.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import lateral_position_error, wrap_angle


@dataclass(frozen=True)
class TransientSpec:
    """How the end of the initial transient is found (see the module docstring)."""

    band_fraction: float = 0.1
    band_floor_m: float = 0.005

    def band(self, initial_lateral_error_m: float) -> float:
        """Settling band (m) for an initial lateral error (m)."""
        return max(self.band_fraction * abs(initial_lateral_error_m), self.band_floor_m)


def transient_end_index(lateral_error: ArrayLike, spec: TransientSpec = TransientSpec()) -> int | None:
    """Index of the first sample with ``|eps_c| <= band``; None if it never settles.

    ``lateral_error`` is ``(n,)`` in metres; NaN samples never count as settled.
    """
    e = np.asarray(lateral_error, dtype=np.float64)
    if e.ndim != 1 or e.size == 0:
        raise ValueError(f"lateral_error must be a non-empty 1-D array, got shape {e.shape}")
    band = spec.band(float(e[0]) if np.isfinite(e[0]) else 0.0)
    inside = np.flatnonzero(np.abs(e) <= band)
    return int(inside[0]) if inside.size else None


def _nan_to_none(value: float) -> float | None:
    return None if not math.isfinite(value) else float(value)


@dataclass(frozen=True)
class RunMetrics:
    """The figures of one run; every field is in SI units, None when undefined."""

    max_abs_lateral_error_m: float | None
    rms_lateral_error_m: float | None
    max_abs_wheel_heading_error_rad: float | None
    settling_distance_m: float | None
    settling_time_s: float | None
    initial_lateral_error_m: float
    settling_band_m: float
    positioning_rms_m: float | None
    positioning_max_m: float | None
    positioning_rms_heading_rad: float | None
    positioning_lateral_mean_abs_m: float | None
    positioning_lateral_std_m: float | None
    positioning_lateral_max_abs_m: float | None
    path_completed: bool
    distance_travelled_m: float
    sim_time_s: float
    wall_time_s: float
    real_time_factor: float | None
    steps: int
    reflections: int

    def to_dict(self) -> dict[str, float | int | bool | None]:
        """A JSON-ready mapping (the content of metrics.json)."""
        return asdict(self)


def compute_metrics(
    t: ArrayLike,
    lateral_error: ArrayLike,
    wheel_heading_error: ArrayLike,
    distance: ArrayLike,
    true_pose: ArrayLike,
    est_pose: ArrayLike,
    est_valid: ArrayLike,
    *,
    path_completed: bool,
    wall_time_s: float,
    reflections: int = 0,
    spec: TransientSpec = TransientSpec(),
) -> RunMetrics:
    """Metrics of a run from its recorded series.

    Parameters
    ----------
    t : (n,) s
        Sample instants.
    lateral_error : (n,) m
        True lateral error ``eps_c`` of the guided point (seed 000 Fig. 5).
    wheel_heading_error : (n,) rad
        True wheel heading error ``xi_r`` (seed 000 eq. 9).
    distance : (n,) m
        Distance travelled by the guided point since the start.
    true_pose, est_pose : (n, 3)
        True and estimated base_link poses.
    est_valid : (n,) bool
        Samples where the estimator has a fix (positioning figures use only these).
    path_completed, wall_time_s, reflections
        Run facts copied into the result.
    spec
        The transient definition (module docstring).
    """
    t = np.asarray(t, dtype=np.float64)
    e = np.asarray(lateral_error, dtype=np.float64)
    xr = wrap_angle(np.asarray(wheel_heading_error, dtype=np.float64))
    dist = np.asarray(distance, dtype=np.float64)
    if not (t.shape == e.shape == xr.shape == dist.shape) or t.ndim != 1:
        raise ValueError("t, lateral_error, wheel_heading_error and distance must share one 1-D shape")
    k0 = transient_end_index(e, spec)
    if k0 is None:
        max_e = rms_e = max_xr = settle_d = settle_t = math.nan
    else:
        tail_e, tail_xr = e[k0:], xr[k0:]
        max_e = float(np.nanmax(np.abs(tail_e)))
        rms_e = float(np.sqrt(np.nanmean(tail_e**2)))
        max_xr = float(np.nanmax(np.abs(tail_xr)))
        settle_d, settle_t = float(dist[k0]), float(t[k0] - t[0])
    pos = _positioning_figures(true_pose, est_pose, est_valid)
    sim_time = float(t[-1] - t[0])
    return RunMetrics(
        max_abs_lateral_error_m=_nan_to_none(max_e),
        rms_lateral_error_m=_nan_to_none(rms_e),
        max_abs_wheel_heading_error_rad=_nan_to_none(max_xr),
        settling_distance_m=_nan_to_none(settle_d),
        settling_time_s=_nan_to_none(settle_t),
        initial_lateral_error_m=float(e[0]),
        settling_band_m=spec.band(float(e[0])),
        **pos,
        path_completed=bool(path_completed),
        distance_travelled_m=float(dist[-1]),
        sim_time_s=sim_time,
        wall_time_s=float(wall_time_s),
        real_time_factor=_nan_to_none(sim_time / wall_time_s) if wall_time_s > 0 else None,
        steps=int(t.size - 1),
        reflections=int(reflections),
    )


def _positioning_figures(true_pose: ArrayLike, est_pose: ArrayLike, est_valid: ArrayLike) -> dict[str, float | None]:
    p = np.asarray(true_pose, dtype=np.float64)
    q = np.asarray(est_pose, dtype=np.float64)
    ok = np.asarray(est_valid, dtype=bool) & np.all(np.isfinite(q), axis=-1)
    names = (
        "positioning_rms_m",
        "positioning_max_m",
        "positioning_rms_heading_rad",
        "positioning_lateral_mean_abs_m",
        "positioning_lateral_std_m",
        "positioning_lateral_max_abs_m",
    )
    if not np.any(ok):
        return dict.fromkeys(names)
    p, q = p[ok], q[ok]
    d = np.hypot(q[:, 0] - p[:, 0], q[:, 1] - p[:, 1])
    dh = wrap_angle(q[:, 2] - p[:, 2])
    lat = lateral_position_error(p, q)
    values = (
        np.sqrt(np.mean(d**2)),
        np.max(d),
        np.sqrt(np.mean(dh**2)),
        np.mean(np.abs(lat)),
        np.std(lat),
        np.max(np.abs(lat)),
    )
    return {n: float(v) for n, v in zip(names, values, strict=True)}
