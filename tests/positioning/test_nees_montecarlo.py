"""EKF consistency over Monte Carlo runs of the shipped tricycle scenarios (issue 12 §1).

Each run's NEES (3 dof: x, y, heading against the reported covariance) is averaged over
the run (:mod:`agvnav.sim.integrity`); for a consistent filter the mean over ``n``
independent runs lies in the 95 % band of ``chi2(3 n) / n`` -- for 200 runs
[2.67, 3.35], the band the issue states. The truth places each reflector from its
surveyed position by the scenario's survey std; the EKF models it as Schmidt-Kalman
consider parameters (``map_std``; :mod:`agvnav.positioning.ekf`). The truth's wheel-radius
and steering-offset errors are drawn per run from the tolerance the filter states
(``positioning.wheel_odometry``; :func:`agvnav.bench.consistency.draw_calibration`), as in
``agvnav bench consistency``: a truth fixed at the tolerance in every run would fix part of
the NEES by construction. A run's time average is less spread than one chi-square sample,
so the band is conservative for the spread and exact for the mean. The bench gives the
same figures split into position and heading (see the EKF's ``covariance``).
"""

from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest
from scipy.stats import chi2

from agvnav.bench.consistency import scenario_text
from agvnav.sim import simulate
from agvnav.world.scenario import parse_scenario

#: The shipped tricycle scenarios positioned by the EKF with the exact wheel model (``wheel_odometry``).
EKF_TRICYCLE = ("guidance_test", "seed000_guidance_agvnav", "seed000_positioning_agvnav", "tricycle_rear_loop")


def _nees(args: tuple[str, int]) -> float:
    name, seed = args
    return float(simulate(parse_scenario(scenario_text(name, seed), source=name)).integrity["nees_mean"])


def _band(n: int) -> tuple[float, float]:
    return chi2.ppf(0.025, 3 * n) / n, chi2.ppf(0.975, 3 * n) / n


def _mean_nees(name: str, n: int) -> float:
    tasks = [(name, seed) for seed in range(n)]
    with ProcessPoolExecutor(max(1, min(4, os.cpu_count() or 1))) as pool:
        return float(np.mean(list(pool.map(_nees, tasks))))


def test_band_is_the_issue_band() -> None:
    lo, hi = _band(200)
    assert (round(lo, 2), round(hi, 2)) == (2.67, 3.35)


def test_guidance_test_nees_inside_its_band_over_8_runs() -> None:
    """CI version: 8 seeds of guidance_test (calibration errors drawn), NEES in [1.55, 4.92] (measured 3.42)."""
    lo, hi = _band(8)
    assert lo < _mean_nees("guidance_test", 8) < hi


@pytest.mark.slow
@pytest.mark.parametrize("name", EKF_TRICYCLE)
def test_ekf_nees_inside_its_95_percent_band_over_200_runs(name: str) -> None:
    lo, hi = _band(200)
    assert lo < _mean_nees(name, 200) < hi
