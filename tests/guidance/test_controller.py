"""Controller objects: factory, interface, refusals, tuning, and convergence from a 110 mm offset."""

import math

import numpy as np
import pytest
from _guidance_sim import run

from agvnav.guidance import (
    CONTROLLERS,
    LineSegment,
    Path,
    SeedGeneralController,
    SeedSimpleController,
    StanleyController,
    linearised_loop,
    lookahead_for_distance,
    loop_convergence_distance,
    make_controller,
    path_from_moves,
    tune_for_convergence,
)

L = 1.2


def straight(direction=1, length=12.0):
    return Path([LineSegment(np.array([0.0, 0.0]), 0.0, length, direction)])


def start_state(path, offset, point):
    """Vehicle with its tracked point `offset` m left of the path start, aligned, wheel at 0."""
    x, y, h = path.start_pose
    d = int(path.direction_at(0.0))
    psi = h + (0.0 if d > 0 else math.pi)
    p = np.array([x, y]) + offset * np.array([-math.sin(h), math.cos(h)])
    if point == "C":
        p = p - L * np.array([math.cos(psi), math.sin(psi)])
    return [p[0], p[1], psi, 0.0]


def test_factory_names_and_errors():
    assert set(CONTROLLERS) == {"seed_general", "seed_simple", "pure_pursuit", "stanley"}
    p = straight()
    for name in CONTROLLERS:
        c = make_controller(name, p, L, convergence_distance=2.0)
        assert c.path is p and c.last_errors is None
    with pytest.raises(ValueError, match="unknown controller 'lqr'"):
        make_controller("lqr", p, L)
    with pytest.raises(ValueError, match=r"seed_general.*lookahead"):
        make_controller("seed_general", p, L, lookahead=1.0)
    with pytest.raises(ValueError, match="only one"):
        make_controller("seed_general", p, L, convergence_distance=1.0, poles_per_m=[-1, -1, -1])


def test_command_interface_last_errors_and_reset():
    c = SeedGeneralController(straight(), L, convergence_distance=2.0, point="O")
    u = c.command(np.array([1.0, 0.05, 0.0]), 0.0, 0.5)
    assert isinstance(u, float) and u < 0.0  # left of the path: steer right
    e = c.last_errors
    assert e.eps_o == pytest.approx(0.05) and e.s == pytest.approx(1.0)
    assert set(e.as_dict()) >= {"eps_c", "eps_o", "xi", "xi_r", "s"}
    assert c.command([1.0, 0.05, 0.0], 0.0, 0.0) == 0.0  # standstill: nothing to correct
    c.reset()
    assert c.last_errors is None
    for bad, match in [((1.0, 0.0), "shape"), ((1.0, np.nan, 0.0), "NaN"), (("a", 0, 0), "numeric")]:
        with pytest.raises(ValueError, match=match):
            c.command(bad, 0.0, 0.5)
    with pytest.raises(ValueError, match="gamma"):
        c.command([0, 0, 0], 2.0, 0.5)
    with pytest.raises(ValueError, match="v must be finite"):
        c.command([0, 0, 0], 0.0, math.inf)


def test_window_hint_keeps_the_controller_on_its_branch():
    # figure: east 4 m, 3/4 turn left, south across the first straight at (3, 0)
    p = path_from_moves([0, 0, 0], [("line", 4.0), ("arc", 1.0, 1.5 * math.pi), ("line", 3.0)])
    c = SeedGeneralController(p, L, convergence_distance=2.0, point="O", window=0.5)
    c.command([2.5, 0.0, 0.0], 0.0, 0.5)
    c.command([3.0, 0.02, 0.0], 0.0, 0.5)  # near the crossing, still on the first straight
    assert c.last_errors.s == pytest.approx(3.0)
    c.set_path(p)  # a fresh start searches the whole path
    assert c.last_errors is None


