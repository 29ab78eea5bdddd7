"""EKF consistency over Monte Carlo runs of the shipped tricycle scenarios (issue 12 §1).

Each run's NEES (3 dof: x, y, heading against the reported covariance) is averaged over
the run (:mod:`agvnav.sim.integrity`); for a consistent filter the mean over ``n``
independent runs lies in the 95 % band of ``chi2(3 n) / n`` -- for 200 runs
[2.67, 3.35], the band the issue states. The truth places each reflector 5 mm (std)
from its surveyed position; the EKF models it as Schmidt-Kalman consider parameters
(``map_std``; :mod:`agvnav.positioning.ekf`). A run's time average is less spread than
one chi-square sample, so the band is conservative for the spread and exact for the
mean. ``agvnav bench consistency`` gives the same figures split into position and
heading (200 runs: guidance_test 2.80, inside its band; see the EKF's ``covariance``).
"""

from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest
import yaml
from scipy.stats import chi2

from agvnav.sim import simulate
from agvnav.world.scenario import builtin_scenario, parse_scenario

#: The shipped tricycle scenarios positioned by the EKF.
EKF_TRICYCLE = ("guidance_test", "seed000_guidance_agvnav", "seed000_positioning_agvnav", "mission_hall")


def _nees(args: tuple[str, int]) -> float:
    name, seed = args
    doc = yaml.safe_load(builtin_scenario(name).read_text(encoding="utf-8"))
    doc["seed"] = seed
    return float(simulate(parse_scenario(yaml.safe_dump(doc), source=name)).integrity["nees_mean"])


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
    """CI version: 8 seeds of guidance_test, mean NEES in [1.55, 4.92] (measured 4.10; 2.74 over 40 seeds)."""
    lo, hi = _band(8)
    assert lo < _mean_nees("guidance_test", 8) < hi


#: Known misses (strict xfails with their 200-run NEES). Empty since the exact steered-wheel model
#: with the calibration consider parameters (issue 12): ``agvnav bench consistency`` measured
#: guidance_test 2.80, seed000_guidance_agvnav 2.73, seed000_positioning_agvnav 2.80 (band
#: 2.67-3.35; they were 2.47, 2.34, 2.57 with Crowley's bound and no systematic errors).
KNOWN_PESSIMISTIC: dict[str, float] = {}


@pytest.mark.slow
@pytest.mark.parametrize("name", [
    pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=f"NEES {KNOWN_PESSIMISTIC[n]} below 2.67 (issue 12)"))
    if n in KNOWN_PESSIMISTIC else n
    for n in EKF_TRICYCLE
])
def test_ekf_nees_inside_its_95_percent_band_over_200_runs(name: str) -> None:
    lo, hi = _band(200)
    assert lo < _mean_nees(name, 200) < hi
