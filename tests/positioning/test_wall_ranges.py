"""Ultrasonic ranges to wall lines as EKF measurements: model, Jacobian, association, fusion."""

import math
import types

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.odometry import OdometryNoise
from agvnav.positioning import make_estimator
from agvnav.positioning.wall_ranges import WallRangeModel, wall_range, wall_range_jacobian
from agvnav.positioning.wall_ranging import distance_from_wall, wall_line
from agvnav.sensors import seed_004_layout

LAYOUT = seed_004_layout()
NO_REFLECTORS = types.SimpleNamespace(reflector_xy=np.zeros((0, 2)), reflector_radius=np.zeros(0))
RIGHT_WALL = np.array([[-3.0, -0.55], [30.0, -0.55]])


def _numerical_jacobian(f, x, eps=1e-6):
    return np.array([(f(x + eps * e) - f(x - eps * e)) / (2 * eps) for e in np.eye(3)])


@given(
    st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-math.pi, math.pi),  # pose
    st.floats(-0.3, 0.3), st.floats(-0.3, 0.3), st.floats(-math.pi, math.pi),  # mount
    st.floats(-math.pi, math.pi),  # wall normal direction
    st.sampled_from(["cone", "ray"]),
)
def test_jacobian_matches_numerical(x, y, psi, xs, ys, phi, alpha, beam):
    n, c = np.array([math.cos(alpha), math.sin(alpha)]), -2.0  # the line is 2 m behind the origin
    pose, mount = np.array([x, y, psi]), (xs, ys, phi)
    g = -(n @ [math.cos(psi + phi), math.sin(psi + phi)])
    if beam == "ray" and g < 0.2:  # the axis must meet the line at a sane incidence
        return
    H = wall_range_jacobian(pose, mount, n, c, beam)
    numeric = _numerical_jacobian(lambda p: float(wall_range(p, mount, n, c, beam)), pose)
    np.testing.assert_allclose(H, numeric, rtol=1e-6, atol=1e-6)


@given(st.floats(-0.25, 0.25), st.floats(-0.1, 0.1), st.floats(-0.2, 0.2))
def test_range_models_agree_with_the_sensor_and_the_seed_formulas(psi, y, dx):
    """cone: the simulated ranger's nearest echo; ray: the inverse of eq 8's ray form."""
    pose = np.array([1.0 + dx, y, psi])
    for name in ("right_front", "right_rear"):
        sensor = LAYOUT[name]
        n, c = wall_line(RIGHT_WALL, sensor.sensor_pose(pose)[:2])
        echo = sensor.echo(pose, RIGHT_WALL[None])
        assert float(wall_range(pose, sensor.mount, n, c, "cone")) == pytest.approx(float(echo.range), abs=1e-12)
        ray = float(wall_range(pose, sensor.mount, n, c, "ray"))
        implied = distance_from_wall([ray], [sensor.mount], psi, n, beam="ray")[0]
        assert implied == pytest.approx(float(n @ pose[:2] - c), abs=1e-12)


def test_association_picks_the_nearest_modelled_wall_and_gates():
    walls = np.array([RIGHT_WALL, RIGHT_WALL - [0.0, 0.5], [[0.2, -0.6], [0.4, -0.6]]])
    model = WallRangeModel(walls, LAYOUT)
    P = np.diag([1e-4, 1e-4, 1e-5])
    pose = np.array([1.0, 0.0, 0.0])
    index, h = model.candidates("right_front", pose)
    assert index.tolist() == [0, 1]
    assert h == pytest.approx([0.35, 0.85])  # wall 2 is not abreast
    a = model.associate("right_front", 0.352, pose, P, gate=10.83)
    assert a is not None and a.wall == 0 and a.innovation == pytest.approx(0.002)
    jacobian = a.H
    assert jacobian == pytest.approx((0.0, 1.0, 0.15))  # d grows with y and with a CCW turn of the front sensor
    assert model.associate("right_front", 0.45, pose, P, gate=10.83) is None  # 10 cm off: outside the gate
    assert model.associate("right_front", math.nan, pose, P, gate=10.83) is None
    assert model.associate("front", 0.35, pose, P, gate=10.83) is None  # no wall ahead
    with pytest.raises(ValueError, match="unknown rangers"):
        model.check_names(["rear"])


