"""Campaign test helpers: a short base scenario (0.4 m straight) and one 2-worker LocalCluster per session."""

import textwrap

import pytest

from agvnav.campaign.runner import local_cluster

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
    """Address of the runner's default cluster (2 single-threaded worker processes), shared by the tests."""
    with local_cluster(2) as cluster:
        yield cluster.scheduler_address
