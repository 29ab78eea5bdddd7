"""Integrity figures and outcome reasons (issue 12 §2): synthetic series and short closed-loop runs."""

import math

import numpy as np
import pytest
from tests.sim.conftest import scenario_text

import agvnav.sim.build as build_mod
import agvnav.sim.run as run_mod
from agvnav.guidance import GuidanceError
from agvnav.sim import simulate
from agvnav.sim.integrity import CHI2_3_95, integrity_figures, longest_run, nees, silent_mask, stop_episodes
from agvnav.world.scenario import builtin_scenario, parse_scenario


def test_nees_against_the_explicit_formula_and_its_chi2_mean():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(500, 3, 3))
    P = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(3)
    e = np.einsum("nij,nj->ni", np.linalg.cholesky(P), rng.normal(size=(500, 3)))
    eps = nees(e, P)
    k = 7
    assert eps[k] == pytest.approx(e[k] @ np.linalg.inv(P[k]) @ e[k], rel=1e-10)
    assert abs(np.mean(eps) - 3.0) < 0.4  # consistent by construction: chi2(3), mean 3
    assert np.mean(eps > CHI2_3_95) == pytest.approx(0.05, abs=0.03)
    P[3] = 0.0
    P[4, 0, 0] = np.nan
    assert np.isnan(nees(e, P)[3]) and np.isnan(nees(e, P)[4])
    with pytest.raises(ValueError):
        nees(e, P[:, :2, :2])


def test_longest_run():
    t = np.arange(10) * 0.5
    assert longest_run(t, [0, 1, 1, 1, 0, 1, 1, 0, 0, 0]) == 1.5
    assert longest_run(t, np.zeros(10)) == 0.0
    assert longest_run([0.0], [1]) == 0.0


def _series(n=11, err=0.0, sigma=0.01, status=1.0):
    t = np.arange(n) * 0.2
    z = np.zeros(n)
    s = {"t": t, "x": z, "y": z, "psi": z, "est_x": z + err, "est_y": z, "est_psi": z, "est_status": z + status}
    for k in ("est_cov_xy", "est_cov_xpsi", "est_cov_ypsi"):
        s[k] = z.copy()
    s["est_cov_xx"] = s["est_cov_yy"] = z + sigma**2
    s["est_cov_psipsi"] = z + 1e-4
    return s


@pytest.mark.parametrize(
    ("err", "sigma", "status", "silent"),
    [
        (0.03, 0.01, 1.0, False),  # 3 sigma, 3 cm: honest
        (0.06, 0.01, 1.0, True),  # 6 sigma while tracking: silent
        (0.15, 0.1, 1.0, True),  # 1.5 sigma but 15 cm: silent
        (0.5, 0.01, 2.0, False),  # far off, but the status says dead reckoning: not silent
        (0.5, 0.01, 4.0, False),  # ... or lost
    ],
)
def test_silent_mask(err, sigma, status, silent):
    assert bool(np.all(silent_mask(_series(err=err, sigma=sigma, status=status)))) is silent


def test_stop_episodes_distance_until_standstill_or_release():
    t = np.arange(12) * 0.1
    level = np.array([0, 0, 2, 2, 2, 2, 0, 0, 2, 0, 0, 0])
    speed = np.array([0.5, 0.5, 0.4, 0.2, 0.0, 0.0, 0.1, 0.3, 0.3, 0.5, 0.5, 0.5])
    dist = np.cumsum(speed) * 0.1
    ep = stop_episodes(t, level, speed, dist, max_decel=0.5)
    assert len(ep) == 2
    assert ep[0]["t"] == pytest.approx(0.2) and ep[0]["speed"] == 0.5 and ep[0]["standstill"] == 1.0
    assert ep[0]["braking"] == pytest.approx(0.25) and ep[0]["distance"] == pytest.approx(0.02 + 0.0)
    assert ep[1]["standstill"] == 0.0 and ep[1]["distance"] == 0.0  # released on the next sample


def _run(text, name):
    return simulate(parse_scenario(text, name))


