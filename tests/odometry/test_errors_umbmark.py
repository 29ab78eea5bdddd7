"""Systematic/non-systematic error injection and UMBmark calibration (Borenstein and Feng 1996)."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.odometry import (
    DifferentialGeometry,
    NonSystematicErrors,
    SystematicErrors,
    TricycleErrors,
    TrueDifferentialVehicle,
    TrueTricycleVehicle,
    estimate_errors,
    integrate_pose,
    square_run,
    tricycle_increments,
    umbmark,
)

NOMINAL = DifferentialGeometry.symmetric(0.1, 0.5)


def test_true_geometry_keeps_mean_radius_and_has_ratio_e_d():
    true = SystematicErrors(e_d=1.005, e_b=1.02).true_geometry(NOMINAL)
    assert true.radius_right / true.radius_left == pytest.approx(1.005)
    assert 0.5 * (true.radius_right + true.radius_left) == pytest.approx(0.1)
    assert true.track == pytest.approx(0.51)
    with pytest.raises(ValueError, match="e_d"):
        SystematicErrors(e_d=0.0)
    with pytest.raises(ValueError, match="track"):
        DifferentialGeometry(0.1, 0.1, -0.5)


def test_nonsystematic_errors_are_seeded_and_bumps_shorten():
    ns = NonSystematicErrors(slip_k=1e-4, bump_rate=2.0, bump_loss=0.01)
    a = TrueDifferentialVehicle(NOMINAL, nonsystematic=ns, seed=3)
    b = TrueDifferentialVehicle(NOMINAL, nonsystematic=ns, seed=3)
    pa = pb = np.zeros(3)
    for _ in range(50):
        pa, pb = a.advance(pa, 1.0, 1.0), b.advance(pb, 1.0, 1.0)
    np.testing.assert_array_equal(pa, pb)
    bumpy = NonSystematicErrors(bump_rate=1.0, bump_loss=0.01)
    ground = bumpy.perturb(np.full(10000, 1.0), np.random.default_rng(0))
    assert np.mean(1.0 - ground) == pytest.approx(0.01, rel=0.05)  # one bump per metre, 1 cm each
    slip = NonSystematicErrors(slip_k=1e-4).perturb(np.full(20000, 2.0), np.random.default_rng(1))
    assert np.var(slip) == pytest.approx(2e-4, rel=0.05)


def test_misalignment_drifts_sideways():
    truth = TrueDifferentialVehicle(NOMINAL, SystematicErrors(misalignment=0.01))
    end = truth.advance(np.zeros(3), 10.0, 10.0)  # 1 m straight by the encoders
    assert end[1] == pytest.approx(np.sin(0.01) * 1.0)


def test_first_order_return_errors_match_formulas():
    """Pure E_b: β = 0 so E_d comes out 1; the CW and CCW errors are mirror images."""
    true = SystematicErrors(e_b=1.01).true_geometry(NOMINAL)
    cw, ccw = square_run(true, NOMINAL, 4.0, True), square_run(true, NOMINAL, 4.0, False)
    alpha = np.pi / 2 * (1 - 1 / 1.01)
    np.testing.assert_allclose(cw, [-2 * 4.0 * alpha, -2 * 4.0 * alpha], rtol=0.05)
    np.testing.assert_allclose(ccw, [-2 * 4.0 * alpha, 2 * 4.0 * alpha], rtol=0.05)
    res = estimate_errors([cw], [ccw], 4.0, 0.5)
    assert res.e_d == pytest.approx(1.0, abs=1e-6) and abs(res.beta) < 1e-6


def test_umbmark_recovers_e_d_and_e_b_and_corrects_odometry():
    true = SystematicErrors(e_d=1.005, e_b=1.02).true_geometry(NOMINAL)
    res, corrected = umbmark(true, NOMINAL, side=4.0, runs=1)
    assert abs(res.e_d - 1.005) < 0.1 * 0.005
    assert abs(res.e_b - 1.02) < 0.1 * 0.02
    before = max(np.hypot(*square_run(true, NOMINAL, 4.0, cw)) for cw in (True, False))
    after = max(np.hypot(*square_run(true, corrected, 4.0, cw)) for cw in (True, False))
    assert before / after >= 10.0
    assert res.e_max_syst == pytest.approx(before)


def test_umbmark_iterations_refine_the_linearised_estimate():
    true = SystematicErrors(e_d=1.005, e_b=1.02).true_geometry(NOMINAL)
    res, corrected = umbmark(true, NOMINAL, side=4.0, runs=1, iterations=3)
    assert res.e_d == pytest.approx(1.005, abs=1e-8) and res.e_b == pytest.approx(1.02, abs=1e-8)
    assert corrected.track == pytest.approx(true.track, rel=1e-8)


def test_umbmark_with_random_errors_still_calibrates():
    """Averaging 5 runs each way with slip and bumps, the systematic part is still found (looser band)."""
    true = SystematicErrors(e_d=1.005, e_b=1.02).true_geometry(NOMINAL)
    ns = NonSystematicErrors(slip_k=1e-6)
    res, _ = umbmark(true, NOMINAL, side=4.0, runs=5, nonsystematic=ns, seed=4)
    assert abs(res.e_b - 1.02) < 0.2 * 0.02 and abs(res.e_d - 1.005) < 0.3 * 0.005
    res2, _ = umbmark(true, NOMINAL, side=4.0, runs=5, nonsystematic=ns, seed=4)
    assert (res2.e_d, res2.e_b) == (res.e_d, res.e_b)  # same seed, same result
    np.testing.assert_array_equal(res2.centroid_cw, res.centroid_cw)


def test_tricycle_truth_vs_nominal_odometry():
    """A 1 % larger traction wheel: the odometry (nominal radius) under-reports a straight run by 1 %."""
    truth = TrueTricycleVehicle(1.3, 0.125, TricycleErrors(radius_scale=1.01, wheelbase_scale=0.98))
    pose_true, pose_odo = np.zeros(3), np.zeros(3)
    for _ in range(100):
        pose_true = truth.advance(pose_true, 1.0, 0.0)
        pose_odo = integrate_pose(pose_odo, *tricycle_increments(0.125, 0.0, 1.3))
    assert pose_true[0] == pytest.approx(1.01 * pose_odo[0])
    # Turning: a shorter true wheelbase turns faster than the odometry believes.
    turned = truth.advance(np.zeros(3), 1.0, 0.5)
    assert turned[2] == pytest.approx(0.125 * 1.01 * np.sin(0.5) / (1.3 * 0.98))
    with pytest.raises(ValueError, match="radius_scale"):
        TricycleErrors(radius_scale=0.0)
