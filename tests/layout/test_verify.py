"""Closed-loop check of a small plan: the run's EKF models are the truth's; measured vs predicted on one definition."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav.layout import load_layout, parse_layout, plan_layout
from agvnav.layout.generate import generated_hall_dict
from agvnav.layout.schema import LayoutSpec
from agvnav.layout.verify import profile_speed, refine_ramps, route_scenario, verify_plan


def test_route_scenario_tells_the_filter_the_truth(small_text: str) -> None:
    plan = plan_layout(parse_layout(small_text))
    sc = route_scenario(plan, 0, seed=5)
    assert sc.positioning.params["map_std"] == 0.0
    assert sc.world_truth.reflector_survey_std_m == 0.0
    slip = plan.spec.verify.wheel_slip_k
    assert sc.vehicle.truth.slip_k == slip  # type: ignore[union-attr]
    k_d, k_dth, k_th = sc.positioning.odometry_noise
    assert (k_d, k_dth, k_th) == (0.5 * slip, 2.0 * slip / 0.5**2, 0.0)
    assert tuple(sc.positioning.initial_error) == (0.0, 0.0, 0.0)


def test_verify_small_hall_measured_near_predicted(small_text: str) -> None:
    plan = plan_layout(parse_layout(small_text))
    rows = verify_plan(plan, routes=[0])
    assert [r["section"] for r in rows] == ["0-4 m", "4-8 m"]
    for r in rows:
        assert r["outcome"] == "completed" and r["relocalisations"] == 0
        assert r["samples"] > 20
        # the same definition (RMS of the base_link position-error norm): the same order as the prediction
        # (the warehouse bench pools ~0.8; four short sections of one run scatter more)
        assert 0.3 < r["measured_rms_m"] / r["predicted_rms_m"] < 2.0
        assert 0.0 < r["crlb_rms_m"] < 0.01 / 3


def test_shipped_generated_hall_is_the_generator() -> None:
    spec = load_layout("generated_100x60")
    want = generated_hall_dict()
    assert spec.name == want["name"] and len(spec.routes) == len(want["routes"]) == 20
    assert [r.name for r in spec.routes] == [r["name"] for r in want["routes"]]
    assert spec.verify.vehicle == "differential" and spec.goniometer.mount == (0.3, 0.0, 0.0)
    assert [o.id for o in spec.hall.occluders] == [o["id"] for o in want["hall"]["occluders"]]
    assert spec.model_dump(exclude={"seed"}) == LayoutSpec.model_validate(want).model_dump(exclude={"seed"})


def test_speed_must_be_positive(small_text: str) -> None:
    with pytest.raises(ValueError, match="speed_m_s"):
        parse_layout(small_text.replace("verify: {", "verify: {speed_m_s: 0, "))


def test_speed_profile_and_ramp_refinement() -> None:
    s = np.array([0.0, 0.5, 1.0, 1.5, 10.0])
    v = profile_speed(s, 10.0, 1.0, 0.5)
    np.testing.assert_allclose(v, [0.05, math.sqrt(0.5), 1.0, 1.0, 0.05])
    pose = np.column_stack([s, np.zeros(5), np.zeros(5)])
    vis = np.eye(5, dtype=bool)
    rs, rp, rv = refine_ramps(s, pose, vis, 1.0, 0.5)  # ramps: the first and last metre
    assert rs[0] == 0.0 and rs[-1] == 10.0 and np.all(np.diff(rs) > 0)
    assert np.sum(rs <= 1.0) == 51 and np.all(np.diff(rs[rs <= 1.0]) <= 0.02 + 1e-12)
    np.testing.assert_allclose(rp[:, 0], rs)  # interpolated on the line
    assert rv[1].tolist() == vis[1].tolist() and rv[-1].tolist() == vis[4].tolist()