def test_driving_into_a_pillar_fails_with_collision():
    text = scenario_text(
        **{"  start: [5.5, 2.0, 0.0]": "  start: [2.0, 6.5, 0.0]",
           "    - {type: arc, radius_m: 1.24, sweep_deg: 90.0}\n": "",
           "  lateral_offset_m: 0.110": "  lateral_offset_m: 0.0"}
    )
    # the lab's pillar P1 stands at x 4.8..5.2, y 5.8..6.2; the 0.9 m wide body passes along y = 6.5
    r = _run(text, "pillar.yaml")
    assert r.outcome == "failed" and r.reason == "collision"
    assert r.series["t"][-1] < 15.0  # the run ended at the collision, not at the time limit


def test_blind_goniometer_stops_the_vehicle_and_the_run_fails_positioning_lost():
    text = scenario_text(**{"end_hold_s: 1.0": "end_hold_s: 1.0\nduration_s: 10.0"}) + (
        "safety: {lateral_3sigma_slow_m: 0.0605, lateral_3sigma_stop_m: 0.062, resume_after_s: 0.5}\n"
        "faults:\n  - {kind: blind, start_s: 0.0}\n"
    )
    r = _run(text, "blind.yaml")
    assert r.outcome == "failed" and r.reason == "positioning_lost"
    fig = r.integrity
    assert fig["stop_demands"] >= 1 and fig["time_stopped_for_positioning_s"] > 1.0
    assert fig["stops_within_braking_distance"] is True
    assert fig["time_in_status_s"]["dead_reckoning"] > 8.0
    assert np.all(r.series["v_cmd"][-5:] == 0.0)
    q = [fig[k] for k in ("quality_min", "quality_p5", "quality_p50", "quality_p95")]
    assert all(v is None for v in q) or (0.0 <= q[0] <= q[1] <= q[2] <= q[3] <= 1.0)  # null without a figure


def test_no_fault_run_completes_with_its_integrity_figures(short_scenario):
    r = simulate(short_scenario)
    fig = r.integrity
    assert fig["time_in_status_s"] == {"tracking": pytest.approx(4.0)}
    assert fig["stop_demands"] == 0 and fig["time_stopped_for_positioning_s"] == 0.0
    assert fig["max_true_lateral_error_m"] == pytest.approx(np.max(np.abs(r.series["lateral_error"])))
    assert fig["nees_samples"] == r.series["t"].size and math.isfinite(fig["nees_mean"])
    used = r.series["est_reflectors_used"]
    assert fig["reflectors_used_min"] == float(np.nanmin(used)) and fig["reflectors_used_p50"] >= 3.0
    assert fig["n_dropped"] == 0 and np.all(r.series["est_n_dropped"] == 0.0)


def test_reflectors_used_and_dropped_readings_in_the_figures():
    s = _series(n=11)
    s.update(lateral_error=np.zeros(11), v_cmd=np.zeros(11), guard_level=np.zeros(11), est_quality=np.full(11, 0.9),
             est_reflectors_used=np.array([np.nan, 3, 4, 4, 5, 5, 5, 6, 6, 6, 6], float),
             est_n_dropped=np.array([0, 0, 1, 1, 1, 2, 2, 2, 2, 3, np.nan], float))
    fig = integrity_figures(s, np.zeros(11), 0.5)
    assert fig["reflectors_used_min"] == 3.0 and fig["reflectors_used_p50"] == 5.0
    assert fig["reflectors_used_p95"] == pytest.approx(np.percentile([3, 4, 4, 5, 5, 5, 6, 6, 6, 6], 95))
    assert fig["n_dropped"] == 3  # the count at the end (NaN samples skipped)
    del s["est_reflectors_used"], s["est_n_dropped"]  # an older recording: no such columns
    fig = integrity_figures(s, np.zeros(11), 0.5)
    assert fig["reflectors_used_min"] is None and fig["n_dropped"] is None


class _FailingFollower:
    last_errors = None

    def set_path(self, path):
        pass

    def command(self, pose, v, steering=0.0):
        raise GuidanceError("cannot steer this")


