"""Campaign test helpers: a short base scenario (0.4 m straight) and one 2-worker LocalCluster per session."""

import logging
import textwrap

import pytest
from distributed import LocalCluster

#: Overrides that make the default scenario a ~3 s drive: a 0.4 m line, starting 20 mm off it.
SHORT = """\
overrides:
  path.segments: [{type: line, length_m: 0.4}]
  start.lateral_offset_m: 0.02
"""


def campaign_text(body: str, short: bool = True) -> str:
    """A campaign file: ``name``/``base`` lines, the short overrides, then ``body`` (dedented)."""
    head = "name: tiny\nbase: guidance_test\n"
    return head + (SHORT if short else "") + textwrap.dedent(body)


@pytest.fixture
def write_campaign(tmp_path):
    """Write a campaign file built by :func:`campaign_text`; return its path."""

    def write(body: str, short: bool = True, name: str = "c.yaml"):
        p = tmp_path / name
        p.write_text(campaign_text(body, short))
        return p

    return write


@pytest.fixture(scope="session")
def scheduler():
    """Address of a 2-worker, 1-thread-each LocalCluster shared by the campaign tests."""
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=logging.ERROR,
        scheduler_kwargs={"dashboard_address": ":0"},
    ) as cluster:
        yield cluster.scheduler_address
