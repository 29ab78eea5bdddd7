"""Integrity figures of a closed-loop run (issue 12 §2): what positioning did and how honest it was.

All from the recorded series, vectorised after the run:

* time and distance in each estimator status (a sample's status holds until the next);
* time the positioning guard demanded a stop (:mod:`agvnav.navigation.guard`), how many
  times, and the worst such stop (:func:`stop_episodes`): the speed then and the
  distance travelled until standstill, against the braking distance
  ``v² / (2 a_max)`` plus :data:`STOP_MARGIN_M`;
* the estimator's quality figure (minimum and percentiles) when it provides one, the
  number of reflectors behind the estimate (minimum and percentiles) and the readings
  it dropped as implausible (``n_dropped``, the count at the end of the run);
* NEES ``ε = e^T P^{-1} e`` of the full pose error ``e = x̂ − x`` (heading wrapped)
  against the reported covariance ``P``: mean, median, 95th percentile and the
  fraction above the χ²(3) 95 % point (7.815);
* silent failure: the longest stretch with status ``tracking`` while the true
  position error exceeds 5σ of the reported position covariance (Mahalanobis, 2-D)
  or 0.1 m;
* the largest true lateral error over the whole run.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import wrap_angle
from agvnav.sim.engine import STATUS_CODES

__all__ = [
    "CHI2_3_95",
    "SILENT_ERROR_M",
    "SILENT_SIGMAS",
    "STOP_MARGIN_M",
    "integrity_figures",
    "longest_run",
    "nees",
    "silent_mask",
    "stop_episodes",
]

#: 95 % point of the χ² distribution with 3 degrees of freedom.
CHI2_3_95 = 7.814727903251178
#: A tracking estimate more than this many σ (or :data:`SILENT_ERROR_M`) off the truth fails silently.
SILENT_SIGMAS = 5.0
#: A tracking estimate farther than this (m) from the truth fails silently, whatever its σ.
SILENT_ERROR_M = 0.1
#: A demanded stop is safe within the braking distance plus this margin (m).
STOP_MARGIN_M = 0.2

_COV = ("est_cov_xx", "est_cov_xy", "est_cov_xpsi", "est_cov_yy", "est_cov_ypsi", "est_cov_psipsi")


def _covariances(series: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    """``(n, 3, 3)`` reported covariances from the recorded entries."""
    xx, xy, xp, yy, yp, pp = (np.asarray(series[k], dtype=np.float64) for k in _COV)
    return np.stack([np.stack([xx, xy, xp], -1), np.stack([xy, yy, yp], -1), np.stack([xp, yp, pp], -1)], -2)


def _errors(series: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    """``(n, 3)`` estimate minus truth, heading wrapped (m, m, rad)."""
    e = np.column_stack(
        [series["est_x"] - series["x"], series["est_y"] - series["y"], series["est_psi"] - series["psi"]]
    )
    e[:, 2] = wrap_angle(e[:, 2])
    return e


def nees(errors: ArrayLike, covariances: ArrayLike) -> NDArray[np.float64]:
    """Normalised estimation error squared ``e^T P^{-1} e`` per sample, NaN where ``P`` is singular or not finite.

    ``errors (n, d)``, ``covariances (n, d, d)``.
    """
    e = np.asarray(errors, dtype=np.float64)
    P = np.asarray(covariances, dtype=np.float64)
    if e.ndim != 2 or P.shape != (*e.shape, e.shape[1]):
        raise ValueError(f"errors (n, d) and covariances (n, d, d) do not match: {e.shape}, {P.shape}")
    out = np.full(e.shape[0], np.nan)
    ok = np.all(np.isfinite(e), axis=1) & np.all(np.isfinite(P), axis=(1, 2))
    ok[ok] &= np.linalg.det(P[ok]) > 0.0
    if np.any(ok):
        sol = np.linalg.solve(P[ok], e[ok][..., None])[..., 0]
        out[ok] = np.einsum("ij,ij->i", e[ok], sol)
    return out


def silent_mask(series: dict[str, NDArray[np.float64]]) -> NDArray[np.bool_]:
    """Samples where the estimator says ``tracking`` while its position is off (see the module docstring)."""
    e = _errors(series)
    P = _covariances(series)
    d2 = nees(e[:, :2], P[:, :2, :2])
    far = np.hypot(e[:, 0], e[:, 1]) > SILENT_ERROR_M
    inconsistent = ~(d2 <= SILENT_SIGMAS**2)  # NaN (no covariance) counts as inconsistent
    tracking = np.asarray(series["est_status"]) == STATUS_CODES["tracking"]
    return np.asarray(tracking & (far | inconsistent), dtype=np.bool_)


def longest_run(t: ArrayLike, mask: ArrayLike) -> float:
    """Longest duration (s) of consecutive samples where ``mask`` holds (a sample holds until the next)."""
    tt = np.asarray(t, dtype=np.float64)
    m = np.asarray(mask, dtype=bool)
    if tt.size < 2:
        return 0.0
    dt = np.diff(tt)
    best = cur = 0.0
    for on, step in zip(m[:-1].tolist(), dt.tolist(), strict=True):
        cur = cur + step if on else 0.0
        best = max(best, cur)
    return float(best)


def _per_status(t: NDArray[np.float64], codes: NDArray[np.float64], dist: NDArray[np.float64]) -> dict[str, Any]:
    names = {v: k for k, v in STATUS_CODES.items()}
    dt, dd = np.diff(t), np.abs(np.diff(dist))
    time_in: dict[str, float] = {}
    dist_in: dict[str, float] = {}
    for code in np.unique(codes[:-1]):
        sel = codes[:-1] == code
        name = names.get(float(code), "other")
        time_in[name] = time_in.get(name, 0.0) + float(np.sum(dt[sel]))
        dist_in[name] = dist_in.get(name, 0.0) + float(np.sum(dd[sel]))
    return {"time_in_status_s": dict(sorted(time_in.items())), "distance_in_status_m": dict(sorted(dist_in.items()))}


def stop_episodes(
    t: ArrayLike, guard_level: ArrayLike, speed: ArrayLike, distance: ArrayLike, max_decel: float
) -> list[dict[str, float]]:
    """Every stop the guard demanded: ``t`` (s), ``speed`` then (m/s), ``distance`` (m), ``braking`` (m).

    An episode runs while the guard level is ``stop``; its ``distance`` is travelled from
    the demand until standstill (``speed == 0``) or until the guard releases, whichever
    comes first; ``braking = v² / (2 max_decel)`` at the speed of the step before the
    demand; ``standstill`` is 1.0 when the vehicle stood still within the episode.
    """
    tt = np.asarray(t, dtype=np.float64)
    stop = np.asarray(guard_level, dtype=np.float64) >= 2.0
    v = np.abs(np.asarray(speed, dtype=np.float64))
    d = np.asarray(distance, dtype=np.float64)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], stop.astype(np.int8), [0]])))
    out = []
    for k0, k1 in zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True):
        v0 = float(v[k0 - 1]) if k0 > 0 else float(v[k0])
        still = np.flatnonzero(v[k0:k1] == 0.0)
        k_end = k0 + int(still[0]) if still.size else k1 - 1
        out.append({
            "t": float(tt[k0]),
            "speed": v0,
            "distance": float(abs(d[k_end] - d[k0])),
            "braking": v0 * v0 / (2.0 * max_decel),
            "standstill": float(still.size > 0),
        })
    return out


def _stop_figures(
    series: dict[str, NDArray[np.float64]], dist: NDArray[np.float64], max_decel: float
) -> dict[str, Any]:
    """Time stopped for positioning and the worst demanded stop (largest distance beyond braking)."""
    t = series["t"]
    level = np.asarray(series["guard_level"])
    episodes = stop_episodes(t, level, series["v_cmd"], dist, max_decel)
    out: dict[str, Any] = {
        "time_stopped_for_positioning_s": float(np.sum(np.diff(t)[level[:-1] >= 2.0])),
        "stop_demands": len(episodes),
        "first_stop_demand_s": episodes[0]["t"] if episodes else None,
        "speed_at_stop_demand_m_s": None,
        "distance_to_stop_m": None,
        "braking_distance_m": None,
        "stops_within_braking_distance": None,
    }
    if episodes:
        worst = max(episodes, key=lambda e: e["distance"] - e["braking"])
        out.update(
            speed_at_stop_demand_m_s=worst["speed"],
            distance_to_stop_m=worst["distance"],
            braking_distance_m=worst["braking"],
            stops_within_braking_distance=bool(worst["distance"] <= worst["braking"] + STOP_MARGIN_M),
        )
    return out


def _percentiles(values: NDArray[np.float64], prefix: str) -> dict[str, float | None]:
    v = values[np.isfinite(values)]
    keys = (f"{prefix}_min", f"{prefix}_p5", f"{prefix}_p50", f"{prefix}_p95")
    if v.size == 0:
        return dict.fromkeys(keys)
    return dict(zip(keys, (float(np.min(v)), *(float(np.percentile(v, q)) for q in (5, 50, 95))), strict=True))


def _column(series: dict[str, NDArray[np.float64]], name: str) -> NDArray[np.float64]:
    """``series[name]`` as floats, all NaN when the run did not record it."""
    if name in series:
        return np.asarray(series[name], dtype=np.float64)
    return np.full(np.shape(series["t"]), np.nan)


def _last_count(values: NDArray[np.float64]) -> int | None:
    """The last finite value of a running count as an int (None if none was recorded)."""
    v = values[np.isfinite(values)]
    return int(v[-1]) if v.size else None


def _nees_figures(series: dict[str, NDArray[np.float64]]) -> dict[str, Any]:
    eps = nees(_errors(series), _covariances(series))
    eps = eps[np.isfinite(eps)]
    if eps.size == 0:
        return {"nees_mean": None, "nees_median": None, "nees_p95": None, "nees_above_chi2_95": None, "nees_samples": 0}
    return {
        "nees_mean": float(np.mean(eps)),
        "nees_median": float(np.median(eps)),
        "nees_p95": float(np.percentile(eps, 95)),
        "nees_above_chi2_95": float(np.mean(eps > CHI2_3_95)),
        "nees_samples": int(eps.size),
    }


def integrity_figures(
    series: dict[str, NDArray[np.float64]], distance: ArrayLike, max_decel: float
) -> dict[str, Any]:
    """The integrity section of metrics.json (see the module docstring); JSON-ready.

    ``series`` needs ``t``, the true and estimated poses, ``est_status``,
    ``lateral_error``, ``v_cmd`` and the guard's signals (:data:`agvnav.navigation.guard.GUARD_SIGNALS`);
    ``distance (n,)`` in m, ``max_decel`` the vehicle's deceleration limit (m/s²).
    """
    t = np.asarray(series["t"], dtype=np.float64)
    dist = np.asarray(distance, dtype=np.float64)
    lat = np.abs(np.asarray(series["lateral_error"], dtype=np.float64))
    out: dict[str, Any] = {
        "max_true_lateral_error_m": float(np.nanmax(lat)) if np.any(np.isfinite(lat)) else None,
        **_per_status(t, np.asarray(series["est_status"]), dist),
        **_stop_figures(series, dist, max_decel),
        **_percentiles(np.asarray(series["est_quality"], dtype=np.float64), "quality"),
        **_percentiles(_column(series, "est_reflectors_used"), "reflectors_used"),
        "n_dropped": _last_count(_column(series, "est_n_dropped")),
        **_nees_figures(series),
        "longest_silent_failure_s": longest_run(t, silent_mask(series)),
    }
    for key, value in out.items():
        if isinstance(value, float) and not math.isfinite(value):
            out[key] = None
    return out
