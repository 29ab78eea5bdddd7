"""Path followers of every vehicle family driving kinematic models in closed loop.

Ground truth: the final lateral error is measured on the *true* pose of the
kinematic model (projected on the path here, not read from the follower),
the model-A loop is compared with the stacker loop it must reproduce, and the
designs are checked against their linearised poles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from agvnav.guidance import (
    CRITICAL_SETTLING_PER_DISTANCE,
    FOLLOWERS,
    GuidanceError,
    Path,
    PathFollower,
    make_follower,
    path_from_moves,
)
from agvnav.guidance.gains import envelope_distance, modal_response
from agvnav.guidance.holonomic import HolonomicFollower
from agvnav.guidance.steered import SteeredFollower
from agvnav.guidance.unicycle import UnicycleFollower, pure_pursuit_lookahead_for_distance
from agvnav.kinematics import (
    Ackermann,
    DifferentialDrive,
    KinematicModel,
    MecanumBase,
    TractorTrailer,
    TricycleRearDrive,
    TricycleStacker,
)


@dataclass(frozen=True)
class Steered:
    wheelbase: float = 1.0
    drive_point: str = "C"
    max_steer: float = 1.2


@dataclass(frozen=True)
class Unicycle:
    track: float = 0.5
    wheel_radius: float = 0.1


@dataclass(frozen=True)
class Holonomic:
    wheel_radius: float = 0.05
    half_length: float = 0.3
    half_width: float = 0.25


GEOMETRY = {"steered": Steered(), "unicycle": Unicycle(), "holonomic": Holonomic()}
LINE_ARC = path_from_moves((0.0, 0.0, 0.0), [("line", 2.0), ("arc", 2.0, math.pi / 2), ("line", 3.0)])


def tracked_xy(follower: PathFollower, state: np.ndarray) -> tuple[float, float]:
    """True position of the tracked point: C for steered followers tracking C, else base_link."""
    x, y, psi = state[:3]
    if isinstance(follower, SteeredFollower) and follower.point == "C":
        return x + follower.wheelbase * math.cos(psi), y + follower.wheelbase * math.sin(psi)
    return x, y


def plant_input(follower: PathFollower, state: np.ndarray, v: float, rate: float, dt: float) -> np.ndarray:
    """The family's conversion of (v, v_lateral, rate) into the kinematic model's input.

    Steered: the steering actuator holds its angle limit (the rate is cut so one step stops at it).
    """
    if isinstance(follower, SteeredFollower):
        limit, gamma = follower.max_steer * (1 - 1e-9), float(state[3])
        rate = min(max(rate, (-limit - gamma) / dt), (limit - gamma) / dt)
        return np.array([follower.drive_speed(v, gamma), rate])
    if isinstance(follower, HolonomicFollower):
        assert follower.last_twist is not None
        return np.array(follower.last_twist)
    return np.array([v, rate])


def drive(
    follower: PathFollower, model: KinematicModel, state0: np.ndarray, v: float, dt: float = 0.04
) -> tuple[np.ndarray, list[float]]:
    """Drive until the tracked point's projection reaches 5 cm before the path end; return states and |lateral|."""
    path = follower.path
    state, states, lateral = np.asarray(state0, dtype=float), [], []
    for _ in range(int(1.5 * path.length / (abs(v) * dt))):
        steering = float(state[3]) if isinstance(follower, SteeredFollower) else 0.0
        _, rate = follower.command(state[:3], v, steering)
        state = model.step(state, plant_input(follower, state, v, rate, dt), dt)
        states.append(state)
        pr = path.project_point(*tracked_xy(follower, state))
        lateral.append(abs(pr.lateral))
        if pr.s >= path.length - 0.05:
            return np.array(states), lateral
    raise AssertionError("the vehicle did not reach the path end")


def model_for(family: str, drive_point: str = "C") -> KinematicModel:
    if family == "steered":
        return TricycleStacker(1.0, max_steer=1.2) if drive_point == "C" else TricycleRearDrive(1.0, max_steer=1.2)
    if family == "unicycle":
        return DifferentialDrive(0.5, 0.1)
    return MecanumBase(0.05, 0.3, 0.25)


