"""Run plans: per-run seeds derived from the campaign seed (SeedSequence children), grid order, random draws."""

import numpy as np
import pytest

from agvnav.campaign import load_campaign, plan_runs, run_seed


def test_run_seed_is_the_spawned_child():
    children = np.random.SeedSequence(42).spawn(5)
    for i, child in enumerate(children):
        assert run_seed(42, i) == int(child.generate_state(1, np.uint64)[0]) >> 1
    assert 0 <= run_seed(42, 3) < 2**63


def test_run_seed_refuses_negative():
    with pytest.raises(ValueError, match="must be >= 0"):
        run_seed(-1, 0)


def test_same_campaign_seed_same_plan(write_campaign):
    body = (
        "seed: 9\nseeds: 3\ngrid:\n  traction.speed_m_s: [0.2, 0.3]\n"
        "random:\n  goniometer.p_miss: {uniform: [0.0, 0.2]}\n"
    )
    a = plan_runs(load_campaign(write_campaign(body, name="a.yaml")))
    b = plan_runs(load_campaign(write_campaign(body, name="b.yaml")))
    assert a == b
    other = plan_runs(load_campaign(write_campaign(body.replace("seed: 9", "seed: 10"), name="c.yaml")))
    assert [p.seed for p in other] != [p.seed for p in a]


def test_grid_order_and_seeds(write_campaign):
    body = "seed: 1\nseeds: 2\ngrid:\n  traction.speed_m_s: [0.2, 0.3]\n  goniometer.p_miss: [0.0, 0.1]\n"
    plans = plan_runs(load_campaign(write_campaign(body)))
    assert [p.index for p in plans] == list(range(8))
    assert [(p.params["traction.speed_m_s"], p.params["goniometer.p_miss"]) for p in plans[::2]] == [
        (0.2, 0.0), (0.2, 0.1), (0.3, 0.0), (0.3, 0.1)
    ]
    assert [p.seed for p in plans] == [run_seed(1, i) for i in range(8)]
    assert len({p.seed for p in plans}) == 8


def test_common_seeds_repeat_across_grid_points(write_campaign):
    body = "seed: 1\nseeds: 3\ncommon_seeds: true\ngrid:\n  traction.speed_m_s: [0.2, 0.3]\n"
    plans = plan_runs(load_campaign(write_campaign(body)))
    assert [p.seed for p in plans] == [run_seed(1, r) for r in (0, 1, 2, 0, 1, 2)]


def test_random_draws_within_range_and_reproducible(write_campaign):
    body = (
        "seed: 5\nruns: 200\nrandom:\n  goniometer.p_miss: {uniform: [0.05, 0.1]}\n"
        "  traction.speed_m_s: {normal: [0.3, 0.01]}\n  controller.name: {choice: [seed_simple, stanley]}\n"
    )
    plans = plan_runs(load_campaign(write_campaign(body)))
    p_miss = np.array([p.params["goniometer.p_miss"] for p in plans])
    speed = np.array([p.params["traction.speed_m_s"] for p in plans])
    assert np.all((p_miss >= 0.05) & (p_miss < 0.1)) and abs(np.mean(p_miss) - 0.075) < 0.005
    assert abs(np.mean(speed) - 0.3) < 0.005 and 0.005 < np.std(speed) < 0.015
    assert {p.params["controller.name"] for p in plans} == {"seed_simple", "stanley"}
    # a run's draws depend on its index only: a longer campaign keeps the first runs
    longer = plan_runs(load_campaign(write_campaign(body.replace("runs: 200", "runs: 300"), name="d.yaml")))
    assert longer[:200] == plans
