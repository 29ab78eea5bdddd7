"""A short simulated drive, for the tests of the log readers and verdicts (written as CSV by ``_csv_log``)."""

import pytest

from agvnav.sim import simulate
from agvnav.world.scenario import load_scenario


@pytest.fixture(scope="session")
def short_run():
    """The seed-000 guidance test's first 6 s (start pose known: the EKF tracks from the start)."""
    return simulate(load_scenario("guidance_test").model_copy(update={"duration_s": 6.0}))
