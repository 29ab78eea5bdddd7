"""``agvnav bench positioning``: dynamic positioning of a moving tricycle, four methods, five speeds.

A seed-000 pallet stacker (front drive wheel, wheelbase ``WHEELBASE``) drives open loop
-- piecewise constant steering, so lines and arcs -- through the shipped lab map with
the seed's goniometer (8 Hz, 65535 pulses, 30 m; seed 000 §4.1), at a drive-wheel speed
of 0, 0.2, 0.5, 1 and 2 m/s. Every method is fed the same noisy odometry (50 Hz) and
the same anonymous reflections (with misses and spurious ones) through the streaming
interface, and its pose is compared with the truth at every odometry sample.

Speed 0 is the static reference: the vehicle stands at ``N_STATIC`` poses spread along
the path. The static CRLB row value is the Cramér-Rao bound of one fix from all the
reflectors seen in the revolution, at the same poses (:func:`agvnav.positioning.crlb`).
Lateral error as seed 000 §4.2 measures it: the estimate minus the truth, projected on
the normal of the true heading (of point O). The sensor sees the true reflectors, the
estimators the surveyed map (``SURVEY_STD``); odometry errors follow ``ODOMETRY_NOISE``.
Extra key ``vs_static``: a method's RMS position error over its own at speed 0.

Seed 000 §5's switch (issue 13): the last records drive straight through the critical
circle of a three-reflector layout (``SWITCH_REFLECTORS``), where the three-bearing
(relative) fix is indeterminate, with the angle propagation triangulating by absolute
angles (the seed's method), by relative angles with absolute angles inside a geometric
band around the circle (``band``), and by the switch on the predicted error of each
method (``predicted``, :func:`agvnav.positioning.fix_switch.predicted_position_variances`);
``relative_fraction`` is the share of the switch's fixes made by the relative method.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import angle_diff, compose
from agvnav.kinematics.base import twist_step
from agvnav.kinematics.tricycle import TricycleStacker
from agvnav.odometry import OdometryNoise
from agvnav.positioning import crlb
from agvnav.positioning.estimator import METHODS, make_estimator
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import Reflector, WorldMap, load_builtin_map

TITLE = (
    "Dynamic positioning of a moving tricycle in the lab (8 Hz head, 65535 pulses, 30 m). "
    "Seed 000 real vehicle at 0.2 m/s: mean |e_lat| 9.7 mm, std 6.6 mm, max 23 mm. "
    "Targets: methods 2-4 within 1.5x of their static error at 1-2 m/s, naive >= 5x worse, EKF within 1.2x of the best"
)

SPEEDS = (0.0, 0.2, 0.5, 1.0, 2.0)
WHEELBASE = 1.3  # m, O to C
MOUNT = (0.6, 0.0, 0.0)  # head centre P in base_link (m, rad)
ODOMETRY_DT = 0.02  # s
N_STATIC = 8
STATIC_SECONDS = 1.5
SETTLE_SECONDS = 0.5
#: Odometry noise of the bench (Crowley coefficients, seed 002 §3.2): 1 mm/sqrt(m) in distance,
#: 0.3 mrad/sqrt(m) and 1 mrad/sqrt(rad) in heading -- good industrial traction/steering encoders.
ODOMETRY_NOISE = OdometryNoise(k_d=1e-6, k_dtheta=1e-7, k_theta=1e-6)
#: Std (m) of the survey error of each reflector position: the sensor sees the true reflectors,
#: the estimators use the surveyed map (seed 000 §4.1: positions measured topographically).
SURVEY_STD = 0.002
#: Path of O: (length m, curvature 1/m) per segment, from START; the 1.24 m arc is seed 000 §4.3's.
START = (3.0, 2.5, 0.0)
SEGMENTS = ((8.0, 0.0), (np.pi, 0.5), (2.0, 0.0), (np.pi, 0.5), (6.0, 0.0), (1.24 * np.pi / 2, 1 / 1.24), (3.0, 0.0))


@dataclass(frozen=True)
class Drive:
    """Open-loop truth: segment start times ``t (K+1,)``, start poses of O ``(K+1, 3)``,
    O speed ``u (K,)`` (m/s) and yaw rate ``omega (K,)`` (rad/s) of each segment."""

    t: NDArray[np.float64]
    poses: NDArray[np.float64]
    u: NDArray[np.float64]
    omega: NDArray[np.float64]

    @property
    def duration(self) -> float:
        """Total time (s)."""
        return float(self.t[-1])

    def pose_at(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """Exact base_link (O) pose ``(k, 3)`` at instants ``t (k,)``: the arc of a constant (v, gamma)."""
        t = np.clip(np.atleast_1d(np.asarray(t, dtype=np.float64)), 0.0, self.t[-1])
        k = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.u) - 1)
        return twist_step(self.poses[k], self.u[k], 0.0, self.omega[k], t - self.t[k])

    def odometry(
        self, t0: NDArray[np.float64], t1: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Exact increments ``(delta_d, delta_theta)`` of O between instants ``t0`` and ``t1``."""
        delta_d = self._integral(t1, self.u) - self._integral(t0, self.u)
        return delta_d, self._integral(t1, self.omega) - self._integral(t0, self.omega)

    def _integral(self, t: NDArray[np.float64], rate: NDArray[np.float64]) -> NDArray[np.float64]:
        t = np.clip(t, 0.0, self.t[-1])
        cum = np.concatenate([[0.0], np.cumsum(rate * np.diff(self.t))])
        k = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(rate) - 1)
        return cum[k] + rate[k] * (t - self.t[k])


