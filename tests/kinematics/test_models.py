"""Model-specific analytic cases (seeds 000, 002, 003, 004)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.kinematics import (
    TERRAIN_PRESETS,
    Ackermann,
    DifferentialDrive,
    MecanumBase,
    TrackedVehicle,
    TrackTerrain,
    TractorTrailer,
    TricycleRearDrive,
    TricycleStacker,
    TricycleStackerSimple,
    castor_heading_rate,
    castor_wheel_residual,
    fixed_wheel_residual,
    point_velocity,
    rolling_residual,
    steered_wheel_residual,
    swedish_wheel_residual,
    terrain_preset,
    turning_radius,
)

speed = st.floats(-2.0, 2.0)


# ------------------------------------------------------------------ differential
@given(vr=speed, vl=speed)
def test_constant_wheel_speeds_give_arc_of_seed_radius(vr, vl):
    """Seed 002 eq. 4: R = L(v_R+v_L)/(2(v_R−v_L)); every point of the path is R from the ICR."""
    if abs(vr - vl) < 1e-3:
        return
    dd = DifferentialDrive(track=0.5)
    u = dd.input_from_wheel_speeds([vr, vl])
    x0 = np.array([0.3, -0.2, 0.4])
    centre, radius = dd.icr(x0, u)
    assert radius == pytest.approx(0.5 * (vr + vl) / (2 * (vr - vl)))
    path = np.stack([dd.step(x0, u, t) for t in np.linspace(0.1, 3.0, 7)])
    dist = np.hypot(path[:, 0] - centre[0], path[:, 1] - centre[1])
    np.testing.assert_allclose(dist, abs(radius), atol=1e-12)


def test_turning_radius_special_cases():
    r = turning_radius([1.0, 1.0, 0.0, -1.0], [1.0, -1.0, 0.0, 1.0], 0.5)
    assert r[0] == np.inf and r[1] == 0.0 and np.isnan(r[2]) and r[3] == 0.0


@given(v=speed, w=st.floats(-3.0, 3.0))
def test_wheel_rates_round_trip_seed_004(v, w):
    """Seed 004 eqs. 1-2 (inverse) then seed 002 eqs. 6-8 (forward) give back (v, ω)."""
    dd = DifferentialDrive(track=0.4, wheel_radius=0.06)
    rates = dd.wheel_rates([v, w])
    assert rates[0] == pytest.approx((2 * v + w * 0.4) / (2 * 0.06))
    assert rates[1] == pytest.approx((2 * v - w * 0.4) / (2 * 0.06))
    np.testing.assert_allclose(dd.input_from_wheel_rates(rates), [v, w], atol=1e-12)


def test_differential_wheels_roll_without_slip():
    """Both fixed wheels' seed-003 constraints (lateral and rolling) hold."""
    dd = DifferentialDrive(track=0.5, wheel_radius=0.1)
    x, u = np.array([1.0, 2.0, 0.3]), np.array([0.7, 0.9])
    qd = dd.derivative(x, u)
    for y_b, rate in zip((-0.25, 0.25), dd.wheel_rates(u), strict=True):
        assert abs(fixed_wheel_residual(x, qd, [0.0, y_b, 0.0])) < 1e-12
        v_contact = point_velocity(x, qd, [0.0, y_b])
        assert abs(rolling_residual(v_contact, x[2], rate, 0.1)) < 1e-12


def test_differential_wheel_speed_limit():
    dd = DifferentialDrive(track=0.5, max_wheel_speed=1.0)
    with pytest.raises(ValueError, match="wheel speed"):
        dd.check_input([0.9, 1.0])
    dd.check_input([0.5, 1.0])
    with pytest.raises(ValueError, match="track"):
        DifferentialDrive(track=-0.5)


# ---------------------------------------------------------------------- tricycle
def test_stacker_follows_seed_000_eq_8():
    tri = TricycleStacker(wheelbase=1.3)
    x = np.array([0.0, 0.0, 0.2, 0.4])
    f = tri.derivative(x, [0.5, 0.1])
    np.testing.assert_allclose(f, [0.5 * np.cos(0.4) * np.cos(0.2), 0.5 * np.cos(0.4) * np.sin(0.2),
                                   0.5 * np.sin(0.4) / 1.3, 0.1])


