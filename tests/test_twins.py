"""One parametrized equivalence test over the twin table (``agvnav.twins``), and its guard.

Every row of ``agvnav.twins.TWINS`` has a case here that draws random inputs and
returns both forms' outputs; the test asserts they agree to the row's ``atol``.
The guard fails when the source holds a scalar twin (a public name of a
``*.scalar`` module, or a function/method named ``*_scalar``/``*_few``/``*_one``
that says it mirrors another form) that the table does not list.
"""

from __future__ import annotations

import ast
import importlib
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import agvnav
from agvnav.actuators import PID, MotorPair, WheelSpeedLoop
from agvnav.actuators.scalar import ScalarSpeedLoop
from agvnav.actuators.speed_profile import _profile_speed_scalar, profile_speed
from agvnav.actuators.steering import _steering_step_scalar, steering_step
from agvnav.geometry.angles import wrap_angle, wrap_angle_scalar
from agvnav.guidance.errors import tracking_errors, tracking_errors_scalar
from agvnav.guidance.paths import ArcSegment, LineSegment
from agvnav.guidance.paths import Path as GPath
from agvnav.kinematics import TricycleStacker
from agvnav.kinematics.scalar import stacker_rate, stacker_rk4, stacker_rk4_values, track_twist
from agvnav.kinematics.tracked import TrackedVehicle, TrackSlipNoise
from agvnav.odometry import (
    differential_increments,
    tricycle_increments,
)
from agvnav.odometry.errors import NonSystematicErrors
from agvnav.odometry.scalar import differential_increments_scalar, track_increments, tricycle_increments_scalar
from agvnav.positioning import _fast as pos_fast
from agvnav.positioning.bearing_gate import gate_reflection
from agvnav.positioning.edge_bearing import bearing_model
from agvnav.positioning.gating import GateSpec
from agvnav.sensors.goniometer import Goniometer
from agvnav.twins import TWINS, Twin, twin_names
from agvnav.world import load_builtin_map

SRC = Path(agvnav.__file__).parent
N_DRAWS = 40
Pair = tuple[object, object]


def _resolve(ref: str) -> object:
    module, _, qual = ref.partition(":")
    obj: object = importlib.import_module(module)
    for part in qual.split("."):
        obj = getattr(obj, part)
    return obj


def _wrap(rng: np.random.Generator) -> Pair:
    a = [float(v) for v in rng.uniform(-20, 20, 8)] + [math.pi, -math.pi, 3 * math.pi, 0.0]
    return [wrap_angle_scalar(v) for v in a], wrap_angle(np.array(a))


def _stacker_rk4(rng: np.random.Generator) -> Pair:
    model = TricycleStacker(1.1)
    model.substeps = 1
    x = np.array([*rng.normal(size=2), rng.uniform(-3, 3), rng.uniform(-1.4, 1.4)])
    u = rng.normal(size=2)
    return stacker_rk4(x, u[0], u[1], 1.1, 0.05)[0], model.step(x, u, 0.05)


def _stacker_rk4_values(rng: np.random.Generator) -> Pair:
    model = TricycleStacker(1.1)
    model.substeps = 1
    x = np.array([*rng.normal(size=2), rng.uniform(-3, 3), rng.uniform(-1.4, 1.4)])
    u = rng.normal(size=2)
    new, start, end = stacker_rk4_values(x.tolist(), u[0], u[1], 1.1, 0.05)
    ref = model.step(x, u, 0.05)
    return [*new, *start, *end], [*ref, *model.derivative(x, u), *model.derivative(ref, u)]


def _stacker_rate(rng: np.random.Generator) -> Pair:
    x = np.array([*rng.normal(size=2), rng.uniform(-3, 3), rng.uniform(-1.4, 1.4)])
    u = rng.normal(size=2)
    return stacker_rate(x[2], x[3], u[0], u[1], 1.1), TricycleStacker(1.1).derivative(x, u)


def _tracked(rng: np.random.Generator) -> object:
    return TrackedVehicle(0.33, 0.05, str(rng.choice(["concrete", "artificial_grass", "ideal"])))


