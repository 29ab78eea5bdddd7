"""The one progress helper: quiet off a terminal, passes that restart add up, remembered durations."""

from __future__ import annotations

import json

from agvnav.cli.progress import RunProgress


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
