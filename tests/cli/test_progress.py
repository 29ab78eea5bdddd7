"""The one progress helper: quiet off a terminal, passes that restart add up, remembered durations."""

from __future__ import annotations

import json

import pytest

from agvnav.cli.progress import RunProgress, expected_sim_time
from agvnav.sim import simulate
from agvnav.sim.build import build
from agvnav.world.scenario import load_scenario, parse_scenario


def test_quiet_when_not_enabled_but_counts(capsys):
    with RunProgress("x", total=10.0, enabled=False) as bar:
        for t in (1.0, 5.0, 10.0):
            bar.update(t)
    assert bar.done == 10.0
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""


def test_a_second_pass_from_zero_adds_to_the_first():
    with RunProgress("x", total=20.0, enabled=False) as bar:
        for t in (2.0, 6.0, 10.0, 1.0, 4.0):  # the second pass (e.g. without landmarks) restarts at 0
            bar.update(t)
    assert bar.done == 14.0


def test_campaign_style_callback_sets_the_total():
    with RunProgress("c", unit="runs", enabled=False) as bar:
        bar.runs(3, 8)
    assert bar.done == 3.0


def test_a_silent_step_remembers_its_wall_time_for_the_next_bar(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    with RunProgress("bench x", key="bench x", enabled=True):
        pass
    saved = json.loads((tmp_path / "agvnav" / "durations.json").read_text())
    assert "bench x" in saved and saved["bench x"] >= 0.0
    with RunProgress("bench y", key="bench y", enabled=False):  # off a terminal nothing is written
        pass
    assert "bench y" not in json.loads((tmp_path / "agvnav" / "durations.json").read_text())


SHUTTLE = """\
name: shuttle
seed: 1
step_s: 0.05
vehicle: {model: differential, track_m: 0.5, wheel_radius_m: 0.08, encoder_counts_per_rev: 4096}
traction: {speed_m_s: 0.5, max_accel_m_s2: 0.3, max_decel_m_s2: 0.3}
map: {reflectors: [{id: R1, x: -5, y: -5}, {id: R2, x: 12, y: -5}, {id: R3, x: 0, y: 12}]}
positioning: {method: dead_reckoning, initial_std: [0.0, 0.0, 0.0]}
path:
  start: [0, 0, 0]
  segments:
    - {type: line, length_m: 1.0}
    - {type: line, length_m: 1.0, heading_deg: 180, direction: reverse}
    - {type: line, length_m: 1.0, heading_deg: 0}
    - {type: line, length_m: 1.0, heading_deg: 180, direction: reverse}
"""


@pytest.mark.parametrize("name", ["guidance_test", "shuttle"])
def test_the_expected_time_of_a_path_is_its_simulated_duration(name: str) -> None:
    """The total was the path at cruise speed with one pair of ramps: a path that stops at cusps overshot it.

    ``shuttle`` drives 1 m forward and back twice, stopping at each of its three cusps: 15.7 s
    expected, the old total 12.3 s.
    """
    sc = load_scenario(name) if name != "shuttle" else parse_scenario(SHUTTLE)
    built = build(sc)
    expected = expected_sim_time(sc, built)
    times: list[float] = []
    r = simulate(sc, progress=times.append, built=built)
    assert r.completed, r.reason
    assert expected == pytest.approx(times[-1], rel=0.05)


def test_the_bar_ends_full_whatever_the_estimate() -> None:
    """A run past its expected total takes the total along; a run that ends short fills the bar."""
    with RunProgress("long", total=10.0, enabled=True) as bar:
        bar.update(4.0)
        assert bar.fraction == pytest.approx(0.4)
        bar.update(15.0)  # past the estimate
        assert bar.total == 15.0 and bar.fraction == 1.0
    with RunProgress("short", total=10.0, enabled=True) as bar:
        bar.update(3.0)
    assert bar.fraction == 1.0 and bar.done == bar.total == 3.0
    with RunProgress("failed", total=10.0, enabled=False) as bar:
        bar.update(3.0)
        bar.finish()
    assert bar.fraction == 1.0