def _track_twist(rng: np.random.Generator) -> Pair:
    veh, u = _tracked(rng), rng.uniform(-1, 1, 2)
    return track_twist(u[0], u[1], veh.twist_matrix.tolist()), veh.body_twist(u)  # type: ignore[attr-defined]


def _track_increments(rng: np.random.Generator) -> Pair:
    veh, d = _tracked(rng), rng.uniform(-0.2, 0.2, 2)
    twist = veh.body_twist(d)  # type: ignore[attr-defined]
    return track_increments(d[0], d[1], veh.twist_matrix.tolist()), [twist[0], twist[2]]  # type: ignore[attr-defined]


def _track_factors(rng: np.random.Generator) -> Pair:
    terrain = TrackSlipNoise(std=float(rng.uniform(0, 0.05)))
    seed, d = int(rng.integers(1 << 30)), float(rng.choice([rng.uniform(0, 2), 0.0]))
    return (terrain.factors_scalar(d, np.random.default_rng(seed)),
            terrain.factors(d, np.random.default_rng(seed)))


def _tricycle_increments(rng: np.random.Generator) -> Pair:
    ds, g = rng.uniform(-0.3, 0.3), rng.uniform(-1.5, 1.5)
    return tricycle_increments_scalar(ds, g, 1.2), np.asarray(tricycle_increments(ds, g, 1.2))


def _differential_increments(rng: np.random.Generator) -> Pair:
    dr, dl = rng.uniform(-0.3, 0.3, 2)
    return differential_increments_scalar(dr, dl, 0.5), np.asarray(differential_increments(dr, dl, 0.5))


def _perturb(rng: np.random.Generator) -> Pair:
    std = float(rng.uniform(0.0, 0.05))
    model = NonSystematicErrors(slip_k=std * std, bump_rate=float(rng.choice([0.0, 2.0])))
    seed, d = int(rng.integers(1 << 30)), float(rng.uniform(-0.3, 0.3))
    return model.perturb_scalar(d, np.random.default_rng(seed)), model.perturb(d, np.random.default_rng(seed))


def _speed_loop(rng: np.random.Generator) -> Pair:
    ref = WheelSpeedLoop(MotorPair(asymmetry=0.05), PID())
    fast = ScalarSpeedLoop(WheelSpeedLoop(MotorPair(asymmetry=0.05), PID()))
    a, b = [], []
    for _ in range(20):
        sp = rng.uniform(-6, 6, 2)
        a.append(ref.step(sp, 0.01))
        b.append(fast.step((float(sp[0]), float(sp[1])), 0.01))
    return b, a


def _steering_step(rng: np.random.Generator) -> Pair:
    g, r, cmd = rng.uniform(-1.5, 1.5), rng.uniform(-1, 1), rng.uniform(-2, 2)
    dt, tau = rng.uniform(0.01, 0.1), float(rng.choice([0.0, rng.uniform(0.01, 0.2)]))
    ref = steering_step(g, r, cmd, dt, tau, 1.0, 1.4)
    return _steering_step_scalar(g, r, cmd, dt, tau, 1.0, 1.4), [float(ref[0]), float(ref[1])]


def _profile_speed(rng: np.random.Generator) -> Pair:
    v, target, rem, dt = rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-0.1, 3), rng.uniform(0.01, 0.1)
    return _profile_speed_scalar(v, target, rem, dt, 0.3, 0.4), profile_speed(v, target, rem, dt, 0.3, 0.4)


def _path() -> object:
    line = LineSegment(np.array([1.0, 2.0]), 0.3, 3.0)
    arc = ArcSegment(line.end, 0.3, 1.5, 2.0)
    return GPath([line, arc])


def _segment(kind: str) -> object:
    return _path().segments[0 if kind == "line" else 1]  # type: ignore[attr-defined]


