"""``agvnav bench landmarks``: seed 004 Tables I-II over seeds, with and without wall landmarks.

For each terrain (concrete, artificial grass) agvnav's 3.5 m square scenario
(``tracked_square_3p5_<terrain>``: landmark corrections blended, lateral
recalibration on; the odometry mismatch in its YAML is one assumed value, not a
measured one) is driven for 10 laps with and without landmarks, over several
random seeds (slip noise and ultrasonic noise). The comparison with the seed's
tables, with the seed's own landmark rule and a band over the unknown parameters,
is ``agvnav bench seeds``; this table reports agvnav's figures only. One record per terrain and mode:
``mean_error_per_lap_m`` / ``max_error_per_lap_m`` over all laps and seeds of
the per-lap error (distance between consecutive true lap end points, see
:mod:`agvnav.sim.laps`), ``laps`` per run; also the distance from the start
after the first and the last lap (``first_lap_from_start_m``,
``final_from_start_m``, means over seeds): bounded with landmarks, growing
without. Quick mode: 2 laps, 1 seed.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from agvnav.sim.laps import prepare_tracked, run_tracked
from agvnav.world.scenario import load_scenario

TITLE = "Seed 004 tracked robot, agvnav's landmark rule: error per lap with and without wall landmarks (3.5 m, 15 cm/s)"

TERRAINS = {"concrete": "tracked_square_3p5_concrete", "artificial_grass": "tracked_square_3p5_grass"}


def run(quick: bool, seed: int) -> list[dict[str, Any]]:
    """Records ``terrain, landmarks, mean_error_per_lap_m, max_error_per_lap_m, laps`` (+ extras)."""
    laps, n_seeds = (2, 1) if quick else (10, 3)
    records: list[dict[str, Any]] = []
    for terrain, name in TERRAINS.items():
        sc = load_scenario(name)
        if sc.route is None:
            raise ValueError(f"scenario {name} is not a route scenario of the tracked robot")
        for landmarks in (True, False):
            per_lap, first, final, wall = [], [], [], 0.0
            for k in range(n_seeds):
                run_sc = sc.with_seed(seed + k).with_controller(laps=laps)
                parts = prepare_tracked(run_sc)
                r = run_tracked(run_sc, parts.route, parts.world, parts.layout, parts.params, use_landmarks=landmarks)
                per_lap.append(r.laps.per_lap_m)
                first.append(r.laps.error_m[0])
                final.append(r.laps.error_m[-1])
                wall += r.wall_time_s
            e = np.concatenate(per_lap)
            records.append({
                "terrain": terrain,
                "landmarks": landmarks,
                "mean_error_per_lap_m": float(np.mean(e)),
                "max_error_per_lap_m": float(np.max(e)),
                "laps": laps,
                "seeds": n_seeds,
                "first_lap_from_start_m": float(np.mean(first)),
                "final_from_start_m": float(np.mean(final)),
                "wall_time_per_run_s": wall / n_seeds,
            })
    return records
