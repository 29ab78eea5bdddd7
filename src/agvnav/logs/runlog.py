"""A simulated run as an MCAP log of ROS 2 messages (``agvnav simulate --log run.mcap``).

One message per topic and recorded step (see :mod:`agvnav.logs.topics`), one per
goniometer reflection on the reflection topics, and the static parts (mount,
path, reflector map, positioning settings) once at t = 0. The odometry frame is
the vehicle's start pose; ``odom -> base_link`` is the wheel odometry integrated
with the midpoint heading, and ``map -> odom`` the estimate composed with that
odometry's inverse (REP-105).

The odometry increments ride in ``/odom``'s twist (increment / step), so a log
can be replayed through an estimator exactly as the simulator fed it
(:func:`agvnav.logs.localize.localize`); this needs every step recorded
(runs up to :data:`agvnav.sim.engine.MAX_RECORDED_ROWS` steps).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import compose, inverse
from agvnav.logs import topics as tp
from agvnav.logs.messages import covariance6, header, planar_pose, transform, vector3
from agvnav.logs.writer import LogWriter
from agvnav.odometry import WHEEL_ODOMETRY_KEYS
from agvnav.sim.build import odometry_noise
from agvnav.world import builtin_map_names

if TYPE_CHECKING:
    from agvnav.sim.run import SimResult
    from agvnav.world import WorldMap
    from agvnav.world.scenario import Scenario

__all__ = [
    "COV_COLUMNS",
    "integrate_odometry",
    "positioning_settings",
    "write_estimate_messages",
    "write_reflector_map",
    "write_run_log",
]

Series = Mapping[str, NDArray[np.float64]]

#: The covariance columns of the series, row-major upper triangle of (x, y, psi).
COV_COLUMNS = ("est_cov_xx", "est_cov_xy", "est_cov_xpsi", "est_cov_yy", "est_cov_ypsi", "est_cov_psipsi")
_STEERING = ("gamma", "phi", "phi_left", "phi_right")
_STEERING_RATE = {"gamma": "gamma_rate", "phi": "phi_rate"}
_WHEELS = ("omega_right", "omega_left", "omega_fl", "omega_fr", "omega_rl", "omega_rr")


def positioning_settings(scenario: Scenario, series: Series) -> dict[str, Any]:
    """The estimator's settings of a run as JSON-ready SI values (the ``/agvnav/settings`` document).

    Mirrors how :func:`agvnav.sim.build.build` creates the estimator: method, head
    mount (m, m, rad), goniometer encoder and rate, odometry noise, survey std, extra
    parameters, and the initial pose and covariance (the estimate recorded at t = 0).
    """
    g, ps = scenario.goniometer, scenario.positioning
    doc: dict[str, Any] = {
        "scenario": scenario.name,
        "map": _map_reference(scenario),
        "method": ps.method or ("ekf" if g is not None else "dead_reckoning"),
        "odometry_noise": list(ps.odometry_noise),
        "params": dict(ps.params),
        "initial_pose": [float(series[k][0]) for k in ("est_x", "est_y", "est_psi")],
        "initial_covariance": covariance3(series, 0).tolist() if COV_COLUMNS[0] in series else None,
        "step_s": scenario.step_s,
    }
    if g is not None:
        doc.update(
            mount=[g.mount[0], g.mount[1], math.radians(g.mount[2])], pulses_per_rev=g.pulses_per_rev,
            rate_hz=g.rate_hz, max_range_m=g.max_range_m,
        )
    if scenario.world_truth.reflector_survey_std_m > 0.0:
        doc["map_std_m"] = scenario.world_truth.reflector_survey_std_m
    if ps.wheel_odometry is not None:  # the exact steered-wheel model (SI), as build() makes it, and its
        noise = odometry_noise(scenario)  # Crowley bound for the readers of three coefficients (mapping)
        doc["wheel_odometry"] = {k: getattr(noise, k) for k in WHEEL_ODOMETRY_KEYS}
        doc["odometry_noise"] = [noise.k_d, noise.k_dtheta, noise.k_theta]
    return doc


def _map_reference(scenario: Scenario) -> str | None:
    """The scenario's map as a shipped name or an absolute file path (None for an inline map)."""
    m = scenario.map
    if not isinstance(m, str):
        return None
    if m in builtin_map_names() or Path(m).is_absolute() or scenario.base_dir is None:
        return m
    return str((scenario.base_dir / m).resolve())


def covariance3(series: Series, k: int) -> NDArray[np.float64]:
    """The ``(3, 3)`` covariance of row ``k`` from the ``est_cov_*`` columns."""
    xx, xy, xp, yy, yp, pp = (float(series[c][k]) for c in COV_COLUMNS)
    return np.array([[xx, xy, xp], [xy, yy, yp], [xp, yp, pp]])


