"""The reaction state machine: warning slows, protective stops, resume after a clear hold (issue 18)."""

from __future__ import annotations

import pytest

from agvnav.reactive import Reaction, ReactionLimits, field_demand


def test_transitions_and_hold():
    r = Reaction(ReactionLimits(slow_speed_fraction=0.4, resume_after_s=1.0))
    assert r.update(0.0, 0) == 1.0 and r.state == "clear"
    assert r.update(0.1, field_demand(False, True)) == 0.4 and r.state == "slow"
    assert r.update(0.2, field_demand(True, True)) == 0.0 and r.state == "stop"
    assert r.stops == 1
    # clear from 0.3 s: still stopped until the field has been clear for 1 s
    assert r.update(0.3, 0) == 0.0
    assert r.update(1.2, 0) == 0.0
    assert r.update(1.3, 0) == 1.0 and r.state == "clear"
    assert [(a, b) for _, a, b in r.transitions] == [(0, 1), (1, 2), (2, 0)]


def test_worse_demand_during_the_hold_restarts_it():
    r = Reaction(ReactionLimits(0.3, 1.0))
    r.update(0.0, 2)
    r.update(0.1, 0)        # hold starts
    r.update(0.5, 1)        # warned again: the hold restarts at 0.5 s
    assert r.update(1.2, 0) == 0.0  # 0.7 s since the restart
    assert r.update(1.5, 0) == 1.0 and r.state == "clear"  # 1 s after 0.5 s: down to the demanded level


def test_disabled_reaction_never_slows():
    r = Reaction(enabled=False)
    assert r.update(0.0, 2) == 1.0 and r.scale == 1.0


def test_bad_input():
    with pytest.raises(ValueError, match="demand"):
        Reaction().update(0.0, 3)
    with pytest.raises(ValueError, match="slow_speed_fraction"):
        ReactionLimits(slow_speed_fraction=0.0)
