"""Positioning on recorded data: a simulated run replayed through agvnav.logs.localize reproduces its estimate.

The engine feeds the estimator the step's odometry split at each reflection; localize
does the same from the log, so the only differences are the log's nanosecond stamps
(numerical noise, far below a micrometre). The CSV layout gives the same estimate.
"""

import json

import numpy as np
import pytest

from agvnav.logs import RecordedLog, estimator_from_settings, localize, read_csv_log, read_log, write_run_log
from agvnav.logs.reader import counts_to_increments
from agvnav.sim import simulate
from agvnav.sim.build import build_world
from agvnav.world.scenario import load_scenario


def _short():
    """The seed-000 guidance test's first 10 s (the transient and the straight): a short log."""
    return load_scenario("guidance_test").model_copy(update={"duration_s": 10.0})


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    sc = _short()
    result = simulate(sc)
    path = tmp_path_factory.mktemp("replay") / "run.mcap"
    write_run_log(result, path)
    return result, read_log(path), build_world(sc)


def _compare(series, reference, tol_m):
    for c in ("est_x", "est_y"):
        assert np.max(np.abs(series[c] - reference[c])) < tol_m, c
    assert np.max(np.abs(series["est_psi"] - reference["est_psi"])) < tol_m
    np.testing.assert_array_equal(series["est_status"], reference["est_status"])
    for c in ("est_cov_xx", "est_cov_yy", "est_cov_psipsi"):
        np.testing.assert_allclose(series[c], reference[c], rtol=1e-6, atol=1e-14)


def test_replaying_the_log_reproduces_the_simulation_estimate(recorded):
    result, log, world = recorded
    loc = localize(log, estimator_from_settings(log.settings, world))
    assert loc.method == "ekf" and loc.n_reflections == result.events["reflections"]["t"].size
    assert loc.n_accepted > 0.8 * loc.n_reflections and loc.late_rejected == 0
    _compare(loc.series, result.series, 1e-7)