def test_stacker_point_c_speed_is_v_along_the_wheel():
    """C moves at speed v in the direction ψ+γ (the drive wheel rolls without slip)."""
    tri = TricycleStacker(wheelbase=1.3)
    x, u = np.array([0.5, -1.0, 0.7, -0.5]), np.array([0.8, 0.0])
    qd = tri.derivative(x, u)
    v_c = point_velocity(x[:3], qd[:3], [1.3, 0.0])
    np.testing.assert_allclose(v_c, 0.8 * np.array([np.cos(0.2), np.sin(0.2)]), atol=1e-12)
    np.testing.assert_allclose(tri.point_c(x), [0.5 + 1.3 * np.cos(0.7), -1.0 + 1.3 * np.sin(0.7)])


def test_tricycle_wheels_satisfy_seed_003_constraints_along_trajectory():
    tri = TricycleStacker(wheelbase=1.3, max_steer_rate=1.0)
    rng = np.random.default_rng(7)
    x = np.array([0.0, 0.0, 0.0, 0.1])
    for _ in range(200):
        u = np.array([rng.uniform(-1, 1), rng.uniform(-0.5, 0.5)])
        qd = tri.derivative(x, u)
        assert abs(fixed_wheel_residual(x[:3], qd[:3], [0.0, 0.4, 0.0])) < 1e-12
        assert abs(fixed_wheel_residual(x[:3], qd[:3], [0.0, -0.4, 0.0])) < 1e-12
        assert abs(steered_wheel_residual(x[:3], qd[:3], [1.3, 0.0], x[3])) < 1e-12
        x = tri.step(x, u, 0.02)
        x[3] = np.clip(x[3], -1.2, 1.2)


def test_constant_steering_is_an_exact_circle():
    tri = TricycleStackerSimple(wheelbase=1.3)
    gamma, v = 0.5, 0.4
    radius = 1.3 / np.tan(gamma)
    x0 = np.array([0.0, 0.0, 0.0])
    pts = np.stack([tri.step(x0, [v, gamma], t) for t in (1.0, 5.0, 20.0)])
    np.testing.assert_allclose(np.hypot(pts[:, 0], pts[:, 1] - radius), radius, atol=1e-12)
    np.testing.assert_allclose(pts[:, 2], v * np.sin(gamma) / 1.3 * np.array([1.0, 5.0, 20.0]), atol=1e-12)


@given(u_o=st.floats(0.05, 2.0) | st.floats(-2.0, -0.05), w=st.floats(-1.0, 1.0))
def test_tricycle_inverse_round_trip(u_o, w):
    for tri in (TricycleStacker(wheelbase=1.3), TricycleRearDrive(wheelbase=1.3, max_steer=1.55)):
        drive, steer = tri.inverse(u_o, w)
        speed, omega = tri._twist(drive, steer)
        assert speed == pytest.approx(u_o, abs=1e-12) and omega == pytest.approx(w, abs=1e-12)
        assert tri.steer_for_curvature(w / u_o) == pytest.approx(steer)


def test_tricycle_limits_named():
    tri = TricycleStacker(wheelbase=1.3, max_steer_rate=0.5)
    with pytest.raises(ValueError, match="gamma"):
        tri.check_state([0, 0, 0, np.pi / 2])  # −90° < γ < 90° is exclusive (seed 000)
    tri.check_state([0, 0, 0, np.pi / 2 - 1e-6])
    with pytest.raises(ValueError, match="gamma_dot"):
        tri.check_input([0.1, 0.6])
    with pytest.raises(ValueError, match="wheelbase"):
        TricycleStacker(wheelbase=-1.0)
    with pytest.raises(ValueError, match="max_steer"):
        TricycleStacker(wheelbase=1.0, max_steer=2.0)
    with pytest.raises(ValueError, match="gamma"):
        TricycleStackerSimple(wheelbase=1.0, max_steer=0.5).check_input([1.0, 0.6])
    with pytest.raises(ValueError, match="phi"):
        TricycleRearDrive(wheelbase=1.0, max_steer=0.5).check_state([0, 0, 0, -0.51])


def test_model_a_and_b_agree_on_the_path_of_o():
    """Rear traction V and front traction V_d = V/cos φ describe the same motion of O (seed 003)."""
    a, b = TricycleRearDrive(1.0, max_steer=1.2), TricycleStacker(1.0)
    x = np.array([0.0, 0.0, 0.3, 0.6])
    np.testing.assert_allclose(a.derivative(x, [0.5, 0.2]), b.derivative(x, [0.5 / np.cos(0.6), 0.2]), atol=1e-12)


