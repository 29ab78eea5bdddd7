"""The compiled per-reflection path (issue 11) gives the plain path's numbers, bit for bit.

The streaming estimators run their prediction, gate and Schmidt update as compiled kernels
(``move_state``, ``gate_rows``, ``gate_accept`` of :mod:`agvnav.positioning._fast`) when the
kernels run compiled, and as the plain functions otherwise. ``tests/test_twins.py`` checks each
kernel against its plain form on random inputs and ``tests/test_jit.py`` each kernel's two modes;
here whole closed-loop runs (every noise model, the bearing index, walls that hide reflectors,
lock-out inflations, a fix-based estimator) must give the same series in both.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvnav import _jit
from agvnav.bench.speed import _scenario_with, reflector_map
from agvnav.positioning import _fast
from agvnav.sim.build import build

pytestmark = pytest.mark.usefixtures("restore_jit_mode")


def _run(scenario: object, compiled: bool, seconds: float) -> tuple[dict[str, np.ndarray], object]:
    _jit.set_compiled(compiled)
    built = build(scenario)  # type: ignore[arg-type]
    out = built.loop.run(min(seconds, built.duration), 0.0)
    return out.series, built.loop.estimator


CASES = {
    "tricycle_index": (lambda: _scenario_with("guidance_test", map=reflector_map(64)), 6.0),
    "tricycle_rear": (lambda: _scenario_with("tricycle_rear_loop"), 6.0),
    "differential": (lambda: _scenario_with("differential_loop"), 6.0),
    "mecanum_lateral": (lambda: _scenario_with("mecanum_loop"), 6.0),
    "naive_fix_based": (lambda: _scenario_with("guidance_test", positioning={"method": "naive"}), 4.0),
    "clutter_lockouts": (lambda: _scenario_with("fault_clutter"), 8.0),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_compiled_path_gives_the_plain_path_bits(case: str) -> None:
    make, seconds = CASES[case]
    plain, est_p = _run(make(), False, seconds)
    fast, est_f = _run(make(), True, seconds)
    assert set(plain) == set(fast)
    for name in plain:
        a, b = np.asarray(plain[name]), np.asarray(fast[name])
        assert a.shape == b.shape and a.tobytes() == b.tobytes(), name
    assert est_p.n_accepted == est_f.n_accepted > 20  # type: ignore[attr-defined]
    assert est_p.n_rejected == est_f.n_rejected  # type: ignore[attr-defined]
    assert est_p.n_inflations == est_f.n_inflations  # type: ignore[attr-defined]
    for attr in ("_x_t", "_P_t", "_odom_t", "_M", "_Pxc"):
        assert getattr(est_p, attr, None) == getattr(est_f, attr, None), attr
    if hasattr(est_p, "_C"):
        assert est_p._C.tobytes() == est_f._C.tobytes()  # type: ignore[attr-defined]


def test_powers_reach_the_c_library_pow() -> None:
    """``x ** 2`` in CPython is libm's ``pow``, which differs from ``x * x`` on some inputs; the kernels match it."""
    rng = np.random.default_rng(3)
    ratios = rng.uniform(0.0, 1.0, 20_000).tolist()
    differ = [r for r in ratios if r**2 != r * r]
    assert differ, "no input where pow(x, 2) and x * x differ: the check below would be vacuous"
    _jit.set_compiled(True)
    gc = _fast.gate_constants(_gate_spec(), (0.0, 0.0, 0.0), None, 1e-7)
    assert gc[_fast._G_TWO] == 2.0 and gc[_fast._G_THREE] == 3.0
    # a reflector at distance d with radius r = ratio d: the Jacobian's edge gain takes ratio ** 2 and d ** 3
    for ratio in differ[:20]:
        d = 3.0
        tab = _fast.gate_table([(d, 0.0, ratio * d)])
        z = -math.asin(ratio)  # the edge bearing seen from the origin, heading 0
        got = _fast.gate_rows(z, 1.0, (0.0, 0.0, 0.0), (1e-6, 0.0, 0.0, 0.0, 1e-6, 0.0, 0.0, 0.0, 1e-6),
                              (1.0,) * 9, np.zeros((1, 6)), np.full(1, -math.inf), np.ones(1, np.bool_), tab, gc,
                              np.zeros(2, np.int64), np.zeros(0, np.int64))
        ref = _fast.gate_one(z, (0.0, 0.0, 0.0), (1e-6, 0.0, 0.0, 0.0, 1e-6, 0.0, 0.0, 0.0, 1e-6), (0.0, 0.0, 0.0),
                             [(d, 0.0, ratio * d)], _gate_spec(), [-math.inf], 1.0)
        assert got[0] == ref[0] == 0
        assert (got[4], got[5], got[6], got[7]) == (*ref[4], ref[5])


def _gate_spec() -> object:
    from agvnav.positioning.gating import GateSpec

    return GateSpec(1e-7, 30.0, 10.8, 0.001, 0.1)


@pytest.mark.parametrize("p_xy", [0.01, 0.13])
def test_lockout_inflation_between_gate_and_update(p_xy: float) -> None:
    """Rejections that outnumber acceptances inflate ``P`` between the gate and the update, in either mode.

    With ``P`` already large (``p_xy = 0.13``: no room left below ``MAX_INFLATED_POSITION_VAR``
    before the update, room after it) the inflation must not happen; with room it must.
    """
    from agvnav.positioning import make_estimator
    from agvnav.positioning.identification import bearing_model
    from agvnav.world import load_builtin_map

    world = load_builtin_map("lab")
    pose = np.array([6.0, 5.0, 0.3])
    mount = (0.3, 0.0, 0.0)
    results = []
    for compiled in (False, True):
        _jit.set_compiled(compiled)
        est = make_estimator("ekf", world, mount, initial_pose=pose,
                             initial_covariance=np.diag([0.01, 0.01, 1e-6]), strict=True)
        est.predict(0.0, 0.0, 0.0)
        est._P_t = (p_xy, 0.0, 0.0, 0.0, p_xy, 0.0, 0.0, 0.0, 1e-6)  # type: ignore[attr-defined]  # grown since
        est._recent.extend((0.001 * (k + 1), False) for k in range(5))  # type: ignore[attr-defined]  # 5 in no gate
        h, _, _ = bearing_model(pose, mount, world.reflector_xy, world.reflector_radius)
        # a reflector its own bearing identifies (alone in its gate), the farthest such
        j = next(int(i) for i in np.argsort(-np.hypot(*(world.reflector_xy - pose[:2]).T))
                 if est._gate(0.01, float(h[i])).index == i)  # type: ignore[attr-defined]
        accepted = est.update(0.01, float(h[j]) - est.bearing_offset)
        results.append((accepted, est.n_inflations, est._x_t, est._P_t, est._M, est._C.tobytes()))  # type: ignore[attr-defined]
    assert results[0][0] and results[0][:2] == results[1][:2]
    assert results[0][1] == (1 if p_xy == 0.01 else 0)
    assert results[0] == results[1]