DRIVE_POINTS = {"steered": ("C", "O"), "unicycle": ("-",), "holonomic": ("-",)}
PAIRS = [(fam, name, dp) for fam, names in FOLLOWERS.items() for name in names for dp in DRIVE_POINTS[fam]]


@pytest.mark.parametrize(("family", "name", "drive_point"), PAIRS)
def test_every_follower_brings_its_vehicle_from_a_10_cm_offset_onto_the_path(family, name, drive_point):
    geometry = Steered(drive_point=drive_point) if family == "steered" else GEOMETRY[family]
    follower = make_follower(name, family, LINE_ARC, geometry, convergence_distance=1.5)
    assert follower.family == family
    state0 = np.array([0.0, 0.1, 0.0, 0.0] if family == "steered" else [0.0, 0.1, 0.0])
    _, lateral = drive(follower, model_for(family, drive_point), state0, v=0.3)
    assert lateral[0] > 0.05  # it did start off the path
    assert lateral[-1] < 0.003, (family, name, lateral[-1])
    assert follower.last_errors is not None


@pytest.mark.parametrize("name", ["seed_general", "pure_pursuit"])  # tracking C, tracking O
def test_model_a_rear_drive_reproduces_the_stacker_loop_on_an_arc(name):
    """Same path geometry: with V = v_C cos(phi) the rear-drive loop follows the stacker's trajectory."""
    arc = path_from_moves((0.0, 0.0, 0.0), [("arc", 2.5, 2.0)])
    runs = []
    for dp in ("C", "O"):
        follower = make_follower(name, "steered", arc, Steered(drive_point=dp), convergence_distance=1.5)
        states, lateral = drive(follower, model_for("steered", dp), np.array([0.0, 0.1, 0.0, 0.0]), v=0.3, dt=0.02)
        assert lateral[-1] < 0.002, (dp, lateral[-1])
        runs.append(states)
    n = min(len(r) for r in runs)
    np.testing.assert_allclose(runs[0][:n, :3], runs[1][:n, :3], atol=1e-3)


@pytest.mark.parametrize("name", FOLLOWERS["steered"])
def test_ackermann_bicycle_equivalent_follows_with_the_steered_laws(name):
    """Seed 003 §3.2.6: the Ackermann car moves as the rear-drive tricycle on its bicycle angle."""
    geometry = Steered(wheelbase=1.2, drive_point="O", max_steer=math.radians(40.0))
    follower = make_follower(name, "steered", LINE_ARC, geometry, convergence_distance=1.5)
    model = Ackermann(1.2, 0.8, max_steer=math.radians(40.0))
    _, lateral = drive(follower, model, np.array([0.0, 0.1, 0.0, 0.0]), v=0.3)
    assert lateral[-1] < 0.003


@pytest.mark.parametrize("name", FOLLOWERS["unicycle"])
def test_tractor_of_a_tractor_trailer_follows_and_the_trailer_straightens(name):
    """The unicycle followers steer the differential tractor; the trailer (not controlled) settles behind it."""
    follower = make_follower(name, "unicycle", LINE_ARC, Unicycle(), convergence_distance=1.5)
    model = TractorTrailer(trailer_length=1.0, hitch_offset=0.3, max_hitch_angle=math.radians(80.0))
    states, lateral = drive(follower, model, np.array([0.0, 0.1, 0.0, 0.0]), v=0.3)
    assert lateral[-1] < 0.003
    assert np.max(np.abs(states[:, 3])) < math.radians(45.0)  # far from a jackknife
    assert abs(states[-1, 3]) < math.radians(5.0)  # straightening on the final line


def test_steered_general_law_on_o_reverses_a_model_a_vehicle():
    """Reversing where the vehicle can (seed 000 §3.3: the general law on point O)."""
    path = path_from_moves((0.0, 0.0, 0.0), [("line", 2.0, -1), ("arc", 3.0, math.pi / 3, -1), ("line", 2.0, -1)])
    follower = make_follower(
        "seed_general", "steered", path, Steered(drive_point="O"), convergence_distance=1.5, point="O"
    )
    _, lateral = drive(follower, model_for("steered", "O"), np.array([0.0, 0.1, math.pi, 0.0]), v=-0.2)
    assert lateral[0] > 0.05 and lateral[-1] < 0.003


