import pytest

from agvnav.bench.guidance import CONTROLLERS, PATHS, _supports, scenario_for
from agvnav.sim.build import build


@pytest.mark.parametrize("path", sorted(PATHS))
def test_every_bench_scenario_builds(path):
    for controller in CONTROLLERS:
        if not _supports(controller, path):
            continue
        sc = scenario_for(controller, path, seed=1)
        b = build(sc)
        assert b.point == ("O" if path.startswith("reverse") else "C")
        assert sc.controller.params["convergence_distance"] > 0
        assert b.path.length > 0