def integrate_odometry(increments: NDArray[np.float64]) -> NDArray[np.float64]:
    """Poses ``(n + 1, 3)`` in odom from body increments ``(n, 3)`` (dd, dtheta, dlateral), midpoint heading."""
    poses = np.zeros((increments.shape[0] + 1, 3))
    pose = np.zeros(3)
    for k, (dd, dth, dl) in enumerate(increments.tolist(), start=1):
        c, s = math.cos(0.5 * dth), math.sin(0.5 * dth)
        pose = compose(pose, (dd * c - dl * s, dd * s + dl * c, dth))
        poses[k] = pose
    return poses


def _increments(series: Series, step: float) -> NDArray[np.float64]:
    """``(n, 3)`` increments of the steps ending at rows 1..n; refuses a run not recorded at every ``step`` s."""
    t = series["t"]
    n = t.shape[0]
    cols = [series.get(c, np.zeros(n)) for c in ("odo_dd", "odo_dtheta", "odo_dlat")]
    if n > 1 and np.any(np.abs(np.diff(t) - step) > 1e-9 * max(1.0, float(t[-1]))):
        raise ValueError(f"a log needs every step recorded ({step:g} s apart); this run recorded every k-th step only")
    return np.column_stack(cols)[1:]


def write_run_log(result: SimResult, path: str | Path) -> dict[str, int]:
    """Write ``result`` as an MCAP file of ROS 2 messages; return the message count per topic."""
    s, sc = result.series, result.scenario
    settings = positioning_settings(sc, s)
    with LogWriter(path) as w:
        mount = settings.get("mount")
        if mount is not None:
            w.write(tp.TF_STATIC, {"transforms": [transform(0.0, tp.FRAME_BASE, tp.FRAME_HEAD, mount)]}, 0.0)
        w.write(tp.SETTINGS, {"data": json.dumps(settings)}, 0.0)
        write_reflector_map(w, result.world)
        w.write(tp.PATH, _path_message(result.path_polyline(0.05)), 0.0)
        _write_steps(w, s, sc.step_s)
        refl = result.events.get("reflections")
        if refl is not None and mount is not None:
            _write_reflections(w, refl, s, result.world, mount, float(settings.get("max_range_m", 30.0)))
        return dict(w.counts)


def write_reflector_map(w: LogWriter, world: WorldMap) -> None:
    """The reflectors as green cylinders of their radius, 1 m tall, in map at t = 0."""
    markers = [
        {
            "header": header(0.0, tp.FRAME_MAP), "ns": "reflectors", "id": i, "type": 3, "action": 0,
            "pose": planar_pose(float(x), float(y), 0.0), "scale": vector3(2 * r, 2 * r, 1.0),
            "color": {"r": 0.1, "g": 0.7, "b": 0.2, "a": 1.0},
        }
        for i, ((x, y), r) in enumerate(zip(world.reflector_xy.tolist(), world.reflector_radius.tolist(), strict=True))
    ]
    w.write(tp.REFLECTOR_MAP, {"markers": markers}, 0.0)


def _path_message(xy: NDArray[np.float64]) -> dict[str, Any]:
    d = np.diff(xy, axis=0)
    yaw = np.arctan2(d[:, 1], d[:, 0]).tolist()
    yaw.append(yaw[-1] if yaw else 0.0)
    poses = [
        {"header": header(0.0, tp.FRAME_MAP), "pose": planar_pose(x, y, a)}
        for (x, y), a in zip(xy.tolist(), yaw, strict=True)
    ]
    return {"header": header(0.0, tp.FRAME_MAP), "poses": poses}


def write_estimate_messages(w: LogWriter, t: float, pose: NDArray[np.float64], cov: NDArray[np.float64]) -> None:
    """One ``/agvnav/estimate`` message: ``pose (3,)`` in map and its ``(3, 3)`` covariance at ``t`` s."""
    body = {"pose": planar_pose(*pose.tolist()), "covariance": covariance6(cov)}
    msg = {"header": header(t, tp.FRAME_MAP), "pose": body}
    w.write(tp.ESTIMATE, msg, t)


def _array(series: Series, names: tuple[str, ...], k: int) -> dict[str, Any]:
    n = len(names)
    data = [float(series[c][k]) if c in series else math.nan for c in names]
    layout = {"dim": [{"label": ",".join(names), "size": n, "stride": n}], "data_offset": 0}
    return {"layout": layout, "data": data}