def _ekf(**kwargs):
    return make_estimator("ekf", NO_REFLECTORS, walls=np.array([RIGHT_WALL]), rangers=LAYOUT, **kwargs)


def test_ekf_update_ranges_corrects_lateral_offset_and_heading():
    ekf = _ekf(initial_pose=[0.0, 0.03, 0.02], initial_covariance=np.diag([0.05, 0.05, 0.03]) ** 2)
    truth = np.array([0.0, 0.0, 0.0])
    ekf.predict(0.1, 0.0, 0.0)
    for _ in range(20):
        e = LAYOUT.echo(truth, RIGHT_WALL[None])
        ranges = dict(zip(LAYOUT.names, np.where(e.valid, e.range, np.nan).tolist(), strict=True))
        assert ekf.update_ranges(0.1, ranges) == 2  # the right pair; the others see nothing
    # 40 exact ranges of 3 mm std outweigh the prior 90:1 on the heading (lever 0.15 m)
    assert ekf.pose[1:] == pytest.approx([0.0, 0.0], abs=3e-4)
    assert ekf.covariance[1, 1] < 1e-5 and ekf.covariance[0, 0] == pytest.approx(0.05**2)  # x unobservable
    assert ekf.n_ranges_accepted == 40 and ekf.last_range.wall == 0


def test_ekf_with_rangers_stays_bounded_where_dead_reckoning_drifts():
    """A 20 m drive beside a wall; odometry reads 1 % long and turns 0.02 rad/m too much; 3 mm ranger noise."""
    rng = np.random.default_rng(11)
    noise = OdometryNoise(k_d=1e-4, k_dtheta=4e-4, k_theta=1e-4)
    ekf = _ekf(initial_pose=[0.0, 0.0, 0.0], initial_covariance=np.diag([0.01, 0.01, 0.01]) ** 2,
               odometry_noise=noise)
    dead = _ekf(initial_pose=[0.0, 0.0, 0.0], initial_covariance=np.diag([0.01, 0.01, 0.01]) ** 2,
                odometry_noise=noise)
    truth, dt, v = np.zeros(3), 0.05, 0.5
    lateral, heading, lateral_dr = [], [], []
    for k in range(1, 801):
        t = k * dt
        truth = truth + [v * dt, 0.0, 0.0]
        for est in (ekf, dead):
            est.predict(t, 1.01 * v * dt, 0.02 * v * dt)
        e = LAYOUT.echo(truth, RIGHT_WALL[None])
        noisy = np.where(e.valid, e.range + 0.003 * rng.standard_normal(e.range.shape), np.nan)
        ekf.update_ranges(t, dict(zip(LAYOUT.names, noisy.tolist(), strict=True)))
        lateral.append(ekf.pose[1] - truth[1])
        heading.append(ekf.pose[2] - truth[2])
        lateral_dr.append(dead.pose[1] - truth[1])
    assert np.max(np.abs(lateral)) < 0.01 and np.max(np.abs(heading)) < 0.02
    assert abs(lateral_dr[-1]) > 3.0  # 0.02 rad/m over 20 m: 4 m off
    assert ekf.status == "tracking" and dead.n_ranges_accepted == 0


def test_ekf_update_ranges_errors():
    plain = make_estimator("ekf", NO_REFLECTORS, initial_pose=[0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="without walls"):
        plain.update_ranges(0.0, {"front": 0.3})
    with pytest.raises(ValueError, match="give walls"):
        make_estimator("ekf", NO_REFLECTORS, rangers=LAYOUT)
    ekf = _ekf(initial_pose=[0.0, 0.0, 0.0])
    ekf.predict(1.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="predict first"):
        ekf.update_ranges(2.0, {"front": 0.3})
    with pytest.raises(ValueError, match="earlier"):
        ekf.update_ranges(0.5, {"front": 0.3})
    with pytest.raises(ValueError, match="unknown rangers"):
        ekf.update_ranges(1.0, {"rear": 0.3})