@pytest.mark.parametrize("name", FOLLOWERS["unicycle"])
def test_unicycle_followers_back_along_reverse_segments(name):
    path = path_from_moves((0.0, 0.0, 0.0), [("line", 2.0, -1), ("arc", 2.0, -math.pi / 2, -1), ("line", 2.0, -1)])
    follower = make_follower(name, "unicycle", path, Unicycle(), convergence_distance=1.5)
    states, lateral = drive(follower, model_for("unicycle"), np.array([0.0, -0.1, math.pi]), v=-0.3)
    assert lateral[-1] < 0.003
    end_heading = path.heading_at(path.length)
    assert abs(math.remainder(states[-1, 2] - (float(end_heading) + math.pi), 2 * math.pi)) < 0.01


def test_mecanum_follows_a_sideways_segment_with_its_heading_profile():
    """Forward, then sideways along a line and an arc (yaw_offset = -pi/2: the body's left leads)."""
    side = -math.pi / 2
    moves = [("line", 1.5), ("line", 2.0, 1, side), ("arc", 2.0, math.pi / 2, 1, side), ("line", 2.0, 1, side)]
    path = path_from_moves((0.0, 0.0, 0.0), moves)
    follower = make_follower("holonomic", "holonomic", path, Holonomic(), convergence_distance=1.0)
    model = model_for("holonomic")
    state, twists, lateral = np.array([0.0, 0.1, 0.0]), [], []
    for _ in range(5000):
        follower.command(state, 0.3)
        assert follower.last_twist is not None
        twists.append((follower.last_twist, follower.last_errors.s))
        state = model.step(state, np.array(follower.last_twist), 0.02)
        pr = path.project_point(state[0], state[1])
        lateral.append(abs(pr.lateral))
        if pr.s >= path.length - 0.05:
            break
    assert lateral[-1] < 0.003
    wanted = float(path.heading_at(path.length)) + side
    assert abs(math.remainder(state[2] - wanted, 2 * math.pi)) < 1e-3
    late = [tw for tw, s in twists if s > path.length - 1.0]  # settled, on the last sideways line
    vx, vy = np.array([t[0] for t in late]), np.array([t[1] for t in late])
    assert np.all(np.abs(vx) < 0.01) and np.all(vy > 0.29)  # moving along the body's +y (left)


def test_holonomic_lateral_error_decays_exponentially_per_metre():
    """dd/ds = -k d with k = ln(50)/D: the error at distance s is d0 exp(-k s)."""
    line = path_from_moves((0.0, 0.0, 0.0), [("line", 10.0)])
    follower = HolonomicFollower(line, convergence_distance=2.0)
    model, state, v, dt = model_for("holonomic"), np.array([0.0, 0.1, 0.0]), 0.2, 0.001
    for _ in range(5000):  # 1 m
        follower.command(state, v)
        assert follower.last_twist is not None
        state = model.step(state, np.array(follower.last_twist), dt)
    k = math.log(50.0) / 2.0
    assert state[1] == pytest.approx(0.1 * math.exp(-k * 1.0), rel=2e-3)


def _unicycle_jacobian(follower: UnicycleFollower, v: float = 0.5, eps: float = 1e-6) -> np.ndarray:
    """Per-metre Jacobian of (d, h) on a straight path: d' = sin h, h' = omega / |v|."""
    follower.set_path(path_from_moves((-50.0, 0.0, 0.0), [("line", 100.0)]))

    def f(z: np.ndarray) -> np.ndarray:
        follower.reset()
        _, omega = follower.command(np.array([0.0, z[0], z[1]]), v)
        return np.array([math.sin(z[1]), omega / abs(v)])

    cols = [(f(dz) - f(-dz)) / (2 * eps) for dz in np.eye(2) * eps]
    return np.array(cols).T


@pytest.mark.parametrize("name", ["kanayama", "stanley"])
def test_unicycle_designs_are_critically_damped_at_the_convergence_distance(name):
    follower = make_follower(name, "unicycle", LINE_ARC, Unicycle(), convergence_distance=3.0)
    assert isinstance(follower, UnicycleFollower)
    jac = _unicycle_jacobian(follower)
    pole = -CRITICAL_SETTLING_PER_DISTANCE / 3.0
    assert np.trace(jac) == pytest.approx(2 * pole, rel=1e-6)
    assert np.linalg.det(jac) == pytest.approx(pole**2, rel=1e-6)
    x = CRITICAL_SETTLING_PER_DISTANCE  # (1 + x) exp(-x) = 2 %: the response after an offset
    assert (1 + x) * math.exp(-x) == pytest.approx(0.02, rel=1e-12)