def _write_steps(w: LogWriter, s: Series, step: float) -> None:
    """Per recorded step: tf, odometry, estimate, truth, guidance, command, status, joints."""
    t = s["t"]
    inc = _increments(s, step)
    odom = integrate_odometry(inc)
    est = np.column_stack([s["est_x"], s["est_y"], s["est_psi"]])
    has_cov = COV_COLUMNS[0] in s
    joints = _joint_names(s)
    wheel_angle = {c: np.concatenate([[0.0], np.cumsum(s[c][1:] * np.diff(t))]) for c in joints[1]}
    for k, tk in enumerate(t.tolist()):
        rate = inc[k - 1] / (tk - t[k - 1]) if k else np.zeros(3)
        map_odom = compose(est[k], inverse(odom[k])) if np.all(np.isfinite(est[k])) else np.zeros(3)
        w.write(tp.TF, {"transforms": [
            transform(tk, tp.FRAME_MAP, tp.FRAME_ODOM, map_odom.tolist()),
            transform(tk, tp.FRAME_ODOM, tp.FRAME_BASE, odom[k].tolist()),
        ]}, tk)
        w.write(tp.ODOM, {
            "header": header(tk, tp.FRAME_ODOM), "child_frame_id": tp.FRAME_BASE,
            "pose": {"pose": planar_pose(*odom[k].tolist()), "covariance": [0.0] * 36},
            "twist": {"twist": {"linear": vector3(rate[0], rate[2]), "angular": vector3(0.0, 0.0, rate[1])},
                      "covariance": [0.0] * 36},
        }, tk)
        write_estimate_messages(w, tk, est[k], covariance3(s, k) if has_cov else np.zeros((3, 3)))
        if "x" in s:
            w.write(tp.TRUTH, {"header": header(tk, tp.FRAME_MAP),
                               "pose": planar_pose(float(s["x"][k]), float(s["y"][k]), float(s["psi"][k]))}, tk)
        w.write(tp.GUIDANCE, _array(s, tp.GUIDANCE_FIELDS, k), tk)
        w.write(tp.COMMAND, _array(s, tp.COMMAND_FIELDS, k), tk)
        w.write(tp.STATUS, _array(s, tp.STATUS_FIELDS, k), tk)
        w.write(tp.JOINT_STATES, _joint_state(s, joints, wheel_angle, k, tk), tk)


def _joint_names(s: Series) -> tuple[list[str], list[str]]:
    return [c for c in _STEERING if c in s], [c for c in _WHEELS if c in s]


def _joint_state(
    s: Series, joints: tuple[list[str], list[str]], wheel_angle: dict[str, NDArray[np.float64]], k: int, t: float
) -> dict[str, Any]:
    steer, wheels = joints
    names = [f"steer_{c}" for c in steer] + [f"wheel_{c.removeprefix('omega_')}" for c in wheels]
    pos = [float(s[c][k]) for c in steer] + [float(wheel_angle[c][k]) for c in wheels]
    rates = [float(s[_STEERING_RATE[c]][k]) if _STEERING_RATE.get(c, "") in s else math.nan for c in steer]
    vel = rates + [float(s[c][k]) for c in wheels]
    return {"header": header(t, tp.FRAME_BASE), "name": names, "position": pos, "velocity": vel, "effort": []}


def _write_reflections(
    w: LogWriter, refl: Mapping[str, NDArray[np.float64]], s: Series, world: WorldMap,
    mount: list[float], max_range: float,
) -> None:
    """Each reflection: its bearing (stamp = measurement, log time = arrival) and a ray to the reflector."""
    t_arr = refl["t"]
    stamps = refl.get("stamp", t_arr)
    pose = np.column_stack([np.interp(t_arr, s["t"], s[c]) for c in ("x", "y")] +
                           [np.interp(t_arr, s["t"], np.unwrap(s["psi"]))])
    for i, (ta, ts, b) in enumerate(zip(t_arr.tolist(), stamps.tolist(), refl["bearing"].tolist(), strict=True)):
        w.write(tp.BEARING, {"header": header(ts, tp.FRAME_HEAD), "vector": vector3(b)}, ts, log_t=ta)
        j = int(refl["reflector_index"][i]) if "reflector_index" in refl else -1
        head = compose(pose[i], mount)
        length = float(np.hypot(*(world.reflector_xy[j] - head[:2]))) if 0 <= j < len(world.reflector_xy) else max_range
        ray = {
            "header": header(ts, tp.FRAME_HEAD), "ns": "reflections", "id": 0, "type": 5, "action": 0,
            "pose": planar_pose(0.0, 0.0, 0.0), "scale": vector3(0.01),
            "color": {"r": 1.0, "g": 0.3, "b": 0.1, "a": 0.8},
            "lifetime": {"sec": 0, "nanosec": 200_000_000}, "frame_locked": False,
            "points": [vector3(0.0), vector3(length * math.cos(b), length * math.sin(b))],
        }
        w.write(tp.REFLECTIONS, {"markers": [ray]}, ts, log_t=ta)