# --------------------------------------------------------------------- Ackermann
@given(phi=st.floats(-0.7, 0.7))
def test_ackermann_wheel_axes_meet_at_the_icr(phi):
    car = Ackermann(wheelbase=2.5, track=1.5)
    x, u = np.array([1.0, 2.0, 0.3, phi]), np.array([3.0, 0.0])
    qd = car.derivative(x, u)
    left, right = car.wheel_angles(phi)
    pos = car.wheel_positions()
    assert abs(steered_wheel_residual(x[:3], qd[:3], pos[0], left)) < 1e-9
    assert abs(steered_wheel_residual(x[:3], qd[:3], pos[1], right)) < 1e-9
    for p in pos[2:]:
        assert abs(fixed_wheel_residual(x[:3], qd[:3], [p[0], p[1], 0.0])) < 1e-12
    if phi > 0.01:
        assert left > phi > right  # the inner wheel turns more


# ---------------------------------------------------------------- tractor-trailer
def test_trailer_axle_rolls_without_slip_along_trajectory():
    tt = TractorTrailer(trailer_length=2.0, hitch_offset=0.6)
    x = np.array([0.0, 0.0, 0.0, 0.2])
    rng = np.random.default_rng(8)
    for _ in range(200):
        u = np.array([rng.uniform(0.2, 1.0), rng.uniform(-0.4, 0.4)])
        trailer, tv = tt.trailer_pose(x), tt.trailer_velocity(x, u)
        assert abs(fixed_wheel_residual(trailer, tv, [0.0, 0.0, 0.0])) < 1e-12
        x = tt.step(x, u, 0.05)


def test_trailer_settles_to_equilibrium_and_jackknife_check():
    tt = TractorTrailer(trailer_length=2.0, hitch_offset=0.6, max_hitch_angle=np.deg2rad(80))
    kappa = 0.3
    x = np.array([0.0, 0.0, 0.0, 0.0])
    for _ in range(1500):
        x = tt.step(x, [1.0, kappa], 0.05)
    assert x[3] == pytest.approx(tt.equilibrium_hitch_angle(kappa), abs=1e-6)
    # Reversing straight from a bent hitch folds the trailer until it jackknifes.
    # The validated step refuses to end in a jackknife; the unchecked kernel integrates into it.
    with pytest.raises(ValueError, match=r"after a step.*jackknife"):
        for _ in range(400):
            x = tt.step(x, [-1.0, 0.0], 0.05)
    x = tt.step_unchecked(x, [-1.0, 0.0], 0.05)
    assert tt.jackknifed(x)
    with pytest.raises(ValueError, match="jackknife"):
        tt.check_state(x)
    with pytest.raises(ValueError, match="trailer_length"):
        TractorTrailer(trailer_length=0.0)


# ---------------------------------------------------------------------- mecanum
@given(vx=speed, vy=speed, w=speed)
def test_mecanum_round_trip_and_swedish_constraints(vx, vy, w):
    base = MecanumBase(wheel_radius=0.05, half_length=0.3, half_width=0.25, layout="X")
    u = np.array([vx, vy, w])
    rates = base.wheel_rates(u)
    np.testing.assert_allclose(base.twist_from_wheel_rates(rates), u, atol=1e-12)
    x = np.array([0.5, 0.5, 0.8])
    qd = base.derivative(x, u)
    for p, rate, eta in zip(base.wheel_positions, rates, base.roller_angles, strict=True):
        v_c = point_velocity(x, qd, p)
        assert abs(swedish_wheel_residual(v_c, x[2], rate, 0.05, eta)) < 1e-12


def test_mecanum_layouts():
    x_base = MecanumBase(0.05, 0.3, 0.3, "X")
    o_base = MecanumBase(0.05, 0.3, 0.3, "O")
    assert x_base.rank == 3 and o_base.rank == 2
    spin = x_base.wheel_rates([0.0, 0.0, 1.0])
    np.testing.assert_allclose(np.abs(spin), 0.6 / 0.05)
    with pytest.raises(ValueError, match="yaw rate"):
        o_base.twist_from_wheel_rates(np.ones(4))
    with pytest.raises(ValueError, match="layout"):
        MecanumBase(0.05, 0.3, 0.3, "Y")


