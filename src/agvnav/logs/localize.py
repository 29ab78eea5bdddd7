"""Run a positioning method on a recorded log (``agvnav localize``), fed as the simulator feeds it.

For each odometry interval ``(t_k, t_{k+1}]`` the reflections arriving in it are
delivered in time order, each after the odometry increment up to its arrival
(the interval's increment split in proportion to time), then the rest of the
increment up to ``t_{k+1}``: the same splitting as :class:`agvnav.sim.engine.ClosedLoop`,
so a simulated run's log replays to the simulation's estimate. A bearing is
delivered with its stamp (the measurement instant); an estimator that refuses a
stamp older than its own time (a late reflection) raises ValueError, which is
counted as ``late_rejected`` as in the simulator.

A localization is judged before it is reported (:func:`judge`): it failed when the
estimator tracked less than :data:`MIN_TRACKING_SHARE` of the log's duration or used
fewer than :data:`MIN_REFLECTIONS_USED_SHARE` of its reflections; with a recorded truth,
tracking counts only while the estimate is within :data:`TRUTH_TOLERANCE_M` of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.logs.reader import RecordedLog
from agvnav.logs.runlog import COV_COLUMNS
from agvnav.logs.settings import check_settings
from agvnav.odometry import OdometryNoise, SteeredOdometryNoise
from agvnav.positioning import ESTIMATOR_METHODS, make_estimator
from agvnav.sim.engine import STATUS_CODES

__all__ = [
    "MIN_REFLECTIONS_USED_SHARE",
    "MIN_TRACKING_SHARE",
    "TRUTH_TOLERANCE_M",
    "Localization",
    "Verdict",
    "estimator_from_settings",
    "judge",
    "localize",
]

F64 = NDArray[np.float64]

#: Least share of the log's duration (0-1) the estimator must spend tracking for a localization to pass.
MIN_TRACKING_SHARE = 0.5
#: Least share (0-1) of the log's reflections the estimator must use (accept) for a localization to pass.
MIN_REFLECTIONS_USED_SHARE = 0.5
#: With a recorded truth, tracking counts only while the estimated position is within this of it (m):
#: the tolerance simulate judges a run's end on (:data:`agvnav.sim.run.END_TOLERANCE_M`).
TRUTH_TOLERANCE_M = 0.1


@dataclass
class Localization:
    """The estimate along a log: ``series`` columns ``t``, ``est_x``, ``est_y``, ``est_psi``, ``est_status``,
    the ``est_cov_*`` columns, ``est_quality`` (0-1) and ``est_reflectors_used`` (NaN when the estimator
    reports none), one row per odometry instant; and the counts of reflections."""

    series: dict[str, F64]
    method: str
    n_reflections: int
    n_accepted: int
    late_rejected: int
    ignored_before_start: int


def estimator_from_settings(settings: dict[str, Any], world: Any, method: str | None = None) -> Any:
    """A streaming estimator (:func:`agvnav.positioning.make_estimator`) from a log's settings document.

    ``method`` overrides the document's. Keys (SI, rad): ``mount`` [x, y, yaw], ``initial_pose``
    [x, y, psi], ``initial_covariance`` 3x3, ``pulses_per_rev``, ``rate_hz``, ``max_range_m``,
    ``map_std_m``, ``odometry_noise`` [k_d, k_dtheta, k_theta] (:class:`agvnav.odometry.OdometryNoise`)
    or ``wheel_odometry`` (the fields of :class:`agvnav.odometry.SteeredOdometryNoise`),
    ``bearing_offset`` (rad), ``params`` (further estimator keywords). Missing keys take the
    estimator's defaults; an unknown key, or an angle beyond 2π (degrees), is a ValueError
    (:func:`agvnav.logs.settings.check_settings`).
    """
    check_settings(settings)
    name = method or settings.get("method") or "ekf"
    if name not in ESTIMATOR_METHODS:
        raise ValueError(f"unknown positioning method {name!r} for a log; choose one of {list(ESTIMATOR_METHODS)}")
    kwargs: dict[str, Any] = {}
    for key, arg in (("initial_pose", "initial_pose"), ("initial_covariance", "initial_covariance"),
                     ("pulses_per_rev", "pulses_per_rev"), ("rate_hz", "rate_hz"), ("max_range_m", "max_range"),
                     ("map_std_m", "map_std"), ("bearing_offset", "bearing_offset")):
        if settings.get(key) is not None:
            kwargs[arg] = settings[key]
    if settings.get("odometry_noise") is not None:
        kwargs["odometry_noise"] = OdometryNoise(*settings["odometry_noise"])
    if settings.get("wheel_odometry") is not None:
        wheel = {k: v for k, v in settings["wheel_odometry"].items() if v is not None}
        kwargs["odometry_noise"] = SteeredOdometryNoise(**wheel)
    params = settings.get("params") or {}
    mount = settings.get("mount") or (0.0, 0.0, 0.0)
    try:
        return make_estimator(name, world, mount, **{**kwargs, **params})
    except TypeError as exc:  # a key of params the estimator does not take
        if not params:
            raise
        raise ValueError(f"settings params {sorted(params)}: not all are {name} estimator keywords ({exc})") from None


def localize(log: RecordedLog, estimator: Any, method: str = "") -> Localization:
    """Feed ``log`` to ``estimator`` (see the module docstring) and record its estimate at every odometry instant."""
    t, inc = log.t, log.increments
    rt, stamps, bearings = log.reflection_t.tolist(), log.reflection_stamp.tolist(), log.bearing.tolist()
    j, m = 0, len(rt)
    while j < m and rt[j] <= t[0]:
        j += 1
    skipped, late = j, 0
    rows = [_row(float(t[0]), estimator)]
    for k in range(inc.shape[0]):
        t0, t1 = float(t[k]), float(t[k + 1])
        dt = t1 - t0
        dd, dth, dl = inc[k].tolist()
        t_prev = t0
        while j < m and rt[j] <= t1:
            frac = (rt[j] - t_prev) / dt
            estimator.predict(rt[j], dd * frac, dth * frac, dl * frac)
            try:
                estimator.update(stamps[j], bearings[j])
            except ValueError:
                late += 1
            t_prev = rt[j]
            j += 1
        frac = (t1 - t_prev) / dt
        estimator.predict(t1, dd * frac, dth * frac, dl * frac)
        rows.append(_row(t1, estimator))
    names = ("t", "est_x", "est_y", "est_psi", "est_status", *COV_COLUMNS, "est_quality", "est_reflectors_used")
    data = np.array(rows, dtype=np.float64)
    series = {n: data[:, i].copy() for i, n in enumerate(names)}
    return Localization(series, method or getattr(estimator, "method", ""), m, int(getattr(estimator, "n_accepted", 0)),
                        late, skipped)


@dataclass(frozen=True)
class Verdict:
    """How far a localization can be trusted, and whether it failed.

    ``tracking_s`` (s): the time the estimator reported tracking (with truth: and was within
    :data:`TRUTH_TOLERANCE_M` of it); ``tracking_share`` (0-1): that time over the log's duration;
    ``reflections_used_share`` (0-1): accepted over all reflections of the log;
    ``tracking_off_truth_s`` (s, None without truth): time reported tracking but beyond the tolerance;
    ``outcome`` ``"completed"`` or ``"failed"``, with a one-line ``reason`` when failed.
    """

    tracking_s: float
    tracking_share: float
    reflections_used_share: float
    tracking_off_truth_s: float | None
    outcome: str
    reason: str | None


def judge(loc: Localization, log: RecordedLog) -> Verdict:
    """Judge ``loc`` (the estimate along ``log``) on its tracking time and reflections used, on the truth if any.

    The state recorded at odometry instant ``t[k]`` holds over the interval ``(t[k-1], t[k]]``; the shares
    are time-weighted. Fails below :data:`MIN_TRACKING_SHARE` or :data:`MIN_REFLECTIONS_USED_SHARE`.
    """
    s = loc.series
    dt = np.diff(s["t"])
    duration = float(np.sum(dt))
    tracking = s["est_status"][1:] == 1.0
    off_truth_s = None
    if log.truth is not None:
        err = np.hypot(s["est_x"][1:] - log.truth[1:, 0], s["est_y"][1:] - log.truth[1:, 1])
        near = np.isfinite(err) & (err <= TRUTH_TOLERANCE_M)
        off_truth_s = float(np.sum(dt[tracking & ~near]))
        tracking = tracking & near
    tracking_s = float(np.sum(dt[tracking]))
    share = tracking_s / duration if duration > 0 else 0.0
    used = loc.n_accepted / loc.n_reflections if loc.n_reflections else 0.0
    problems = []
    if share < MIN_TRACKING_SHARE:
        truth = f" within {TRUTH_TOLERANCE_M:g} m of the truth" if log.truth is not None else ""
        problems.append(f"tracked {100 * share:.0f} % of the log{truth} ({tracking_s:.1f} of {duration:.1f} s; "
                        f"{100 * MIN_TRACKING_SHARE:.0f} % needed)")
    if used < MIN_REFLECTIONS_USED_SHARE:
        problems.append(f"used {loc.n_accepted} of {loc.n_reflections} reflections ({100 * used:.0f} %; "
                        f"{100 * MIN_REFLECTIONS_USED_SHARE:.0f} % needed)")
    if not problems:
        return Verdict(tracking_s, share, used, off_truth_s, "completed", None)
    reason = "; ".join(problems) + ": check the settings (start pose, mount), the map and the units"
    return Verdict(tracking_s, share, used, off_truth_s, "failed", reason)


def _row(t: float, est: Any) -> tuple[float, ...]:
    x, y, psi = np.asarray(est.pose, dtype=np.float64).tolist()
    c = np.asarray(est.covariance, dtype=np.float64)
    cov = (c[0, 0], c[0, 1], c[0, 2], c[1, 1], c[1, 2], c[2, 2])
    extra = (_optional(est, "quality"), _optional(est, "reflectors_used"))
    return (t, x, y, psi, STATUS_CODES.get(est.status, -1.0), *(float(v) for v in cov), *extra)


def _optional(est: Any, name: str) -> float:
    """A figure some estimators report (quality 0-1, reflectors used); NaN when this one reports none."""
    value = getattr(est, name, None)
    return math.nan if value is None else float(value)