def _segment_point(kind: str) -> Callable[[np.random.Generator], Pair]:
    def case(rng: np.random.Generator) -> Pair:
        seg, u = _segment(kind), float(rng.uniform(-1, 4))
        return seg.point_scalar(u), seg.point_at(u)  # type: ignore[attr-defined]
    return case


def _segment_project(kind: str) -> Callable[[np.random.Generator], Pair]:
    def case(rng: np.random.Generator) -> Pair:
        seg, (x, y) = _segment(kind), rng.uniform(-1, 6, 2)
        lo = float(rng.uniform(0, 1))
        hi = lo + float(rng.uniform(0, 2))
        u = seg.project_scalar(x, y, lo, hi)[0]  # type: ignore[attr-defined]
        return u, seg.local_projection(np.array([x, y]), lo, hi)  # type: ignore[attr-defined]
    return case


def _path_project(rng: np.random.Generator) -> Pair:
    path, (x, y) = _path(), rng.uniform(-1, 6, 2)
    pr, ref = path.project_point(x, y), path.project(np.array([x, y]))  # type: ignore[attr-defined]
    length = float(path.length)  # type: ignore[attr-defined]
    hint, window = float(rng.uniform(0.0, length)), float(rng.uniform(0.05, 0.5 * length))  # a windowed search
    pw = path.project_point(x, y, hint, window)  # type: ignore[attr-defined]
    rw = path.project(np.array([x, y]), hint, window)  # type: ignore[attr-defined]
    return ([pr.s, pr.lateral, pr.heading, pw.s, pw.lateral, pw.heading],
            [float(ref.s), float(ref.lateral), float(ref.heading), float(rw.s), float(rw.lateral), float(rw.heading)])


def _tracking_errors(rng: np.random.Generator) -> Pair:
    path = _path()
    pose = (float(rng.uniform(0, 5)), float(rng.uniform(1, 5)), float(rng.uniform(-3, 3)))
    g, point = float(rng.uniform(-0.5, 0.5)), str(rng.choice(["C", "O"]))
    a = tracking_errors_scalar(path, pose, g, 1.0, point)  # type: ignore[arg-type]
    b = tracking_errors(path, np.array(pose), g, 1.0, point)  # type: ignore[arg-type]
    return [a.eps_c, a.eps_o, a.xi, a.xi_r], [float(b.eps_c), float(b.eps_o), float(b.xi), float(b.xi_r)]


def _goniometer() -> object:
    return Goniometer(rate_hz=8.0, mount=(0.3, 0.1, 0.2))


def _encoder_bearing(rng: np.random.Generator) -> Pair:
    gon, t = _goniometer(), rng.uniform(0, 3600, 5)
    return gon._encoder_bearing_few(t), gon.encoder_bearing(t)  # type: ignore[attr-defined]


def _gate_one(rng: np.random.Generator) -> Pair:
    world = load_builtin_map("lab")
    xy, radius = world.reflector_xy, world.reflector_radius
    pose, mount = rng.uniform([2, 2, -math.pi], [18, 10, math.pi]), (0.3, 0.05, 0.01)
    a = rng.normal(0.0, 0.01, (3, 3))
    P = a @ a.T + 1e-6 * np.eye(3)
    h, _, _ = bearing_model(pose, mount, xy, radius)
    z = float(wrap_angle(h[int(rng.integers(xy.shape[0]))] + rng.normal(0.0, 3e-3)))
    ref = gate_reflection(z, pose, P, mount, xy, radius, 1e-7, gate=10.8, map_std=0.002)
    spec = GateSpec(bearing_var=1e-7, max_range=math.inf, gate=10.8, map_std=0.002, sweep=0.1)
    got = pos_fast.gate_one(z, tuple(pose.tolist()), tuple(P.reshape(9).tolist()), mount,
                            pos_fast.reflector_rows(xy, radius), spec, [-math.inf] * xy.shape[0], 1.05)
    if ref.index < 0:
        return [got[0], got[3]], [ref.index, ref.n_in_gate]
    return [got[0], got[3], got[1], got[2]], [ref.index, ref.n_in_gate, ref.innovation, ref.nis]