def test_a_perturbed_replay_does_not_reproduce_it(recorded):
    """The comparison can fail: one bearing off by a milliradian changes the estimate."""
    result, log, world = recorded
    bearing = log.bearing.copy()
    bearing[len(bearing) // 3] += 1e-3
    bent = RecordedLog(log.t, log.increments, log.reflection_t, log.reflection_stamp, bearing, log.settings)
    loc = localize(bent, estimator_from_settings(log.settings, world))
    with pytest.raises(AssertionError):
        _compare(loc.series, result.series, 1e-7)


def test_the_csv_layout_gives_the_same_estimate(recorded, tmp_path):
    result, log, world = recorded
    s, refl = result.series, result.events["reflections"]
    odo = np.column_stack([s["t"], s["odo_dd"], s["odo_dtheta"]])
    np.savetxt(tmp_path / "odometry.csv", odo, delimiter=",", header="t,delta_d,delta_theta", comments="", fmt="%.17g")
    np.savetxt(tmp_path / "reflections.csv", np.column_stack([refl["t"], refl["bearing"]]), delimiter=",",
               header="t,bearing", comments="", fmt="%.17g")
    np.savetxt(tmp_path / "truth.csv", np.column_stack([s["t"], s["x"], s["y"], s["psi"]]), delimiter=",",
               header="t,x,y,psi", comments="", fmt="%.17g")
    (tmp_path / "settings.json").write_text(json.dumps(log.settings), encoding="utf-8")
    csv_log = read_csv_log(tmp_path)
    np.testing.assert_allclose(csv_log.truth, np.column_stack([s["x"], s["y"], s["psi"]]), atol=1e-12)
    loc = localize(csv_log, estimator_from_settings(csv_log.settings, world))
    _compare(loc.series, result.series, 1e-7)


def _head(log: RecordedLog, steps: int) -> RecordedLog:
    """The first ``steps`` odometry intervals of ``log`` and the reflections arriving in them."""
    keep = log.reflection_t <= log.t[steps]
    return RecordedLog(log.t[: steps + 1], log.increments[:steps], log.reflection_t[keep],
                       log.reflection_stamp[keep], log.bearing[keep], log.settings, truth=log.truth[: steps + 1])


def test_another_method_runs_on_the_log_and_tracks(recorded):
    _, log, world = recorded
    head = _head(log, 120)
    loc = localize(head, estimator_from_settings(log.settings, world, "naive"), "naive")
    tracking = loc.series["est_status"] == 1.0
    assert loc.method == "naive" and tracking.mean() > 0.9
    err = np.hypot(loc.series["est_x"] - head.truth[:, 0], loc.series["est_y"] - head.truth[:, 1])
    assert np.median(err[tracking]) < 0.05  # within centimetres of the truth


def test_a_stale_stamp_is_counted_late_not_fatal(recorded):
    _, log, world = recorded
    stamps = log.reflection_stamp.copy()
    stamps[200] = stamps[200] - 1.0  # a reflection that says it was measured a second before it arrived
    late = RecordedLog(log.t, log.increments, log.reflection_t, stamps, log.bearing, log.settings)
    loc = localize(late, estimator_from_settings(log.settings, world))
    assert loc.late_rejected == 1


def test_bad_logs_are_refused_naming_the_problem(recorded, tmp_path):
    _, log, world = recorded
    with pytest.raises(ValueError, match="increase strictly"):
        RecordedLog(log.t[::-1], log.increments, log.reflection_t, log.reflection_stamp, log.bearing)
    with pytest.raises(ValueError, match="must not decrease"):
        RecordedLog(log.t, log.increments, log.reflection_t[::-1], log.reflection_stamp, log.bearing)
    (tmp_path / "odometry.csv").write_text("t,delta_d\n0,0\n1,0.1\n", encoding="utf-8")
    (tmp_path / "reflections.csv").write_text("t,bearing\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"odometry\.csv.*delta_theta"):
        read_csv_log(tmp_path)
    with pytest.raises(ValueError, match="unknown positioning method"):
        estimator_from_settings(log.settings, world, "astrology")
    with pytest.raises(ValueError, match=r"an \.mcap file or a folder"):
        read_log(tmp_path / "nothing.txt")


def test_a_holonomic_vehicle_replays_with_its_lateral_increments(tmp_path):
    """The mecanum vehicle's odometry has a sideways part (/odom twist linear.y): replayed too."""
    sc = load_scenario("mecanum_loop").model_copy(update={"duration_s": 4.0})
    result = simulate(sc)
    assert np.any(np.abs(result.series["odo_dlat"]) > 1e-6)
    write_run_log(result, tmp_path / "m.mcap")
    log = read_log(tmp_path / "m.mcap")
    np.testing.assert_allclose(log.increments[:, 2], result.series["odo_dlat"][1:], rtol=1e-12, atol=1e-15)
    loc = localize(log, estimator_from_settings(log.settings, build_world(sc)))
    _compare(loc.series, result.series, 1e-7)


def test_encoder_counts_give_the_arc_increments_even_across_a_counter_wrap(tmp_path):
    """Arc of radius 2 m, track 0.5 m, 0.01 rad per row, 0.1 mm per count: ΔD = R Δθ [seed002 eq22]."""
    n = 50
    right = 65000 + 225 * np.arange(n)  # passes 65535: a 16-bit counter wraps
    left = 175 * np.arange(n)
    enc = {"metres_per_count_right": 1e-4, "metres_per_count_left": 1e-4, "track_m": 0.5, "counter_bits": 16}
    inc = counts_to_increments(right % 65536, left, enc)
    np.testing.assert_allclose(inc, np.tile([0.02, 0.01, 0.0], (n - 1, 1)), atol=1e-12)
    t = np.arange(n) * 0.05
    np.savetxt(tmp_path / "odometry.csv", np.column_stack([t, right % 65536, left]), delimiter=",",
               header="t,counts_right,counts_left", comments="", fmt="%.17g")
    (tmp_path / "reflections.csv").write_text("t,bearing\n0.07,0.5\n", encoding="utf-8")
    with pytest.raises(ValueError, match="encoders"):
        read_csv_log(tmp_path)
    (tmp_path / "settings.json").write_text(json.dumps({"encoders": enc}), encoding="utf-8")
    np.testing.assert_allclose(read_csv_log(tmp_path).increments, inc)
    with pytest.raises(ValueError, match="track_m"):
        counts_to_increments(right, left, {"metres_per_count_right": 1e-4, "metres_per_count_left": 1e-4})
