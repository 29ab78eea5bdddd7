"""Shared test helpers: a constant-arc drive and a feeder of odometry + reflections."""

from __future__ import annotations

import numpy as np

from agvnav.geometry import angle_diff
from agvnav.kinematics.base import twist_step
from agvnav.odometry import OdometryNoise
from agvnav.positioning.estimator import StreamingEstimator
from agvnav.sensors.goniometer import Goniometer
from agvnav.world import WorldMap


def arc_pose_at(start: np.ndarray, speed: float, omega: float):
    """Exact pose of a body moving at constant speed (m/s) and yaw rate (rad/s)."""

    def pose_at(t: np.ndarray) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        return twist_step(np.broadcast_to(start, t.shape + (3,)), speed, 0.0, omega, t)

    return pose_at


def feed(
    est: StreamingEstimator,
    world: WorldMap,
    gon: Goniometer,
    pose_at,
    speed: float,
    omega: float,
    t_end: float,
    dt: float = 0.02,
    rng: np.random.Generator | None = None,
    noise: OdometryNoise | None = None,
    bearing_noise: float = 0.0,
    sample_every: int = 1,
    odometry_at_reflections: bool = False,
):
    """Drive ``est`` with odometry every ``dt`` (and, optionally, at every reflection) and the reflections.

    Odometry increments get Gaussian errors of covariance ``noise.increment_covariance``
    (the filter's own model) when ``noise`` is given. Returns ``(times, estimates,
    covariances)`` sampled after every ``sample_every``-th regular odometry call.
    """
    rng = rng or np.random.default_rng(0)
    refl = gon.scan(world, pose_at, 0.0, t_end, rng if gon.noisy else None)
    bearings = refl.bearing + rng.normal(0.0, bearing_noise, refl.bearing.shape) if bearing_noise else refl.bearing
    ticks = np.arange(0.0, t_end + 1e-12, dt)
    est.predict(0.0, 0.0, 0.0)
    j = int(np.searchsorted(refl.t, ticks[1], side="right"))
    out_t, out_x, out_p = [], [], []
    last = [0.0]

    def odometry(t: float) -> None:
        step = t - last[0]
        dd, dth = speed * step, omega * step
        if noise is not None:
            cov = noise.increment_covariance(dd, dth)
            dd += rng.normal(0.0, np.sqrt(cov[0, 0]))
            dth += rng.normal(0.0, np.sqrt(cov[1, 1]))
        est.predict(t, dd, dth)
        last[0] = t

    for i in range(1, len(ticks)):
        while j < len(refl) and refl.t[j] <= ticks[i]:
            if odometry_at_reflections and refl.t[j] > last[0]:
                odometry(float(refl.t[j]))
            est.update(float(refl.t[j]), float(bearings[j]))
            j += 1
        odometry(float(ticks[i]))
        if i % sample_every == 0:
            out_t.append(ticks[i])
            out_x.append(est.pose)
            out_p.append(est.covariance)
    return np.array(out_t), np.array(out_x), np.array(out_p)


def drive_nees(est: StreamingEstimator, world: WorldMap, gon: Goniometer, start: np.ndarray, speed: float,
               omega: float, seconds: float, dt: float, rng: np.random.Generator, noise: OdometryNoise,
               bearing_noise: float, sample_every: int) -> np.ndarray:
    """NEES (3 dof) of ``est`` at the sampled instants of a constant-arc drive from ``start``.

    The drive is :func:`feed`'s with odometry read at every reflection (the filter sees no
    extrapolation) and increment errors matched to ``noise``.
    """
    pose_at = arc_pose_at(start, speed, omega)
    t, x, P = feed(est, world, gon, pose_at, speed, omega, seconds, dt, rng, noise, bearing_noise,
                   sample_every=sample_every, odometry_at_reflections=True)
    truth = pose_at(t)
    e = x - truth
    e[:, 2] = angle_diff(x[:, 2], truth[:, 2])
    return np.einsum("ki,kij,kj->k", e, np.linalg.inv(P), e)