CASES: dict[str, Callable[[np.random.Generator], Pair]] = {
    "wrap_angle": _wrap, "stacker_rk4": _stacker_rk4, "stacker_rk4_values": _stacker_rk4_values,
    "stacker_rate": _stacker_rate,
    "track_twist": _track_twist, "track_factors": _track_factors, "tricycle_increments": _tricycle_increments,
    "track_increments": _track_increments, "differential_increments": _differential_increments,
    "perturb": _perturb, "speed_loop": _speed_loop, "steering_step": _steering_step,
    "profile_speed": _profile_speed, "tracking_errors": _tracking_errors,
    "line_point": _segment_point("line"), "line_project": _segment_project("line"),
    "arc_point": _segment_point("arc"), "arc_project": _segment_project("arc"),
    "path_project": _path_project, "encoder_bearing": _encoder_bearing, "gate_one": _gate_one,
}


@pytest.mark.parametrize("twin", TWINS, ids=lambda t: t.name)
def test_twin_forms_agree(twin: Twin) -> None:
    """Both forms exist and agree to the row's tolerance on random inputs."""
    assert callable(_resolve(twin.scalar)) and callable(_resolve(twin.reference))
    assert twin.name in CASES, f"twin {twin.name!r} has no equivalence case in tests/test_twins.py"
    rng = np.random.default_rng(11)
    for _ in range(N_DRAWS):
        got, ref = CASES[twin.name](rng)
        np.testing.assert_allclose(np.asarray(got, dtype=float), np.asarray(ref, dtype=float).reshape(np.shape(got)),
                                   rtol=0, atol=twin.atol, err_msg=twin.name)


def test_twin_names_unique_and_every_case_listed() -> None:
    names = [t.name for t in TWINS]
    assert len(names) == len(set(names))
    assert set(CASES) == set(names)


_SUFFIXES = ("_scalar", "_few", "_one")
_MIRROR_WORDS = ("fast path", "mirrors", "same arithmetic", "same operations", "same equations")


def _scalar_twins_in_source() -> set[str]:
    """``module:qualname`` of every scalar twin the source declares (see the module doc)."""
    found: set[str] = set()
    for path in SRC.rglob("*.py"):
        rel = path.relative_to(SRC.parent).with_suffix("")
        module = ".".join(p for p in rel.parts if p != "__init__")
        tree = ast.parse(path.read_text(encoding="utf-8"))
        is_scalar_module = path.stem == "scalar"
        for node in tree.body:
            items = [(node, node.name)] if isinstance(node, (ast.FunctionDef, ast.ClassDef)) else []
            if isinstance(node, ast.ClassDef):
                items += [(m, f"{node.name}.{m.name}") for m in node.body if isinstance(m, ast.FunctionDef)]
            for item, qual in items:
                doc = (ast.get_docstring(item) or "").lower()
                named = item.name.endswith(_SUFFIXES) and any(w in doc for w in _MIRROR_WORDS)
                top_level_public = is_scalar_module and "." not in qual and not item.name.startswith("_")
                if named or (top_level_public and isinstance(item, ast.FunctionDef)):
                    found.add(f"{module}:{qual}")
                if top_level_public and isinstance(item, ast.ClassDef):
                    found.update(f"{module}:{qual}.{m.name}" for m in item.body
                                 if isinstance(m, ast.FunctionDef) and not m.name.startswith("_"))
    return found


def test_every_scalar_twin_in_the_source_is_in_the_table() -> None:
    missing = sorted(_scalar_twins_in_source() - twin_names())
    assert not missing, "scalar twins missing from agvnav.twins.TWINS (add a row and a case):\n" + "\n".join(missing)


def test_guard_sees_known_twins() -> None:
    """The guard is not vacuous: it finds the scalar modules' kernels and a ``*_scalar`` method."""
    found = _scalar_twins_in_source()
    assert "agvnav.kinematics.scalar:stacker_rate" in found
    assert "agvnav.guidance.paths:ArcSegment.project_scalar" in found
