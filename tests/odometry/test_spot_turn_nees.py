"""Issue 32: a turn on the spot, odometry covariance against the truth differential vehicle (NEES Monte Carlo).

The truth (:class:`agvnav.vehicles.DifferentialPlant`) slips each wheel with ``var = slip_k |s|``; a
turn on the spot rolls both wheels ``b |dtheta| / 2`` in opposite directions, so the base shifts along
its heading. Crowley's form [seed002 eq17] puts that translation's variance at ``K_D |dD| = 0``: the
propagated covariance does not grow along the heading and the NEES of the pose after the turn is far
over its chi-square band (the station estimator's false alarm of issue 32). The wheel-pair model
(:class:`agvnav.odometry.WheelPairOdometryNoise`) is consistent. Small version in CI, a larger one slow.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.odometry import NonSystematicErrors, OdometryNoise, noise_from_truth, propagate, wheel_pair_noise
from agvnav.vehicles.differential import DifferentialPlant

SLIP_K, TRACK, RADIUS = 1e-4, 0.5, 0.08
#: The docked state of the station estimator before a fine-positioning turn (m, m, rad): seed 12's.
P0 = np.diag([1e-4**2, 1e-4**2, 1e-4**2])
DT = 0.05


def _turn(rng: np.random.Generator, angle: float, rate: float = 0.5) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """One turn on the spot of ``angle`` (rad) at ``rate`` (rad/s) then a stop: (truth (3,), odometry increments)."""
    plant = DifferentialPlant(RADIUS, TRACK, 4096, [0.0, 0.0, 0.0],
                              nonsystematic=NonSystematicErrors(slip_k=SLIP_K))
    w = math.copysign(rate, angle) * 0.5 * TRACK / RADIUS
    steps = max(1, round(abs(angle) / rate / DT))
    odo = []
    for k in range(steps + 20):  # the speed loops run on after the zero command: wait them out
        cmd = (w, -w) if k < steps else (0.0, 0.0)
        plant.advance(cmd, k * DT, DT, rng)
        dd, dth, _ = plant.odometry()
        odo.append((dd, dth))
    return np.asarray(plant.pose, dtype=float), odo


def _nees(noises: list[OdometryNoise], angle: float, runs: int, seed: int) -> list[float]:
    """Mean NEES (3 dof) of the dead-reckoned pose after the turn under each model, started from P0 around the
    truth; the same turns for every model."""
    rng = np.random.default_rng(seed)
    out: list[list[float]] = [[] for _ in noises]
    for _ in range(runs):
        truth, odo = _turn(rng, angle)
        x0 = rng.multivariate_normal(np.zeros(3), P0)  # the estimate's error before the turn
        for noise, nees in zip(noises, out, strict=True):
            x, P = x0, P0.copy()
            for dd, dth in odo:
                x, P = propagate(x, P, dd, dth, noise)
            e = np.asarray(x) - truth
            e[2] = math.remainder(float(e[2]), 2.0 * math.pi)
            nees.append(float(e @ np.linalg.solve(P, e)))
    return [float(np.mean(n)) for n in out]


def _band(runs: int) -> tuple[float, float]:
    """99.9 % band of the mean of ``runs`` chi2(3) draws (Wilson-Hilferty), divided by ``runs``."""
    k = 3 * runs
    z = 3.29
    lo = k * (1 - 2 / (9 * k) - z * math.sqrt(2 / (9 * k))) ** 3
    hi = k * (1 - 2 / (9 * k) + z * math.sqrt(2 / (9 * k))) ** 3
    return lo / runs, hi / runs


CROWLEY = noise_from_truth("differential", SLIP_K, TRACK)


def test_the_wheel_pair_model_reduces_to_crowley_straight_and_for_the_heading_of_a_spot_turn():
    wp = wheel_pair_noise(CROWLEY, TRACK)
    assert wp.slip_k == pytest.approx(SLIP_K, rel=1e-12)
    assert wp.increment_covariance(0.3, 0.0) == pytest.approx(CROWLEY.increment_covariance(0.3, 0.0), rel=1e-12)
    spot, crowley = wp.increment_covariance(0.0, 0.4), CROWLEY.increment_covariance(0.0, 0.4)
    assert spot[1, 1] == pytest.approx(crowley[1, 1], rel=1e-12)
    assert crowley[0, 0] == 0.0 and spot[0, 0] == pytest.approx(SLIP_K * TRACK * 0.4 / 4, rel=1e-12)
    # an arc: the exact covariance of the two wheels' slips (right rolls 0.35, left 0.25)
    J = np.array([[0.5, 0.5], [1 / TRACK, -1 / TRACK]])
    exact = J @ np.diag([SLIP_K * 0.35, SLIP_K * 0.25]) @ J.T
    assert wp.increment_covariance(0.3, 0.1 / TRACK) == pytest.approx(exact, rel=1e-12)


def test_wheel_pair_noise_refuses_a_bad_track():
    with pytest.raises(ValueError, match="track_m"):
        wheel_pair_noise(CROWLEY, 0.0)


def test_spot_turn_nees_small_monte_carlo():
    """A 1.5 deg fine-positioning turn (seed 12's) over 60 runs: the wheel-pair model inside the 99.9 % band,
    Crowley's form far above it."""
    angle, runs = math.radians(1.5), 60
    lo, hi = _band(runs)
    good, bad = _nees([wheel_pair_noise(CROWLEY, TRACK), CROWLEY], angle, runs, seed=32)
    assert lo < good < hi, (good, lo, hi)
    assert bad > 5.0 * hi, bad


@pytest.mark.slow
@pytest.mark.parametrize("deg", [1.5, 10.0, 90.0])
def test_spot_turn_nees_monte_carlo(deg: float):
    runs = 300
    lo, hi = _band(runs)
    (good,) = _nees([wheel_pair_noise(CROWLEY, TRACK)], math.radians(deg), runs, seed=3200 + int(deg))
    assert lo < good < hi, (deg, good, lo, hi)
