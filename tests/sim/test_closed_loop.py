import math

import numpy as np
import pytest
from tests.sim.conftest import scenario_text

from agvnav.sim import simulate
from agvnav.sim.build import build, reflectors_in_view
from agvnav.sim.metrics import guidance_figures
from agvnav.world.scenario import ScenarioError, default_scenario, parse_scenario

#: Seed 000 §4.3: the straight starts after the 90 deg arc of radius 1.24 m (path abscissa, m).
STRAIGHT_START_M = 1.24 * math.pi / 2.0


def test_same_seed_same_arrays_other_seed_differs(short_scenario):
    a = simulate(short_scenario)
    b = simulate(short_scenario)
    assert a.series.keys() == b.series.keys()
    for name in a.series:
        np.testing.assert_array_equal(a.series[name], b.series[name], err_msg=name)
    for name in a.events["reflections"]:
        np.testing.assert_array_equal(a.events["reflections"][name], b.events["reflections"][name])
    c = simulate(short_scenario.with_seed(7))
    assert not np.array_equal(a.series["x"], c.series["x"])


def test_every_signal_recorded_once_per_step(short_scenario):
    r = simulate(short_scenario)
    n = r.series["t"].size
    dt = short_scenario.step_s
    np.testing.assert_allclose(np.diff(r.series["t"]), dt, atol=1e-12)
    assert r.series["t"][-1] == pytest.approx(4.0)
    for name in ("x", "y", "psi", "gamma", "x_C", "est_x", "v_cmd", "rate_cmd", "eps_c", "xi_r", "ds_meas"):
        assert r.series[name].shape == (n,)
    # C is L_true ahead of O, on the body axis
    L = r.scenario.vehicle.wheelbase_m
    np.testing.assert_allclose(np.hypot(r.series["x_C"] - r.series["x"], r.series["y_C"] - r.series["y"]), L)
    # reflections arrive in time order, inside the run
    tr = r.events["reflections"]["t"]
    assert tr.size > 8 * 4 and np.all(np.diff(tr) >= 0) and tr[-1] <= 4.0


def _seed_guidance(r):
    s = r.series
    return guidance_figures(s["s_true"], s["distance_C"], s["eps_c"], s["xi_r"], STRAIGHT_START_M)


def test_default_scenario_seed_guidance_figures_depend_on_the_controller():
    """Seed 000 §4.3 read as the seed states it (on the straight, 0.5 m past its start; issue 13).

    The default gains keep max |eps_c| under the seed's 16.5 mm and |xi_r| under 3.8 deg;
    the same run with poles three times slower has not corrected the 110 mm by the end of
    the arc, and the same figure exceeds the seed's: the test fails if the controller does.
    """
    r = simulate(default_scenario())
    g = _seed_guidance(r)
    assert r.completed
    assert g.initial_lateral_error_m == pytest.approx(0.110, abs=1e-9)
    assert g.settling_distance_m is not None and 0.3 < g.settling_distance_m < 2.0
    assert g.max_abs_eps_c_after_m is not None and g.max_abs_eps_c_after_m <= 0.0165
    assert g.max_abs_xi_r_after_rad is not None and g.max_abs_xi_r_after_rad <= math.radians(3.8)
    assert r.metrics.positioning_rms_m < 0.01
    end = r.path.end_pose
    assert math.hypot(r.series["x_C"][-1] - end[0], r.series["y_C"][-1] - end[1]) < 0.02
    slow = simulate(parse_scenario(scenario_text(**{"poles_per_m: [-3.0, -3.0]": "poles_per_m: [-1.0, -1.0]"})))
    gs = _seed_guidance(slow)
    assert gs.max_abs_eps_c_after_m is not None and gs.max_abs_eps_c_after_m > 0.0165
    assert gs.settling_distance_m is not None and gs.settling_distance_m > g.settling_distance_m + 1.0


def test_truth_odometry_vs_nominal(short_scenario):
    """A 2 % larger real wheel: encoders (nominal radius) under-read the true distance by 1/1.02."""
    text = scenario_text(**{"wheel_radius_error: 0.003": "wheel_radius_error: 0.02", "slip_std: 0.01": "slip_std: 0.0"})
    text = text.replace("end_hold_s: 1.0", "duration_s: 5.0", 1)
    r = simulate(parse_scenario(text))
    true_d = r.series["distance_C"][-1]
    meas_d = np.sum(np.abs(r.series["ds_meas"]))
    assert meas_d == pytest.approx(true_d / 1.02, abs=2 * 2 * math.pi * 0.1 / 4096)
    # the traction encoder quantises to whole pulses of 2 pi R / N
    q = 2 * math.pi * 0.1 / 4096
    steps = r.series["ds_meas"] / q
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    # the steering encoder rounds to whole pulses too
    qs = 2 * math.pi / 16384
    g = r.series["gamma_meas"] / qs
    np.testing.assert_allclose(g, np.round(g), atol=1e-6)


def test_pose_interpolation_matches_fine_integration(short_scenario):
    from agvnav.kinematics import TricycleStacker

    b = build(short_scenario)
    plant = b.plant
    rng = np.random.default_rng(0)
    plant.advance((0.8, math.radians(60.0)), 0.0, 0.05, rng)
    t = np.linspace(0.0, 0.05, 11)
    got = plant.pose_at(t)
    model = TricycleStacker(plant.L_true)
    ref = np.empty((t.size, 3))
    for i, ti in enumerate(t):
        x = np.array(plant._start)
        n = 40
        for _ in range(n):
            x = model.step(x, np.array(plant._u), ti / n) if ti > 0 else x
        ref[i] = x[:3]
    # 1e-8: a thousandth of the goniometer's encoder resolution (9.6e-5 rad)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-8)


