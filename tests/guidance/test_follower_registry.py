"""make_follower refusals, path feasibility, and the follower kernels against their other formulations."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path as FsPath

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from agvnav.cli import app
from agvnav.guidance import (
    FOLLOWERS,
    ArcSegment,
    FollowErrors,
    GuidanceError,
    InfeasiblePathError,
    KanayamaGains,
    LineSegment,
    Path,
    PathFollower,
    check_path_feasible,
    drive_speed,
    follower_parameters,
    holonomic_body_twist,
    kanayama_path_rate,
    make_follower,
    min_turning_radius,
    path_from_moves,
)
from agvnav.guidance.kanayama import kanayama_law, tracking_error

runner = CliRunner()


@dataclass(frozen=True)
class Steered:
    wheelbase: float = 1.0
    drive_point: str = "O"
    max_steer: float = math.radians(45.0)


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
ALL_NAMES = sorted({n for names in FOLLOWERS.values() for n in names})


# ------------------------------------------------------------------ registry
def test_registry_holds_the_contract_names():
    assert FOLLOWERS == {
        "steered": ("seed_general", "seed_simple", "pure_pursuit", "stanley"),
        "unicycle": ("kanayama", "pure_pursuit", "stanley"),
        "holonomic": ("holonomic",),
    }


@pytest.mark.parametrize("family", list(FOLLOWERS))
@pytest.mark.parametrize("name", ALL_NAMES)
def test_a_name_that_does_not_fit_the_family_is_refused_listing_the_valid_ones(family, name):
    if name in FOLLOWERS[family]:
        assert make_follower(name, family, LINE_ARC, GEOMETRY[family]).family == family
        return
    with pytest.raises(GuidanceError) as info:
        make_follower(name, family, LINE_ARC, GEOMETRY[family])
    assert str(info.value) == f"{name} does not fit a {family} vehicle; choose from: {', '.join(FOLLOWERS[family])}"


def test_seed_law_on_mecanum_message():
    with pytest.raises(GuidanceError, match="seed_simple does not fit a holonomic vehicle; choose from: holonomic"):
        make_follower("seed_simple", "holonomic", LINE_ARC, Holonomic())


def test_unknown_family_geometry_and_parameter_are_refused():
    with pytest.raises(GuidanceError, match="unknown vehicle family 'boat'; choose from: steered, unicycle, holonomic"):
        make_follower("kanayama", "boat", LINE_ARC, Unicycle())
    with pytest.raises(GuidanceError, match="geometry needs wheelbase, drive_point, max_steer"):
        make_follower("seed_general", "steered", LINE_ARC, Unicycle())
    with pytest.raises(GuidanceError, match="lookahed"):
        make_follower("pure_pursuit", "unicycle", LINE_ARC, Unicycle(), lookahed=0.3)
    with pytest.raises(GuidanceError, match="not both"):
        make_follower("stanley", "unicycle", LINE_ARC, Unicycle(), gain_per_m=2.0, convergence_distance=1.0)
    with pytest.raises(GuidanceError, match="convergence_distance"):
        make_follower("holonomic", "holonomic", LINE_ARC, Holonomic(), convergence_distance=-1.0)
    with pytest.raises(GuidanceError, match="drive_point"):
        make_follower("seed_general", "steered", LINE_ARC, Steered(drive_point="X"))
    with pytest.raises(GuidanceError, match="max_steer"):
        make_follower("seed_general", "steered", LINE_ARC, Steered(max_steer=2.0))


@pytest.mark.parametrize("family", list(FOLLOWERS))
def test_every_follower_takes_a_convergence_distance(family):
    for name in FOLLOWERS[family]:
        make_follower(name, family, LINE_ARC, GEOMETRY[family], convergence_distance=1.2)


def test_steered_law_failures_are_guidance_errors():
    follower = make_follower("seed_simple", "steered", LINE_ARC, Steered())
    with pytest.raises(GuidanceError):
        follower.command(np.array([0.0, 0.1, 0.0]), -0.2, 0.0)  # the simple law is unstable in reverse


# --------------------------------------------------------------- feasibility
def test_reverse_segment_refused_for_a_vehicle_that_cannot_reverse_naming_it():
    forward = path_from_moves((0.0, 0.0, 0.0), [("line", 1.0), ("line", 1.0)])
    path = Path([*forward.segments, LineSegment(forward.segments[-1].end, math.pi, 1.0, -1)])  # a cusp
    for family in FOLLOWERS:
        with pytest.raises(InfeasiblePathError, match=r"path segment 2: reverse segment") as info:
            check_path_feasible(path, family, GEOMETRY[family], reverse_allowed=False)
        assert info.value.segment == 2
        check_path_feasible(path, family, GEOMETRY[family], reverse_allowed=True)  # a cusp on one line


def test_arc_tighter_than_the_steering_limit_is_refused_naming_it():
    geo = Steered(wheelbase=1.0, max_steer=math.radians(45.0))  # O turns on >= 1 m, C on >= sqrt(2) m
    assert min_turning_radius(1.0, math.radians(45.0), "O") == pytest.approx(1.0)
    assert min_turning_radius(1.0, math.radians(45.0), "C") == pytest.approx(math.sqrt(2.0))
    path = path_from_moves((0.0, 0.0, 0.0), [("line", 1.0), ("arc", 1.2, 1.0), ("arc", 0.9, -1.0)])
    with pytest.raises(InfeasiblePathError, match=r"path segment 2: arc radius 0\.9 m is below .* 1 m of point O"):
        check_path_feasible(path, "steered", geo, reverse_allowed=False)
    with pytest.raises(InfeasiblePathError, match=r"path segment 1: .* 1\.414 m of point C") as info:
        check_path_feasible(path, "steered", geo, reverse_allowed=False, point="C")
    assert isinstance(info.value, GuidanceError) and info.value.segment == 1
    for family in ("unicycle", "holonomic"):  # they turn on the spot
        check_path_feasible(path, family, GEOMETRY[family], reverse_allowed=False)


def test_corner_refused_for_steered_vehicles_only():
    first = LineSegment(np.zeros(2), 0.0, 1.0)
    corner = Path([first, LineSegment(first.end, 0.5, 1.0)])
    with pytest.raises(InfeasiblePathError, match=r"path segment 1: the body heading jumps by 28\.65 deg"):
        check_path_feasible(corner, "steered", Steered(), reverse_allowed=True)
    check_path_feasible(corner, "unicycle", Unicycle(), reverse_allowed=True)
    # a cusp (reversing back, tangent turned by pi) keeps the body heading: allowed
    cusp = Path([first, ArcSegment(first.end, math.pi, 2.0, -1.0, -1)])
    check_path_feasible(cusp, "steered", Steered(), reverse_allowed=True)
    # driving on in the same direction but backwards would need a turn on the spot
    flip = path_from_moves((0.0, 0.0, 0.0), [("line", 1.0), ("line", 1.0, -1)])
    with pytest.raises(InfeasiblePathError, match=r"path segment 1: the body heading jumps by -180 deg"):
        check_path_feasible(flip, "steered", Steered(), reverse_allowed=True)
    check_path_feasible(flip, "unicycle", Unicycle(), reverse_allowed=True)


def test_feasibility_refuses_bad_arguments():
    with pytest.raises(GuidanceError, match="family"):
        check_path_feasible(LINE_ARC, "hovercraft", Unicycle(), reverse_allowed=True)
    with pytest.raises(GuidanceError, match="Path"):
        check_path_feasible("not a path", "unicycle", Unicycle(), reverse_allowed=True)  # type: ignore[arg-type]


# ------------------------------------------------------------------- kernels
@settings(max_examples=200, deadline=None)
@given(
    d=st.floats(-0.5, 0.5),
    h=st.floats(-3.0, 3.0),
    kappa=st.floats(-2.0, 2.0),
    speed=st.floats(0.01, 2.0),
    theta=st.floats(-math.pi, math.pi),
)
def test_kanayama_path_rate_is_kanayamas_law_with_the_reference_at_the_projection(d, h, kappa, speed, theta):
    gains = KanayamaGains.from_distance(0.7)
    foot = np.array([1.0, -2.0])
    normal = np.array([-math.sin(theta), math.cos(theta)])
    robot = np.array([*(foot + d * normal), theta + h])
    error = tracking_error(robot, np.array([*foot, theta]))
    _, omega = kanayama_law(error, speed, kappa * speed, gains)
    assert kanayama_path_rate(d, h, kappa, speed, gains) == pytest.approx(float(omega), abs=1e-12)


@settings(max_examples=100, deadline=None)
@given(
    speed=st.floats(0.0, 2.0),
    normal=st.floats(-1.0, 1.0),
    tangent=st.floats(-math.pi, math.pi),
    psi=st.floats(-math.pi, math.pi),
)
def test_holonomic_body_twist_rotates_the_world_velocity_into_the_body(speed, normal, tangent, psi):
    vx, vy = holonomic_body_twist(speed, normal, tangent, psi)
    world = speed * np.array([math.cos(tangent), math.sin(tangent)]) + normal * np.array(
        [-math.sin(tangent), math.cos(tangent)]
    )
    back = np.array([vx * math.cos(psi) - vy * math.sin(psi), vx * math.sin(psi) + vy * math.cos(psi)])
    np.testing.assert_allclose(back, world, atol=1e-12)


def test_drive_speed_between_o_and_c():
    """v_O = v_C cos(gamma) [seed000 eq8]."""
    g = 0.4
    assert drive_speed(1.0, g, "C", "O") == pytest.approx(math.cos(g))
    assert drive_speed(math.cos(g), g, "O", "C") == pytest.approx(1.0)
    assert drive_speed(-0.3, g, "O", "O") == -0.3
    with pytest.raises(GuidanceError, match="tracked_point"):
        drive_speed(1.0, 0.0, "A", "O")


PATHS = {
    "forward": LINE_ARC,
    "reverse": path_from_moves((0.0, 0.0, 0.0), [("line", 2.0, -1), ("arc", 2.0, -math.pi / 2, -1)]),
    "sideways": path_from_moves((0.0, 0.0, 0.0), [("line", 2.0, 1, math.pi / 2), ("arc", 2.0, 1.0, 1, math.pi / 2)]),
}
CASES = [(fam, name, key) for fam, names in FOLLOWERS.items() for name in names for key in PATHS
         if not (fam == "steered" and key == "reverse") and (fam == "holonomic" or key != "sideways")]

_BUILT: dict[tuple[str, str, str], PathFollower] = {}


@pytest.mark.parametrize(("family", "name", "key"), CASES)
@settings(max_examples=40, deadline=None)
@given(
    s=st.floats(0.0, 1.0),
    offset=st.floats(-0.4, 0.4),
    heading=st.floats(-0.6, 0.6),
    speed=st.floats(0.0, 1.5),
    steering=st.floats(-0.7, 0.7),
)
def test_follower_output_is_finite_for_poses_near_the_path(family, name, key, s, offset, heading, speed, steering):
    path = PATHS[key]
    if (family, name, key) not in _BUILT:  # steered designs take a while: build once, reset per example
        _BUILT[family, name, key] = make_follower(name, family, path, GEOMETRY[family])
    follower = _BUILT[family, name, key]
    follower.reset()
    at = s * path.length
    xy = path.point_at(at)
    tangent = float(path.heading_at(at))
    direction = int(path.direction_at(at))
    psi = tangent + heading + (math.pi if direction < 0 else 0.0)
    pose = np.array([xy[0] - offset * math.sin(tangent), xy[1] + offset * math.cos(tangent), psi])
    v_lateral, rate = follower.command(pose, direction * speed, steering if family == "steered" else 0.0)
    assert math.isfinite(v_lateral) and math.isfinite(rate)
    assert follower.last_errors is not None
    if family != "holonomic":
        assert v_lateral == 0.0


@settings(max_examples=100, deadline=None)
@given(
    phi=st.floats(0.05, 1.45),
    d=st.floats(-0.5, 0.5),
    heading=st.floats(-3.0, 3.0),
    reverse=st.booleans(),
    yaw=st.floats(-3.0, 3.0),
)
def test_follow_errors_on_an_arc_match_the_geometry(phi, d, heading, reverse, yaw):
    """Left arc of radius 2 about the origin from (2, 0): a point at polar angle phi, radius 2 - d, is d left of it."""
    direction = -1 if reverse else 1
    arc = Path([ArcSegment(np.array([2.0, 0.0]), math.pi / 2, 2.0, math.pi / 2, direction, yaw)])
    tangent = phi + math.pi / 2
    pose = np.array([(2.0 - d) * math.cos(phi), (2.0 - d) * math.sin(phi), tangent + heading])
    for family, name in (("unicycle", "kanayama"), ("holonomic", "holonomic")):
        follower = make_follower(name, family, arc, GEOMETRY[family])
        follower.command(pose, 0.2)
        e = follower.last_errors
        assert isinstance(e, FollowErrors)
        offset = (math.pi if reverse else 0.0) + (yaw if family == "holonomic" else 0.0)
        assert e.s == pytest.approx(2.0 * phi, abs=1e-9)
        assert e.lateral == pytest.approx(d, abs=1e-9)
        assert math.remainder(e.heading_error - (heading - offset), 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
        assert -math.pi <= e.heading_error < math.pi
        assert e.curvature == pytest.approx(0.5) and e.direction == direction and e.segment == 0


# --------------------------------------------------------------------------- parameters (issue 29)

GUIDE = FsPath(__file__).resolve().parents[2] / "docs" / "USER_GUIDE.md"
SCENARIOS_MD = FsPath(__file__).resolve().parents[2] / "docs" / "scenarios.md"


@pytest.mark.parametrize("family, name", [(f, n) for f, names in FOLLOWERS.items() for n in names])
def test_every_follower_parameter_has_a_unit_and_meaning_and_is_in_scenarios_md(family, name):
    params = follower_parameters(name, family)
    assert params and all(p.unit != "?" and p.meaning != "not documented" for p in params), params
    doc = SCENARIOS_MD.read_text(encoding="utf-8")
    section = doc.split(f"### `{name}` ({family})", 1)[1].split("###", 1)[0]
    for p in params:
        assert f"| `{p.name}` | {p.unit} | {p.default} |" in section, (name, p)


def test_the_documented_defaults_are_the_constructors():
    pp = {p.name: p for p in follower_parameters("pure_pursuit", "steered")}
    assert pp["servo_tau"].default == "0.1" and pp["lookahead"].default == "none" and pp["lookahead"].unit == "m"
    assert {p.name for p in follower_parameters("seed_simple", "steered")} >= {"poles_per_m", "convergence_distance"}
    assert "poles_per_m" not in {p.name for p in follower_parameters("pure_pursuit", "steered")}


def test_a_wrong_parameter_names_the_ones_the_follower_takes():
    path = Path([LineSegment(np.zeros(2), 0.0, 4.0)])
    with pytest.raises(GuidanceError, match=r"pure_pursuit takes no parameter 'poles_per_m'.*lookahead \(m, default"):
        make_follower("pure_pursuit", "steered", path, Steered(), poles_per_m=[-3.0, -3.0])
    with pytest.raises(GuidanceError, match=r"'lookahed'.*lookahead \(m, default none\).*max_rate \(rad/s"):
        make_follower("pure_pursuit", "unicycle", path, Unicycle(), lookahed=1.0)


def _guide_scenario():
    text = GUIDE.read_text(encoding="utf-8")
    first = text.split("**Write the scenario.** Save this as `my_first.yaml`:", 1)[1]
    scenario = first.split("```yaml\n", 1)[1].split("```", 1)[0]
    step = text.split("To try another controller, replace the whole `controller` section", 1)[1]
    controller = step.split("```yaml\n", 1)[1].split("```", 1)[0]
    head, rest = scenario.split("controller:\n", 1)
    tail = rest[rest.index("positioning:"):]
    return head + controller + tail


def test_the_user_guides_controller_step_runs_as_written(tmp_path):
    (tmp_path / "my_first.yaml").write_text(_guide_scenario())
    res = runner.invoke(app, ["simulate", str(tmp_path / "my_first.yaml"), "--out", str(tmp_path / "run_pp"),
                              "--no-plots"], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    assert "completed" in res.output and "pure_pursuit" in (tmp_path / "my_first.yaml").read_text()


def test_a_wrong_controller_parameter_is_a_scenario_error_with_file_line_and_key(tmp_path):
    text = _guide_scenario().replace("params: {convergence_distance: 2.0}", "params:\n    lookahed: 1.0")
    (tmp_path / "pp.yaml").write_text(text)
    line = next(i for i, t in enumerate(text.splitlines(), 1) if t.startswith("    lookahed: 1.0"))
    res = runner.invoke(app, ["simulate", str(tmp_path / "pp.yaml"), "--out", str(tmp_path / "o"), "--no-plots"])
    out = " ".join(res.output.split())
    assert res.exit_code == 2 and "Traceback" not in out, res.output
    assert f"pp.yaml:{line}: controller.params.lookahed: pure_pursuit takes no parameter 'lookahed'" in out
    assert "lookahead (m, default none)" in out and "convergence_distance (m, default none)" in out
    # the guide's old advice: change only the name, keeping seed_simple's poles
    old = _guide_scenario().replace("params: {convergence_distance: 2.0}", "poles_per_m: [-3.0, -3.0]")
    (tmp_path / "old.yaml").write_text(old)
    res = runner.invoke(app, ["simulate", str(tmp_path / "old.yaml"), "--out", str(tmp_path / "o"), "--no-plots"])
    assert res.exit_code == 2 and "unexpected keyword" not in res.output
    assert "controller.poles_per_m: pure_pursuit takes no parameter 'poles_per_m'" in " ".join(res.output.split())
