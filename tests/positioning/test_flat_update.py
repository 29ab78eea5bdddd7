"""The EKF's flat per-reflection path (issue 11) gives the base class's numbers, bit for bit.

:meth:`EkfEstimator.update` writes the closed loop's common case out in one pass (one compiled
call, no per-reflection helper calls) and hands every other case to
:meth:`StreamingEstimator.update`. Run with the flat path and with the base class's path alone
(compiled both), closed loops must give the same series and final state; and the flat path must
be the one that handles nearly every reflection (else it would be a copy that never runs).
"""

from __future__ import annotations

import numpy as np
import pytest

from agvnav import _jit
from agvnav.bench.speed import _scenario_with, reflector_map
from agvnav.positioning import _fast
from agvnav.positioning.ekf import EkfEstimator
from agvnav.positioning.estimator import StreamingEstimator
from agvnav.sim.build import build

pytestmark = pytest.mark.usefixtures("restore_jit_mode")

CASES = {
    "tricycle_index": (lambda: _scenario_with("guidance_test", map=reflector_map(64)), 5.0),
    "tricycle_rear": (lambda: _scenario_with("tricycle_rear_loop"), 5.0),
    "clutter_lockouts": (lambda: _scenario_with("fault_clutter"), 8.0),
}


def _run(scenario: object, seconds: float) -> tuple[dict[str, np.ndarray], EkfEstimator]:
    built = build(scenario)  # type: ignore[arg-type]
    out = built.loop.run(min(seconds, built.duration), 0.0)
    est = built.loop.estimator
    assert isinstance(est, EkfEstimator)
    return out.series, est


@pytest.mark.parametrize("case", sorted(CASES))
def test_flat_update_gives_the_base_path_bits(case: str, monkeypatch: pytest.MonkeyPatch) -> None:
    _jit.set_compiled(True)
    make, seconds = CASES[case]
    base_calls: list[float] = []
    base_update = StreamingEstimator.update

    def counted(self: StreamingEstimator, t: float, bearing: float) -> bool:
        base_calls.append(t)
        return base_update(self, t, bearing)

    monkeypatch.setattr(StreamingEstimator, "update", counted)
    flat, est_f = _run(make(), seconds)
    n_fallback = len(base_calls)
    monkeypatch.setattr(EkfEstimator, "update", counted)  # the base class's path alone
    base, est_b = _run(make(), seconds)
    n_reflections = len(base_calls) - n_fallback
    assert set(flat) == set(base)
    for name in flat:
        assert flat[name].tobytes() == base[name].tobytes(), name
    assert est_f.n_accepted == est_b.n_accepted > 20
    assert (est_f.n_rejected, est_f.n_inflations) == (est_b.n_rejected, est_b.n_inflations)
    for attr in ("_x_t", "_P_t", "_odom_t", "_M", "_Pxc", "_trusted", "_t_last_accept", "_recent_ok"):
        assert getattr(est_f, attr) == getattr(est_b, attr), attr
    assert list(est_f._recent) == list(est_b._recent)
    assert est_f._C.tobytes() == est_b._C.tobytes()
    assert est_f._claimed.tobytes() == est_b._claimed.tobytes()
    mf, mb = est_f.monitor, est_b.monitor
    assert mf._entries.rows().tobytes() == mb._entries.rows().tobytes()
    assert (mf._mean_nu, mf._n_nu, mf._clock.phase, mf._clock.sense) == (mb._mean_nu, mb._n_nu, mb._clock.phase,
                                                                         mb._clock.sense)
    assert (mf.verdict, mf.reasons) == (mb.verdict, mb.reasons)
    # the flat path handles the closed loop's reflections; the base path the start-up and the rare cases
    assert n_fallback < 0.25 * n_reflections


def test_flat_update_falls_back_when_interpreted(monkeypatch: pytest.MonkeyPatch) -> None:
    """Interpreted there is no fused kernel: the base class's path handles every reflection."""
    _jit.set_compiled(False)
    seen: dict[str, int] = {"ekf": 0, "base": 0}
    ekf_update, base_update = EkfEstimator.update, StreamingEstimator.update

    def ekf_counted(self: EkfEstimator, t: float, bearing: float) -> bool:
        seen["ekf"] += 1
        return ekf_update(self, t, bearing)

    def base_counted(self: StreamingEstimator, t: float, bearing: float) -> bool:
        seen["base"] += 1
        return base_update(self, t, bearing)

    monkeypatch.setattr(EkfEstimator, "update", ekf_counted)
    monkeypatch.setattr(StreamingEstimator, "update", base_counted)
    _, est = _run(_scenario_with("guidance_test"), 3.0)
    assert seen["ekf"] == seen["base"] > est.n_accepted > 20


def test_kernel_bound_follows_the_mode() -> None:
    """``Kernel.bound`` is what a call runs: the plain function interpreted, the dispatcher compiled."""
    k = _fast.move_state
    _jit.set_compiled(False)
    assert k.bound() is k.py_func
    _jit.set_compiled(True)
    assert k.bound() is k.dispatcher()
    args = ((0.0, 0.0, 0.0), (1.0, 2.0, 0.3), (1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 1e-5),
            (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (0.0,) * 6, 0.01, 0.002, 0.0, 0.01,
            _fast.move_constants((1e-3, 3e-3, 1e-3, 1e-3), None, True, False, (0.0, 0.0)))
    assert k.bound()(*args) == k.py_func(*args) == k(*args)