class _FakeEstimator:
    def __init__(self):
        self.calls = []
        self.pose = np.zeros(3)
        self.status = "tracking"

    def predict(self, t, dd, dth, dl=0.0):
        self.calls.append(("p", t, dd, dth))

    def update(self, t, bearing):
        self.calls.append(("u", t, bearing))


def test_engine_splits_odometry_at_measurement_instants(short_scenario):
    b = build(short_scenario)
    fake = _FakeEstimator()
    b.loop.estimator = fake
    (gonio,) = b.loop.sensors
    gonio.estimator = fake  # a sensor feeds the estimator it is wired to
    b.autopilot.profile.reset(0.2)
    out = b.loop.run(2.0)
    times = [c[1] for c in fake.calls]
    assert times == sorted(times)
    ups = [c for c in fake.calls if c[0] == "u"]
    assert len(ups) == out.events["reflections"]["t"].size > 0
    dd = sum(c[2] for c in fake.calls if c[0] == "p")
    assert dd == pytest.approx(np.sum(out.series["odo_dd"]), rel=1e-12, abs=1e-15)
    # every update is preceded by a prediction to the same instant
    for i, c in enumerate(fake.calls):
        if c[0] == "u":
            assert fake.calls[i - 1][0] == "p" and fake.calls[i - 1][1] == c[1]


@pytest.mark.parametrize(
    ("old", "new", "key", "words"),
    [
        ("poles_per_m: [-3.0, -3.0]", "poles_per_m: [3.0, -3.0]", "controller.poles_per_m", ""),
        (
            "    - {type: line, length_m: 3.0}",
            "    - {type: line, length_m: 3.0, start: [9.0, 4.0]}",
            "path.segments[1].start",
            "gap",
        ),
        (
            "map: lab",
            "map: {reflectors: [{id: A, x: 1, y: 1}, {id: B, x: 2, y: 1}], walls: []}",
            "map",
            "reflector(s) in view",
        ),
        ("map: lab", "map: nowhere.yaml", "map", "neither a shipped map"),
        ("radius_m: 1.24", "radius_m: 0.8", "path.segments[0].radius_m", "wheelbase"),
    ],
)
def test_cross_part_errors_name_key_and_line(old, new, key, words):
    text = scenario_text(**{old: new})
    sc = parse_scenario(text, "bad.yaml")
    with pytest.raises(ScenarioError) as info:
        simulate(sc)
    msg = str(info.value)
    line = next(i + 1 for i, ln in enumerate(text.splitlines()) if new.strip() in ln)
    assert msg.startswith("bad.yaml:"), msg
    assert f": {key}: " in msg, msg
    assert words in msg
    assert info.value.line == line


def test_reflectors_in_view_occlusion():
    from agvnav.world.map import WorldMap

    world = WorldMap.from_dict(
        {
            "reflectors": [
                {"id": "A", "x": 5.0, "y": 0.0},
                {"id": "B", "x": 0.0, "y": 5.0},
                {"id": "C", "x": 40, "y": 0},
            ],
            "walls": [{"id": "W", "points": [[2.0, -1.0], [2.0, 1.0]]}],
        }
    )
    counts = reflectors_in_view(world, np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 4.9]]), 0.3, 30.0)
    np.testing.assert_array_equal(counts, [1, 2, 1])


def test_feedforward_start_steering():
    text = scenario_text(**{"steering_deg: 0.0": "steering_deg: feedforward"})
    b = build(parse_scenario(text))
    # C on an arc of radius R: sin(gamma_ss) = L / R (seed 000 eq. 8 at steady state)
    assert b.plant.steering.gamma == pytest.approx(math.asin(1.0 / 1.24), abs=1e-12)


def test_simulate_runs_a_loop_built_beforehand_as_its_own(short_scenario):
    """``simulate(sc, built=build(sc))`` (the CLI builds first to check the scenario) is the same run."""
    own = simulate(short_scenario)
    given = simulate(short_scenario, built=build(short_scenario))
    assert own.series.keys() == given.series.keys()
    for name in own.series:
        np.testing.assert_array_equal(own.series[name], given.series[name], err_msg=name)
    timing = ("wall_time_s", "real_time_factor")
    figures = [{k: v for k, v in r.metrics.to_dict().items() if k not in timing} for r in (own, given)]
    assert figures[0] == figures[1] and own.outcome == given.outcome


@pytest.mark.parametrize(
    ("method", "extra", "fed"),
    [
        ("dead_reckoning", "", "reflections"),  # a goniometer mounted, dead reckoning on purpose
        ("naive", "ultrasonic: {}\n", "ultrasonic"),  # rangers mounted, an estimator of bearings only
    ],
)
def test_a_sensor_whose_kind_the_estimator_does_not_take_is_observed_not_fed(method, extra, fed):
    """Each sensor feeds the estimator of its measurement kind, or none (was an AttributeError traceback)."""
    text = scenario_text("differential_loop", **{"method: ekf": f"method: {method}"}) + extra + "duration_s: 2.0\n"
    sc = parse_scenario(text, "s.yaml")
    built = build(sc)
    role = next(s for s in built.loop.sensors if s.name == fed)
    assert getattr(role, "estimator", "absent") is None
    res = simulate(sc)
    assert res.events[fed]["t"].size > 0  # observed and recorded all the same
    if method == "naive":  # the goniometer still feeds the naive estimator its bearings
        assert next(s for s in built.loop.sensors if s.name == "reflections").estimator is built.estimator