# ---------------------------------------------------------------------- tracked
def test_ideal_tracks_are_seed_004_differential():
    tv, dd = TrackedVehicle(gauge=0.4, sprocket_radius=0.05), DifferentialDrive(track=0.4, wheel_radius=0.05)
    rng = np.random.default_rng(9)
    x, vw = rng.normal(size=(10, 3)), rng.normal(size=(10, 2))
    tracks = tv.track_speeds(vw[:, 0], vw[:, 1], compensate=False)
    np.testing.assert_allclose(tv.step(x, tracks, 0.3), dd.step(x, vw, 0.3), atol=1e-14)
    np.testing.assert_allclose(tv.sprocket_rates(vw[:, 0], vw[:, 1]), dd.wheel_rates(vw), atol=1e-12)


def test_tracked_slip_compensation_round_trip_and_presets():
    for name, ter in TERRAIN_PRESETS.items():
        assert ter.source and terrain_preset(name) is ter
        tv = TrackedVehicle(gauge=0.4, terrain=name)
        tracks = tv.track_speeds(0.15, np.deg2rad(10.0), compensate=True)
        np.testing.assert_allclose(tv.body_twist(tracks), [0.15, 0.0, np.deg2rad(10.0)], atol=1e-12)
    grass, concrete = TrackedVehicle(0.4, terrain="artificial_grass"), TrackedVehicle(0.4, terrain="concrete")
    nominal = grass.track_speeds(0.15, 0.5, compensate=False)
    # Uncompensated commands turn less on grass than on concrete (the tracks skid more).
    assert grass.body_twist(nominal)[2] < concrete.body_twist(nominal)[2] < 0.5
    with pytest.raises(ValueError, match="terrain"):
        terrain_preset("ice")
    with pytest.raises(ValueError, match="slip_left"):
        TrackTerrain(slip_left=1.0)


def test_asymmetric_slip_curves_a_straight_command():
    tv = TrackedVehicle(0.4, terrain=TrackTerrain(slip_left=0.05, slip_right=0.03))
    end = tv.step(np.zeros(3), [0.15, 0.15], 10.0)
    assert end[2] > 0.0 and end[1] > 0.0  # the right track grips better: drifts left


def test_wheel_residual_helpers_seed_forms():
    """Castor: ẋ sinθ − ẏ cosθ + lθ̇; a free castor's heading rate zeroes it."""
    v = np.array([0.3, 0.4])
    rate = castor_heading_rate(v, 0.2, 0.05)
    assert abs(castor_wheel_residual(v, 0.2, rate, 0.05)) < 1e-15
    # Swedish 90° wheel: the residual is the seed's rolling equation.
    assert swedish_wheel_residual([1.0, 0.0], 0.0, 10.0, 0.1, np.pi / 2) == pytest.approx(0.0)
    assert swedish_wheel_residual([1.0, 0.7], 0.0, 10.0, 0.1, np.pi / 2) == pytest.approx(0.0)


@pytest.mark.parametrize(
    ("make", "n_config", "n_constraints"),
    [
        (lambda: DifferentialDrive(track=0.5), 3, 1),  # seed 003 §3.2.4: 3 − 1 = 2
        (lambda: TricycleStacker(wheelbase=1.3), 4, 2),  # §3.2.5: [x y θ φ], 4 − 2 = 2
        (lambda: TricycleRearDrive(wheelbase=1.3, max_steer=1.0), 4, 2),
        (lambda: Ackermann(wheelbase=2.5, track=1.5), 4, 2),  # §3.2.6: like the tricycle
        (lambda: TractorTrailer(trailer_length=2.0), 4, 2),  # §3.2.7
        (lambda: MecanumBase(0.05, 0.3, 0.25), 3, 0),  # Swedish wheels: omnidirectional, 3 DOF
    ],
)
def test_degrees_of_freedom_as_seed_003_counts(make, n_config, n_constraints):
    m = make()
    assert (m.n_state, m.n_constraints, m.dof) == (n_config, n_constraints, n_config - n_constraints)


def test_state_valid_flags_steering_beyond_limit():
    tri = TricycleStacker(wheelbase=1.3, max_steer=1.0)
    states = np.array([[0, 0, 0, 0.5], [0, 0, 0, 1.2], [0, 0, np.nan, 0.0]])
    np.testing.assert_array_equal(tri.state_valid(states), [True, False, False])