def test_unstable_fixed_gains_are_refused():
    p = straight()
    SeedGeneralController(p, L, gains=(1.0, 2.0, 3.0), v_max=1.0)  # bc/a = 6 > 1
    with pytest.raises(ValueError, match=r"\|b\| c / a.*eq\. 18"):
        SeedGeneralController(p, L, gains=(1.0, 2.0, 3.0), v_max=7.0)
    with pytest.raises(ValueError, match="v_max"):
        SeedGeneralController(p, L, gains=(1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match="a > 0 and b > 0"):
        SeedSimpleController(p, L, gains=(1.0, -2.0))
    c = SeedGeneralController(p, L, gains=(1.0, 2.0, 3.0), v_max=1.0)
    assert c.gains_at(-0.5) == (1.0, -2.0, 3.0)  # b follows the direction of travel
    with pytest.raises(ValueError, match="exceeds v_max"):
        c.command([0, 0, 0], 0.0, 1.5)


def test_direction_limited_laws_refuse_reverse():
    s = SeedSimpleController(straight(-1), L)
    with pytest.raises(ValueError, match="v > 0"):
        s.command([0, 0, math.pi], 0.0, -0.3)
    t = StanleyController(straight(-1), L, gain_per_m=2.0)
    with pytest.raises(ValueError, match="forward"):
        t.command([0, 0, math.pi], 0.0, -0.3)


def test_path_tighter_than_wheelbase_for_c_is_an_error():
    p = path_from_moves([0, 0, 0], [("arc", 0.8, 1.0)])
    c = SeedSimpleController(p, L)
    with pytest.raises(ValueError, match="below the wheelbase"):
        c.command([-L, 0.0, 0.0], 0.0, 0.3)


@pytest.mark.parametrize("name, point", [("pure_pursuit", "O"), ("pure_pursuit", "C"), ("stanley", "C")])
def test_tuning_reaches_the_requested_convergence_distance(name, point):
    kw = {"point": point} if name == "pure_pursuit" else {}
    x = tune_for_convergence(name, 2.0, L, 0.5, **kw)
    key = "lookahead" if name == "pure_pursuit" else "gain_per_m"
    c = make_controller(name, straight(), L, **{key: x}, **kw)
    assert loop_convergence_distance(c, 0.5, L) == pytest.approx(2.0, rel=1e-6)
    if (name, point) == ("pure_pursuit", "O"):
        assert x == pytest.approx(lookahead_for_distance(2.0), rel=0.3)  # near the ideal-servo formula


@pytest.mark.parametrize("name, params, direction", [
    ("seed_general", {"point": "C"}, 1), ("seed_general", {"point": "O"}, 1), ("seed_simple", {}, 1),
    ("pure_pursuit", {"point": "O"}, 1), ("pure_pursuit", {"point": "C"}, 1), ("stanley", {}, 1),
    ("seed_general", {"point": "O"}, -1), ("seed_general", {"point": "C"}, -1), ("pure_pursuit", {"point": "O"}, -1),
])
@pytest.mark.parametrize("speed", [0.2, 1.0])
def test_every_controller_is_tuned_to_the_same_convergence_distance(name, params, direction, speed):
    v = speed * direction
    extra = {"v_nominal": v} if name in ("pure_pursuit", "stanley") else {}
    c = make_controller(name, straight(direction), L, convergence_distance=2.5, **params, **extra)
    assert loop_convergence_distance(c, v, L) == pytest.approx(2.5, rel=1e-6)


@pytest.mark.parametrize("point, v", [("O", 0.5), ("C", 0.5), ("O", -0.5), ("C", -0.5)])
def test_linearised_residues_reproduce_the_simulated_response(point, v):
    """The modal residues of linearised_loop give the nonlinear loop's response to a small offset."""
    d = 1 if v > 0 else -1
    c = SeedGeneralController(straight(d), L, convergence_distance=2.0, point=point)
    lam, res = linearised_loop(c, v, L)
    y0 = 0.002
    _, errs, travelled = run(c, start_state(straight(d), y0, point), v, L, distance=3.0, dt=0.005)
    eps = np.array([e["eps_o" if point == "O" else "eps_c"] for e in errs])
    assert eps[0] == pytest.approx(d * y0, abs=1e-12)  # start_state offsets left of the tangent
    lin = eps[0] * np.real(np.exp(np.outer(travelled, lam)) @ res)
    assert np.max(np.abs(eps - lin)) < 0.03 * y0


def test_envelope_distance_bounds_the_simulated_error():
    """The tuned distance is a bound: the nonlinear loop from a small offset is within 2 % beyond it."""
    for name, params in [("seed_general", {"point": "C"}), ("pure_pursuit", {"point": "O", "v_nominal": 0.5})]:
        c = make_controller(name, straight(), L, convergence_distance=2.0, **params)
        _, errs, travelled = run(c, start_state(straight(), 0.01, c.point), 0.5, L, distance=4.0, dt=0.01)
        key = "eps_o" if c.point == "O" else "eps_c"
        eps = np.array([e[key] for e in errs])
        assert np.max(np.abs(eps[travelled >= 2.0])) <= 0.02 * 0.01 * 1.05


CASES = [
    ("seed_general", {"point": "C"}, 1),
    ("seed_general", {"point": "O"}, 1),
    ("seed_general", {"point": "O"}, -1),
    ("seed_general", {"point": "C", "form": 12}, -1),
    ("seed_simple", {}, 1),
    ("pure_pursuit", {"point": "O"}, 1),
    ("pure_pursuit", {"point": "O"}, -1),
    ("pure_pursuit", {"point": "C"}, 1),
    ("stanley", {}, 1),
]


@pytest.mark.parametrize("name, params, direction", CASES)
def test_convergence_from_110_mm_on_a_line(name, params, direction):
    v = 0.5 * direction
    path = straight(direction)
    extra = {"v_nominal": v} if name in ("pure_pursuit", "stanley") else {}
    c = make_controller(name, path, L, convergence_distance=2.0, **params, **extra)
    key = "eps_o" if c.point == "O" else "eps_c"
    _, errs, travelled = run(c, start_state(path, 0.11, c.point), v, L, distance=8.0, dt=0.02)
    eps = np.array([e[key] for e in errs])
    assert eps[0] == pytest.approx(0.11 * direction, abs=1e-9)  # lateral in the reference body frame
    assert np.max(np.abs(eps[travelled > 4.0])) < 0.005
    assert abs(eps[-1]) < 5e-4


@pytest.mark.parametrize("name", ["seed_general", "seed_simple", "pure_pursuit", "stanley"])
def test_convergence_from_110_mm_on_an_arc(name):
    path = path_from_moves([0, 0, 0], [("arc", 4.0, 2.5)])
    params = {"point": "C"} if name in ("seed_general", "pure_pursuit") else {}
    extra = {"v_nominal": 0.5} if name in ("pure_pursuit", "stanley") else {}
    c = make_controller(name, path, L, convergence_distance=2.0, **params, **extra)
    _, errs, travelled = run(c, start_state(path, 0.11, "C"), 0.5, L, distance=9.0, dt=0.02)
    eps = np.array([e["eps_c"] for e in errs])
    assert np.max(np.abs(eps[travelled > 5.0])) < 0.01
    if name.startswith("seed"):
        assert abs(eps[-1]) < 5e-4  # feed-forward: no steady-state error
