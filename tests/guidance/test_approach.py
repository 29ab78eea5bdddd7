"""HeadingHoldApproach: the steered station approach that holds the heading over the last centimetres."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

from agvnav.guidance import make_follower, path_from_moves
from agvnav.guidance.approach import HeadingHoldApproach, hold_steering
from agvnav.guidance.errors import tracking_errors_scalar
from agvnav.guidance.follower import GuidanceError
from agvnav.guidance.paths import LineSegment, Path


@dataclass(frozen=True)
class Steered:
    wheelbase: float = 1.0
    drive_point: str = "C"
    max_steer: float = 1.2


@dataclass(frozen=True)
class Unicycle:
    track: float = 0.5
    wheel_radius: float = 0.1


LINE = path_from_moves((0.0, 0.0, 0.0), [("line", 2.0)])
BACK = Path([LineSegment(np.array([2.0, 0.0]), math.pi, 2.0, direction=-1)])  # backing up to (0, 0)


def _o_follower(path: Path = LINE) -> Any:
    return make_follower("seed_general", "steered", path, Steered(), point="O", convergence_distance=1.0)


def test_far_from_the_stop_the_wrapped_law_steers() -> None:
    plain, held = _o_follower(), HeadingHoldApproach(_o_follower(), (2.0, 0.0), 0.3)
    pose = np.array([1.0, 0.004, 0.01])
    assert held.command(pose, 0.5, 0.02) == plain.command(pose, 0.5, 0.02)
    assert not held.holding


def test_within_the_hold_the_target_steers_the_heading_error_away() -> None:
    held = HeadingHoldApproach(_o_follower(), (2.0, 0.0), 0.3)  # heading_distance 0.1 m
    xi, gamma = math.radians(0.8), 0.01
    _, rate = held.command(np.array([1.8, 0.004, xi]), 0.05, gamma)  # 4 mm lateral: ignored
    assert held.holding
    assert rate == pytest.approx((math.atan(-1.0 * xi / 0.1) - gamma) / 0.1, rel=1e-9)
    back = HeadingHoldApproach(_o_follower(BACK), (0.0, 0.0), 0.3)
    _, rate = back.command(np.array([0.2, 0.0, xi]), -0.05, 0.0)  # reversing: the opposite steering
    assert rate == pytest.approx(math.atan(1.0 * xi / 0.1) / 0.1, rel=1e-9)
    assert back.command(np.array([0.2, 0.0, xi]), 0.0, 0.0) == (0.0, 0.0)


def test_a_path_ending_elsewhere_is_not_held() -> None:
    plain, held = _o_follower(), HeadingHoldApproach(_o_follower(), (5.0, 0.0), 0.3)
    pose = np.array([1.9, 0.002, 0.01])
    assert held.command(pose, 0.05, 0.0) == plain.command(pose, 0.05, 0.0)
    assert not held.holding


def _creep(follower: Any, xi0: float, lateral0: float, v: float = 0.05, dt: float = 0.05) -> tuple[float, float]:
    """Kinematic tricycle (front wheel drives, [seed000 eq8]) creeping from 0.3 m before the end: (heading, lateral)."""
    x, y, psi, gamma = 1.7, lateral0, xi0, 0.0
    for _ in range(2000):
        if x >= 2.0:
            break
        _, rate = follower.command(np.array([x, y, psi]), v, gamma)
        gamma += rate * dt
        v_c = v / math.cos(gamma)
        x += v_c * math.cos(gamma) * math.cos(psi) * dt
        y += v_c * math.cos(gamma) * math.sin(psi) * dt
        psi += v_c * math.sin(gamma) / 1.0 * dt
    return psi, y


def test_the_hold_ends_on_the_station_heading_with_the_lateral_it_started_with() -> None:
    xi0, lat0 = math.radians(0.8), 0.002
    psi, y = _creep(HeadingHoldApproach(_o_follower(), (2.0, 0.0), 0.3), xi0, lat0)
    assert abs(math.degrees(psi)) < 0.05  # exp(-3) of 0.8 deg, and the servo's lag
    assert abs(y - lat0) <= xi0 * 0.1 + 1e-4  # the heading integrated over the decay
    psi_plain, _ = _creep(_o_follower(), xi0, lat0)  # the law on O turns to correct the lateral
    assert abs(math.degrees(psi_plain)) > 0.2


def test_bad_input() -> None:
    with pytest.raises(ValueError, match="hold_distance"):
        HeadingHoldApproach(_o_follower(), (2.0, 0.0), 0.0)
    unicycle = make_follower("pure_pursuit", "unicycle", LINE, Unicycle(), convergence_distance=1.0)
    with pytest.raises(GuidanceError, match="steered"):
        HeadingHoldApproach(unicycle, (2.0, 0.0), 0.3)


# --- curved approaches: the heading error decays as exp(-s / heading_distance) in the guided point's distance ---

ARC = path_from_moves((0.0, 0.0, 0.0), [("line", 1.0), ("arc", 2.5, 1.0)])  # L / R = 0.4
ARC_BACK = path_from_moves((3.0, 0.0, math.pi), [("line", 1.0, -1), ("arc", 2.5, -1.0, -1)])  # backing, a right arc


def _moved(pose: np.ndarray, gamma: float, ds: float, point: str, direction: int) -> np.ndarray:
    """Exact tricycle motion at fixed steering ([seed000 eq8]) over ``ds`` m of the guided point's
    distance along the motion: O runs along the body axis on curvature tan(gamma) / L, C along the
    wheel on sin(gamma) / L (L = 1 m)."""
    x, y, psi = (float(c) for c in pose)
    sigma = direction * ds  # signed displacement along the body axis (O) or the wheel (C)
    if point == "O":
        k, px, py, a = math.tan(gamma), x, y, psi
    else:
        k, px, py, a = math.sin(gamma), x + math.cos(psi), y + math.sin(psi), psi + gamma
    a2 = a + sigma * k
    px, py = px + (math.sin(a2) - math.sin(a)) / k, py - (math.cos(a2) - math.cos(a)) / k
    psi2 = psi + sigma * k
    if point == "C":
        px, py = px - math.cos(psi2), py - math.sin(psi2)
    return np.array([px, py, psi2])


@pytest.mark.parametrize(("point", "path", "direction"), [("O", ARC, 1), ("C", ARC, 1), ("O", ARC_BACK, -1)])
def test_on_an_arc_the_heading_error_decays_at_the_hold_rate(point: str, path: Path, direction: int) -> None:
    follower = make_follower("seed_general", "steered", path, Steered(), point=point, convergence_distance=1.0)
    end = path.point_at(path.length)
    held = HeadingHoldApproach(follower, (float(end[0]), float(end[1])), 0.3)  # heading_distance 0.1 m
    s = path.length - 0.15
    p, h = path.point_at(s), float(path.heading_at(s)) + (0.0 if direction > 0 else math.pi)
    kappa = float(path.curvature_at(s))
    gamma_ss = math.atan(direction * kappa) if point == "O" else math.asin(direction * kappa)
    xi0, lateral = math.radians(0.8), 0.004
    psi = h + xi0 - (gamma_ss if point == "C" else 0.0)  # C: the steady turn's body lags the wheel by gamma_ss
    normal = np.array([-math.sin(h), math.cos(h)])
    guided = p + lateral * normal
    pose = np.array([*(guided - (np.array([math.cos(psi), math.sin(psi)]) if point == "C" else 0.0)), psi])
    gamma0 = gamma_ss + 0.01
    _, rate = held.command(pose, 0.05 * direction, gamma0)
    assert held.holding
    e = held.last_errors
    assert e is not None and float(e.xi) == pytest.approx(xi0, abs=1e-9)
    target = gamma0 + rate * held.servo_tau  # the servo steers towards the target

    def xi_after(ds: float) -> float:
        moved = _moved(pose, target, ds, point, direction)
        return float(tracking_errors_scalar(path, tuple(moved), target, 1.0, point, s_hint=s, window=0.5).xi)

    h_ds = 1e-4
    dxi_ds = (xi_after(h_ds) - xi_after(-h_ds)) / (2.0 * h_ds)
    # known answer: d xi / ds = -xi / heading_distance (the old gamma_ss + atan(-d L xi / hd): 1.10x, 0.92x, 1.22x)
    assert dxi_ds == pytest.approx(-xi0 / 0.1, rel=1e-5)


def test_hold_steering_names_a_bad_point() -> None:
    e = _o_follower()
    e.command(np.array([1.0, 0.0, 0.0]), 0.5, 0.0)
    with pytest.raises(ValueError, match="point"):
        hold_steering(e.last_errors, 1.0, "B", 1.0, 0.1)