def test_unicycle_pure_pursuit_converges_within_the_convergence_distance():
    follower = make_follower("pure_pursuit", "unicycle", LINE_ARC, Unicycle(), convergence_distance=2.5)
    assert isinstance(follower, UnicycleFollower)
    jac = _unicycle_jacobian(follower)
    lam, res = modal_response(jac, np.array([1.0, 0.0]), np.array([1.0, 0.0]))
    assert envelope_distance(lam, res) == pytest.approx(2.5, rel=1e-6)
    lookahead = pure_pursuit_lookahead_for_distance(2.5)
    np.testing.assert_allclose(np.sort_complex(lam), np.sort_complex(np.array([-1 - 1j, -1 + 1j]) / lookahead))


def test_steered_wrapper_hands_the_controller_the_speed_of_c():
    """Tracking O at v_O: the controller gets v_C = v_O / cos(gamma) [seed000 eq8]."""
    follower = make_follower("pure_pursuit", "steered", LINE_ARC, Steered(), convergence_distance=2.0, point="O")
    assert isinstance(follower, SteeredFollower) and follower.point == "O"
    pose, gamma, v_o = np.array([0.1, 0.05, 0.02]), 0.3, 0.25
    _, rate = follower.command(pose, v_o, gamma)
    follower.reset()
    assert rate == follower.controller.command(pose, gamma, v_o / math.cos(gamma))
    assert follower.drive_speed(v_o, gamma) == pytest.approx(v_o / math.cos(gamma))  # stacker drives C


def test_steered_rate_does_not_push_beyond_the_steering_limit():
    follower = make_follower("seed_general", "steered", LINE_ARC, Steered(max_steer=0.5), convergence_distance=1.0)
    _, rate = follower.command(np.array([0.0, -0.5, 0.0]), 0.3, 0.5)  # far right: the law steers further left
    assert rate == 0.0
    _, rate = follower.command(np.array([0.0, 0.5, 0.0]), 0.3, 0.5)  # far left: steering back is allowed
    assert rate < 0.0


def test_followers_reset_and_set_path_forget_the_last_errors():
    for family, names in FOLLOWERS.items():
        for name in names:
            follower = make_follower(name, family, LINE_ARC, GEOMETRY[family])
            follower.command(np.array([0.5, 0.05, 0.0]), 0.2, 0.0)
            assert follower.last_errors is not None
            follower.reset()
            assert follower.last_errors is None
            other = Path(LINE_ARC.segments[:2])
            follower.command(np.array([0.5, 0.05, 0.0]), 0.2, 0.0)
            follower.set_path(other)
            assert follower.last_errors is None and follower.path is other


@pytest.mark.parametrize("family", list(FOLLOWERS))
def test_bad_pose_and_speed_are_value_errors(family):
    follower = make_follower(FOLLOWERS[family][0], family, LINE_ARC, GEOMETRY[family])
    with pytest.raises(ValueError, match="shape"):
        follower.command(np.zeros(2), 0.2)
    with pytest.raises(ValueError, match="NaN"):
        follower.command(np.array([0.0, math.nan, 0.0]), 0.2)
    with pytest.raises(ValueError, match="v must"):
        follower.command(np.zeros(3), math.inf)


def test_zero_speed_gives_zero_command_for_unicycle_and_holonomic():
    for family in ("unicycle", "holonomic"):
        for name in FOLLOWERS[family]:
            follower = make_follower(name, family, LINE_ARC, GEOMETRY[family])
            assert follower.command(np.array([0.3, 0.2, 0.4]), 0.0) == (0.0, 0.0)


def test_guidance_error_is_a_value_error():
    with pytest.raises(ValueError):
        make_follower("seed_simple", "holonomic", LINE_ARC, Holonomic())
    assert issubclass(GuidanceError, ValueError)
