"""Adversarial input sequences for the streaming estimators, and the check made after every call (issue 29).

A sequence is a list of calls: odometry increments, reflections of a real reflector seen from
the estimate (so that updates are accepted and the covariance updates run), arbitrary bearings,
and, for the wall-landmark localizer, ultrasonic readings. Every number may be wild: NaN, +-inf,
1e300, -1e6, a backward or huge time step. :func:`drive` feeds one sequence to a running
estimator (``strict=False``) and returns the first broken state it sees, or None.

Broken: a usable status (``tracking``, ``degraded``, ``dead_reckoning``) with a non-finite pose,
a covariance that is not finite, symmetric and positive definite (Cholesky), or a pose farther
than :data:`FAR_M` from the map; or any exception (a running vehicle drops a bad reading, it
never aborts).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from hypothesis import strategies as st

from agvnav.positioning import make_estimator
from agvnav.positioning.edge_bearing import bearing_model
from agvnav.positioning.wall_landmarks import WallLandmarkLocalizer
from agvnav.sensors import seed_004_layout
from agvnav.world import load_builtin_map

USABLE = ("tracking", "degraded", "dead_reckoning")
#: Streaming methods under test: the four of make_estimator and the tracked robot's localizer.
METHODS = ("naive", "angle_propagation", "batch_ml", "ekf", "wall_landmarks")
MOUNT = np.array([0.3, 0.0, 0.0])
START = np.array([4.0, 3.0, 0.3])
#: A usable pose farther than this (m) from the map's bounding box is broken. The default limits
#: (3 m/s, 10 s largest gap) allow the first increment 30 m and each later one of <= 0.1 s 0.31 m:
#: under 60 m in the longest sequence drawn here.
FAR_M = 200.0
#: The tracked robot's corridor (seed 004): a wall each side and one across, ahead.
CORRIDOR = np.array([[[-3.0, -0.55], [6.0, -0.55]], [[6.0, 0.5], [-3.0, 0.5]], [[1.0, -2.0], [1.0, 2.0]]])
LAYOUT = seed_004_layout()
LAB = load_builtin_map("lab")

WILD = (math.nan, math.inf, -math.inf, 1e300, -1e300, 1e6, -1e6, 5e-324, -0.0)
wild = st.sampled_from(WILD)
#: Time steps (s): ordinary ones, none, backward ones, huge ones and non-finite ones.
dts = st.one_of(st.floats(0.0, 0.1), st.sampled_from((0.0, -0.05, -1.0, -1e6, 30.0, 1e3, 1e6, 1e300)), wild)
#: Odometry increments (m or rad): ordinary, plausible at 0.1 s, too large, or wild.
increments = st.one_of(st.floats(-0.3, 0.3), st.floats(-0.02, 0.02), st.floats(-100.0, 100.0), wild)

odometry = st.tuples(st.just("odometry"), dts, increments, increments, st.one_of(st.just(0.0), increments))
#: A reflection of reflector ``j`` as seen from the estimate, with a bearing error (rad).
reflection = st.tuples(st.just("reflection"), dts, st.integers(0, 8),
                       st.one_of(st.floats(-0.002, 0.002), st.floats(-0.5, 0.5), wild))
bearing = st.tuples(st.just("bearing"), dts, st.one_of(st.floats(-10.0, 10.0), wild))
#: Five ultrasonic ranges (m), each as predicted from the estimate plus an error, or wild.
ranges = st.tuples(st.just("ranges"), dts,
                   st.lists(st.one_of(st.floats(-0.05, 0.05), wild), min_size=5, max_size=5))


def sequences(method: str, max_size: int = 60) -> st.SearchStrategy[list[tuple[Any, ...]]]:
    """Lists of calls for ``method``: odometry and reflections, or odometry and ranges (wall_landmarks)."""
    if method == "wall_landmarks":
        call = st.one_of(odometry, ranges)
    else:
        call = st.one_of(odometry, reflection, reflection, bearing)
    return st.lists(call, min_size=1, max_size=max_size)


def build(method: str) -> Any:
    """A running estimator (drops bad readings) at :data:`START` for ``method``."""
    if method == "wall_landmarks":
        return WallLandmarkLocalizer(CORRIDOR, LAYOUT, pose=(0.0, 0.0, 0.0), strict=False)
    return make_estimator(method, LAB, MOUNT, initial_pose=START, strict=False)


def broken(est: Any, method: str) -> str | None:
    """Why the estimator's reported state is broken, or None (see the module docstring)."""
    status = est.status
    if status not in USABLE:
        return None
    x = np.asarray(est.pose, dtype=np.float64)
    P = np.asarray(est.covariance, dtype=np.float64)
    if x.shape != (3,) or not np.all(np.isfinite(x)):
        return f"{status} with pose {x}"
    if P.shape != (3, 3) or not np.all(np.isfinite(P)):
        return f"{status} with covariance {P.tolist()}"
    if not np.allclose(P, P.T, rtol=1e-9, atol=1e-12 * float(np.max(np.abs(P)))):
        return f"{status} with an asymmetric covariance {P.tolist()}"
    try:
        np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        return f"{status} with a covariance not positive definite {P.tolist()}"
    walls = CORRIDOR if method == "wall_landmarks" else LAB.reflector_xy
    lo, hi = walls.reshape(-1, 2).min(axis=0), walls.reshape(-1, 2).max(axis=0)
    off = np.maximum(np.maximum(lo - x[:2], x[:2] - hi), 0.0)
    if math.hypot(*off) > FAR_M:
        return f"{status} with pose {x.tolist()}, {math.hypot(*off):.3g} m off the map"
    return None


def _call(est: Any, method: str, t: float, call: tuple[Any, ...]) -> None:
    kind = call[0]
    if kind == "odometry":
        est.predict(t, *call[2:])
    elif kind == "reflection":
        x = np.asarray(est.pose, dtype=np.float64)
        if np.all(np.isfinite(x)):
            h, _, _ = bearing_model(x, MOUNT, LAB.reflector_xy[call[2]], LAB.reflector_radius[call[2]])
            z = float(h) - est.bearing_offset + call[3]
        else:
            z = call[3]
        est.update(t, z)
    elif kind == "bearing":
        est.update(t, call[2])
    else:  # ranges
        x = np.asarray(est.pose, dtype=np.float64)
        echo = LAYOUT.echo(x, CORRIDOR) if np.all(np.isfinite(x)) else None
        values = {}
        for i, name in enumerate(LAYOUT.names):
            r = math.nan if echo is None else float(echo.range[i])
            values[name] = r + call[2][i] if math.isfinite(call[2][i]) and abs(call[2][i]) < 1.0 else call[2][i]
        est.update_ranges(t, values)


def drive(method: str, calls: list[tuple[Any, ...]]) -> str | None:
    """Feed ``calls`` to a new running estimator; the first broken state (with the call number), or None."""
    est = build(method)
    t = 0.0
    for k, call in enumerate(calls):
        t_call = t + call[1]
        try:
            _call(est, method, t_call, call)
        except Exception as exc:  # any exception is a finding here
            return f"call {k} {call!r} raised {type(exc).__name__}: {exc}"
        why = broken(est, method)
        if why is not None:
            return f"after call {k} {call!r}: {why}"
        if math.isfinite(t_call) and t_call > t:
            t = t_call
    return None