def lab_drive(speed: float, segments: tuple[tuple[float, float], ...] = SEGMENTS) -> Drive:
    """Open-loop drive of the stacker at drive-wheel speed ``speed`` (m/s) along ``segments``.

    The steering of each segment is ``atan(kappa L)``; the pose at each segment end comes
    from :meth:`TricycleStacker.step` (exact arc at constant steering, [seed000 eq8]).
    """
    model = TricycleStacker(WHEELBASE)
    state = np.array([*START, 0.0])
    t, poses, u, omega = [0.0], [state[:3].copy()], [], []
    for length, kappa in segments:
        gamma = float(model.steer_for_curvature(kappa))
        state[3] = gamma
        speed_o = speed * np.cos(gamma)
        dt = length / speed_o
        state = model.step(state, np.array([speed, 0.0]), dt)
        t.append(t[-1] + dt)
        poses.append(state[:3].copy())
        u.append(speed_o)
        omega.append(speed * np.sin(gamma) / WHEELBASE)
    return Drive(np.array(t), np.array(poses), np.array(u), np.array(omega))


def _noisy_increments(
    dd: NDArray[np.float64], dth: NDArray[np.float64], noise: OdometryNoise, rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Odometry increments with the errors the EKF's covariance model assumes (see OdometryNoise)."""
    sd_d, sd_th = _increment_std(dd, dth, noise)
    return dd + rng.normal(0.0, 1.0, dd.shape) * sd_d, dth + rng.normal(0.0, 1.0, dth.shape) * sd_th


def _increment_std(
    dd: NDArray[np.float64], dth: NDArray[np.float64], noise: OdometryNoise
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Std of the distance and heading increments (m, rad) under ``noise``."""
    cov = noise.increment_covariance(dd, dth)
    return np.sqrt(cov[..., 0, 0]), np.sqrt(cov[..., 1, 1])


def surveyed(world: WorldMap, std: float, rng: np.random.Generator) -> WorldMap:
    """The real world behind a surveyed map: each reflector displaced by N(0, std^2) per axis (m)."""
    shift = rng.normal(0.0, std, (len(world.reflectors), 2))
    moved = tuple(
        Reflector(r.id, r.x + dx, r.y + dy, r.radius) for r, (dx, dy) in zip(world.reflectors, shift, strict=True)
    )
    return WorldMap(moved, world.walls)


def _run_one(
    method: str,
    world: WorldMap,
    true_world: WorldMap,
    gon: Goniometer,
    drive: Drive,
    t_end: float,
    noise: OdometryNoise,
    rng: np.random.Generator,
    **est_kwargs: Any,
) -> dict[str, Any]:
    """Feed one estimator; return truth and estimate at every odometry sample after settling.

    ``est_kwargs`` go to the estimator (e.g. ``triangulation_method``); the record also
    carries the angle propagation's ``n_relative``/``n_held`` counts (None for the others).
    """
    refl = gon.scan(true_world, drive.pose_at, 0.0, t_end, rng)
    ticks = np.arange(0.0, t_end + 1e-12, ODOMETRY_DT)
    dd, dth = drive.odometry(ticks[:-1], ticks[1:])
    dd, dth = _noisy_increments(dd, dth, noise, rng)
    start = drive.pose_at(np.array([0.0]))[0] + rng.normal(0.0, 1.0, 3) * np.array([0.01, 0.01, 0.003])
    est = make_estimator(
        method, world, gon.mount, odometry_noise=noise, initial_pose=start,
        initial_covariance=np.diag([0.01, 0.01, 0.003]) ** 2, rate_hz=gon.rate_hz, max_range=gon.max_range,
        map_std=SURVEY_STD, **est_kwargs,
    )
    est.predict(0.0, 0.0, 0.0)
    j = int(np.searchsorted(refl.t, ticks[1], side="right"))  # before the first increment the odometric rate is unknown
    times, poses = [], []
    for i in range(1, len(ticks)):
        while j < len(refl) and refl.t[j] <= ticks[i]:
            est.update(float(refl.t[j]), float(refl.bearing[j]))
            j += 1
        est.predict(float(ticks[i]), float(dd[i - 1]), float(dth[i - 1]))
        if ticks[i] >= SETTLE_SECONDS:
            times.append(ticks[i])
            poses.append(est.pose)
    times_a = np.array(times)
    return {
        "t": times_a,
        "estimate": np.array(poses),
        "truth": drive.pose_at(times_a),
        "refl_t": refl.t,
        "refl_index": refl.reflector_index,
        "n_relative": getattr(est, "n_relative", None),
        "n_held": getattr(est, "n_held", None),
    }


def _errors(runs: list[dict[str, Any]]) -> dict[str, float]:
    est = np.concatenate([r["estimate"] for r in runs])
    truth = np.concatenate([r["truth"] for r in runs])
    diff = est[:, :2] - truth[:, :2]
    pos = np.hypot(diff[:, 0], diff[:, 1])
    head = angle_diff(est[:, 2], truth[:, 2])
    lat = -np.sin(truth[:, 2]) * diff[:, 0] + np.cos(truth[:, 2]) * diff[:, 1]
    pos = np.where(np.isfinite(pos), pos, np.inf)
    return {
        "rms_position_m": float(np.sqrt(np.mean(pos**2))),
        "max_position_m": float(np.max(pos)),
        "rms_heading_rad": float(np.sqrt(np.mean(head**2))),
        "mean_abs_lateral_m": float(np.mean(np.abs(lat))),
        "std_lateral_m": float(np.std(lat)),
        "max_abs_lateral_m": float(np.max(np.abs(lat))),
    }


def _static_crlb(
    world: WorldMap, gon: Goniometer, runs: list[dict[str, Any]], bearing_std: float
) -> float:
    """RMS over the evaluated poses of the position CRLB of one static fix from the reflectors seen.

    Every bearing's std combines the encoder quantisation and the map survey error at its
    distance, the two error sources a standing vehicle has.
    """
    var = []
    period = 1.0 / gon.rate_hz
    for r in runs:
        for t, pose in zip(r["t"][::10], r["truth"][::10], strict=True):
            seen = np.unique(r["refl_index"][(r["refl_t"] > t - period) & (r["refl_t"] <= t) & (r["refl_index"] >= 0)])
            if seen.size < 3:
                continue
            head = compose(pose, np.asarray(gon.mount))
            dist = np.hypot(*(world.reflector_xy[seen] - head[:2]).T)
            std = np.sqrt(bearing_std**2 + (SURVEY_STD / dist) ** 2)  # encoder and survey error
            cov = crlb(world.reflector_xy[seen], head, std)
            var.append(cov[0, 0] + cov[1, 1])
    return float(np.sqrt(np.mean(var))) if var else float("nan")


#: Seed 000 §5 switch bench: three reflectors (m) and the straight drive of O through their circle.
SWITCH_REFLECTORS = ((0.0, 10.0), (-8.0, -6.0), (9.0, -5.0))
SWITCH_START = (-2.0, 1.0, 0.0)
SWITCH_LENGTH = 13.0  # m: from inside the circle (radius ~10 m) to beyond it
SWITCH_VARIANTS = (("absolute_angles", "absolute_angles"), ("band", "relative_angles"), ("predicted", "predicted"))


def switch_records(quick: bool, seed: int) -> list[dict[str, Any]]:
    """One record per triangulation choice of the angle propagation on the drive through the critical circle."""
    world = WorldMap(tuple(Reflector(f"S{i}", x, y, 0.0) for i, (x, y) in enumerate(SWITCH_REFLECTORS)), ())
    gon = Goniometer(rate_hz=8.0, pulses_per_rev=65535, mount=MOUNT, max_range=30.0)
    speed = 1.0
    length = SWITCH_LENGTH / 2 if quick else SWITCH_LENGTH
    start = np.array(SWITCH_START)
    end = start + [length, 0.0, 0.0]
    drive = Drive(np.array([0.0, length / speed]), np.array([start, end]), np.array([speed]), np.zeros(1))
    records = []
    for label, tri in SWITCH_VARIANTS:
        rng = np.random.default_rng([seed, 5])  # same reflections and odometry for every choice
        run = _run_one("angle_propagation", world, world, gon, drive, drive.duration, ODOMETRY_NOISE, rng,
                       triangulation_method=tri)
        n_rel, n_held = run.pop("n_relative"), run.pop("n_held")
        share = n_rel / (n_rel + n_held) if tri == "predicted" and n_rel + n_held else None
        records.append({"method": f"angle_propagation/{label}", "speed_mps": speed, **_errors([run]),
                        "relative_fraction": share})
    return records


def run(quick: bool, seed: int) -> list[dict[str, Any]]:
    """One record per method and speed (keys of issue 4 §5); ``quick`` shortens every drive."""
    world = load_builtin_map("lab")
    true_world = surveyed(world, SURVEY_STD, np.random.default_rng([seed, 1]))
    gon = Goniometer(rate_hz=8.0, pulses_per_rev=65535, mount=MOUNT, max_range=30.0, p_miss=0.02, spurious_rate=0.2)
    noise = ODOMETRY_NOISE
    bearing_std = gon.resolution / np.sqrt(12.0)
    max_seconds = 3.0 if quick else np.inf
    n_static = 2 if quick else N_STATIC
    records = []
    for speed in SPEEDS:
        crlb_runs: list[dict[str, Any]] | None = None
        for method in METHODS:
            rng = np.random.default_rng([seed, int(speed * 1000)])  # same world for every method
            drive = lab_drive(speed) if speed > 0.0 else None
            runs = _static_runs(method, world, true_world, gon, noise, rng, n_static) if drive is None else [
                _run_one(method, world, true_world, gon, drive, min(drive.duration, max_seconds), noise, rng)
            ]
            crlb_runs = crlb_runs or runs
            records.append({"method": method, "speed_mps": speed, **_errors(runs), "static_crlb_rms_position_m": 0.0})
        value = _static_crlb(world, gon, crlb_runs or [], bearing_std)
        for rec in records[-len(METHODS):]:
            rec["static_crlb_rms_position_m"] = value
    _add_ratios(records)
    return records + switch_records(quick, seed)


def _static_runs(
    method: str,
    world: WorldMap,
    true_world: WorldMap,
    gon: Goniometer,
    noise: OdometryNoise,
    rng: np.random.Generator,
    n: int,
) -> list[dict[str, Any]]:
    """Standstill at ``n`` poses spread along the path, ``STATIC_SECONDS`` each."""
    moving = lab_drive(1.0)
    runs = []
    for t_stop in np.linspace(0.0, moving.duration, n + 2)[1:-1]:
        pose = moving.pose_at(np.array([t_stop]))[0]
        still = Drive(np.array([0.0, STATIC_SECONDS]), np.array([pose, pose]), np.zeros(1), np.zeros(1))
        runs.append(_run_one(method, world, true_world, gon, still, STATIC_SECONDS, noise, rng))
    return runs


def _add_ratios(records: list[dict[str, Any]]) -> None:
    """Extra key ``vs_static``: each method's RMS position error over its own static one."""
    static = {r["method"]: r["rms_position_m"] for r in records if r["speed_mps"] == 0.0}
    for r in records:
        r["vs_static"] = r["rms_position_m"] / static[r["method"]] if static.get(r["method"]) else float("nan")