def test_a_follower_failure_ends_the_run_infeasible(short_scenario, monkeypatch):
    real = build_mod.build

    def failing_build(sc):
        b = real(sc)
        b.autopilot.follower = _FailingFollower()
        return b

    monkeypatch.setattr(run_mod, "build", failing_build)
    r = simulate(short_scenario)
    assert r.outcome == "failed" and r.reason == "infeasible"
    assert r.series["t"][-1] <= 1.0 + 1e-9 + short_scenario.step_s  # the end hold, not the time limit


class _EagerFollower:
    """Commands a sidestep and a turn even at zero speed."""

    last_errors = None
    last_twist = (0.0, 0.1, 0.5)

    def set_path(self, path):
        pass

    def command(self, pose, v, steering=0.0):
        self.last_twist = (v, 0.1, 0.5)
        return 0.1, 0.5


@pytest.mark.parametrize("name", ["differential_loop", "mecanum_loop"])
def test_a_vehicle_stopped_for_positioning_holds_still(name):
    """Stopped by the guard, a follower's correction must not turn or sidestep the vehicle."""
    b = build_mod.build(parse_scenario(scenario_text(name), name))
    pilot = b.autopilot
    pilot.follower = _EagerFollower()
    est = b.estimator
    assert any(c != 0.0 for c in pilot.command(0.0, est, b.plant, 0.05))  # the follower does command motion

    class _Lost:
        status, pose, covariance = "lost", est.pose, est.covariance

    for k in range(1, 100):  # brake at the deceleration limit, then stand
        cmd = pilot.command(0.05 * k, _Lost(), b.plant, 0.05)
    assert pilot.signals()[0] == 0.0 and all(c == 0.0 for c in cmd)


@pytest.mark.parametrize("name", ["guidance_test", "differential_loop", "mecanum_loop"])
def test_an_undefined_estimate_while_moving_brakes_at_the_deceleration_limit(name):
    sc = parse_scenario(scenario_text(name), name)
    b = build_mod.build(sc)
    pilot, est = b.autopilot, b.estimator
    pilot.profile.reset(0.2)
    pilot.command(0.0, est, b.plant, 0.05)
    v0 = pilot.signals()[0]

    class _Undefined:
        status, pose, covariance = "initialising", np.full(3, np.nan), np.full((3, 3), np.nan)

    speeds = []
    for k in range(1, 40):
        cmd = pilot.command(0.05 * k, _Undefined(), b.plant, 0.05)
        speeds.append(pilot.signals()[0])
    expected = np.maximum(v0 - sc.traction.max_decel_m_s2 * 0.05 * np.arange(1, 40), 0.0)
    np.testing.assert_allclose(speeds, expected, atol=1e-9)
    assert all(c == 0.0 for c in cmd)


def test_true_lateral_error_does_not_follow_a_wrong_estimate_along_the_path():
    """The truth 2 cm left of the path throughout; for 2 s the estimate (and its progress) sits
    at the path's end, as after a wrong relocalisation: the true lateral error stays 2 cm."""
    built = build_mod.build(parse_scenario(builtin_scenario("differential_loop").read_text(), "differential_loop"))
    path = built.path
    s = np.linspace(0.0, 0.5 * path.length, 201)
    psi = path.heading_at(s)
    xy = path.point_at(s) + 0.02 * np.column_stack([-np.sin(psi), np.cos(psi)])
    wrong = slice(80, 121)
    est_xy, s_est = xy.copy(), s.copy()
    est_xy[wrong], s_est[wrong] = path.point_at(path.length), path.length
    series = {"x": xy[:, 0], "y": xy[:, 1], "psi": psi, "est_x": est_xy[:, 0], "est_y": est_xy[:, 1],
              "s_est": s_est, "distance": s.copy()}
    run_mod._add_true_errors(series, built)
    assert np.allclose(series["lateral_error"], 0.02, atol=1e-9)
    assert np.allclose(series["s_true"], s, atol=1e-6)
