"""The EKF core: its step record against a hand-computed step, the compiled bearing path against the
generic measurement-model update, the recorder, and NEES consistency of the composed filter."""

from __future__ import annotations

import math
from dataclasses import FrozenInstanceError, dataclass

import numpy as np
import pytest
from scipy.stats import chi2

from agvnav.positioning import _fast
from agvnav.positioning.ekf_core import ConsiderState, EkfCore, EkfStep, make_step
from agvnav.positioning.estimator import make_estimator
from agvnav.positioning.measurement import BearingMeasurement, MeasurementModel
from agvnav.world import load_builtin_map

MOUNT = (0.6, 0.0, 0.0)


@dataclass(frozen=True)
class _Linear:
    """``z = c . x`` with white noise ``R``: the textbook linear measurement."""

    c: tuple[float, float, float]
    R: float
    name: str = "linear"
    index: int = 3
    gate: float = math.inf
    consider_index: int = -1

    def h(self, x: object) -> float:
        return float(np.dot(self.c, np.asarray(x)))

    def jacobian(self, x: object) -> tuple[float, float, float]:
        return self.c

    def noise(self, x: object) -> float:
        return self.R

    def residual(self, z: float, h: float) -> float:
        return z - h

    def consider_jacobian(self, x: object) -> tuple[float, float]:
        return 0.0, 0.0


def _core(x: tuple[float, float, float], P: np.ndarray, consider: ConsiderState | None = None) -> EkfCore:
    core = EkfCore(_fast.move_constants((0.0, 0.0, 0.0, 0.0), None, consider is not None, False, (0.0, 0.0)),
                   consider)
    core.x, core.P = x, tuple(P.reshape(9).tolist())
    return core


def test_step_record_is_the_hand_computed_kalman_step() -> None:
    P = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, 0.002], [0.0, 0.002, 0.01]])
    x0 = (1.0, 2.0, 0.3)
    model = _Linear((1.0, 0.5, 0.0), 0.01)
    assert isinstance(model, MeasurementModel)
    step = make_step(_core(x0, P).update(model, 2.0, t=0.5))
    H = np.array(model.c)
    y = 2.0 - H @ x0  # 2 - (1 + 1) = 0
    S = H @ P @ H + 0.01
    K = P @ H / S
    A = np.eye(3) - np.outer(K, H)
    assert step.accepted and step.reason == "accepted" and step.index == 3 and step.t == 0.5
    assert step.innovation == pytest.approx(y, abs=1e-15)
    assert pytest.approx(S, rel=1e-14) == step.S
    np.testing.assert_allclose(step.K, K, rtol=1e-13)
    np.testing.assert_allclose(step.x_prior, x0, rtol=0)
    np.testing.assert_allclose(step.P_prior, P, rtol=0)
    np.testing.assert_allclose(step.x_posterior, np.array(x0) + K * y, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(step.P_posterior, A @ P @ A.T + 0.01 * np.outer(K, K), rtol=1e-12, atol=1e-16)
    # the information form: P+^-1 = P^-1 + H^T R^-1 H
    np.testing.assert_allclose(np.linalg.inv(step.P_posterior), np.linalg.inv(P) + np.outer(H, H) / 0.01,
                               rtol=1e-9)
    assert step.nis == pytest.approx(y * y / S)
    with pytest.raises(FrozenInstanceError):
        step.accepted = False  # type: ignore[misc]
    with pytest.raises(ValueError):
        step.x_posterior[0] = 0.0


def test_gate_refuses_without_changing_the_state() -> None:
    P = np.diag([0.01, 0.01, 0.001])
    core = _core((0.0, 0.0, 0.0), P)
    step = make_step(core.update(_Linear((1.0, 0.0, 0.0), 0.01, gate=9.0), 5.0))
    assert not step.accepted and step.reason == "outside_gate"
    assert step.nis > 9.0 and np.isnan(step.K).all()
    assert core.x == (0.0, 0.0, 0.0) and tuple(P.reshape(9).tolist()) == core.P


def test_bearing_step_with_a_survey_consider_block_is_the_schmidt_kalman_step() -> None:
    """A fresh consider state (``P_xp = 0``): ``S = H P H^T + b + R``, ``b = svar |H_p|^2``, the gain on the pose."""
    P = np.diag([0.02, 0.03, 0.004]) ** 2
    svar = 0.003**2
    core = _core((1.0, 1.5, 0.2), P, ConsiderState([svar, svar], calibrated=False))
    model = BearingMeasurement((6.0, 4.0, 0.04), MOUNT, 1e-6, index=1)
    x = core.x
    z = model.h(x) + 0.002
    step = make_step(core.update(model, z))
    H = np.array(model.jacobian(x))
    b = svar * (H[0] ** 2 + H[1] ** 2)
    S = H @ P @ H + b + 1e-6
    K = P @ H / S
    A = np.eye(3) - np.outer(K, H)
    np.testing.assert_allclose(step.S, S, rtol=1e-12)
    np.testing.assert_allclose(step.K, K, rtol=1e-12)
    np.testing.assert_allclose(step.P_posterior, A @ P @ A.T + (b + 1e-6) * np.outer(K, K), rtol=1e-10, atol=1e-18)
    # P_xp of reflector 1 after the update: -K H_p P_pp = K H[:2] svar
    assert core.consider is not None
    np.testing.assert_allclose(core.consider.cross_covariance()[:, 2:4], np.outer(K, H[:2]) * svar, rtol=1e-10)
    np.testing.assert_array_equal(core.consider.cross_covariance()[:, :2], 0.0)


def _feed(est: object, rng: np.random.Generator, n: int) -> list[EkfStep]:
    """Bearings of the hall's reflectors seen from the true pose, in time order; the steps recorded."""
    steps: list[EkfStep] = []
    est.record_steps(steps.append)  # type: ignore[attr-defined]
    truth = (10.0, 8.0, 0.1)
    world = load_builtin_map("hall")
    t = 0.0
    for k in range(n):
        j = k % len(world.reflector_radius)
        rx, ry = world.reflector_xy[j]
        model = BearingMeasurement((float(rx), float(ry), float(world.reflector_radius[j])), MOUNT, 1e-8)
        t += 0.01
        est.predict(t, 0.0, 0.0)  # type: ignore[attr-defined]
        est.update(t, model.h(truth) + rng.normal(0.0, 1e-4) - est.bearing_offset)  # type: ignore[attr-defined]
    return steps


def test_estimator_records_every_bearing_step_and_last_step() -> None:
    world = load_builtin_map("hall")
    est = make_estimator("ekf", world, MOUNT, initial_pose=(10.02, 7.98, 0.105), bearing_std=1e-4)
    steps = _feed(est, np.random.default_rng(0), 40)
    assert len(steps) == 40
    last = est.last_step
    assert last is not None and (last.t, last.index, last.reason) == (steps[-1].t, steps[-1].index, steps[-1].reason)
    np.testing.assert_array_equal(last.P_posterior, steps[-1].P_posterior)
    accepted = [s for s in steps if s.accepted]
    assert len(accepted) == est.n_accepted > 10
    for s in accepted:
        assert s.measurement == "bearing" and s.index >= 0
        assert np.all(np.isfinite(s.K)) and np.trace(s.P_posterior) < np.trace(s.P_prior)
    for s in steps:
        if not s.accepted:
            assert s.reason in ("outside_gate", "ambiguous")
            np.testing.assert_array_equal(s.x_posterior, s.x_prior)


def test_compiled_bearing_path_equals_the_generic_model_update() -> None:
    """``gate_accept`` (the bearing model's compiled form) against :meth:`EkfCore.update` with the model."""
    world = load_builtin_map("hall")
    est = make_estimator("ekf", world, MOUNT, initial_pose=(10.02, 7.98, 0.105), bearing_std=1e-4)
    rng = np.random.default_rng(1)
    _feed(est, rng, 30)  # a consider state with cross-covariances built up
    core = est.core
    assert core.consider is not None
    twin = _core(core.x, np.array(core.P).reshape(3, 3), ConsiderState(core.consider.svar, False))
    twin.consider.M, twin.consider.C = core.consider.M, core.consider.C.copy()  # type: ignore[union-attr]
    j = 2
    rx, ry = world.reflector_xy[j]
    model = BearingMeasurement((float(rx), float(ry), float(world.reflector_radius[j])), MOUNT, est.bearing_std**2,
                               index=j)
    z = model.h(core.x) + 3e-4
    generic = make_step(twin.update(model, z, gated=False))
    est.association.claimed[:] = -math.inf
    assoc, K = est._gate_accept(est.t + 1e-3, z)
    assert assoc.index == j
    np.testing.assert_allclose(K, generic.K, rtol=1e-12)
    np.testing.assert_allclose(core.x, generic.x_posterior, rtol=1e-12)
    np.testing.assert_allclose(core.P, generic.P_posterior.reshape(9), rtol=1e-10, atol=1e-18)
    np.testing.assert_allclose(core.consider.cross_covariance(), twin.consider.cross_covariance(),  # type: ignore
                               rtol=1e-9, atol=1e-18)


def _nees(runs: int, seed: int) -> float:
    """Mean NEES of the composed filter (core + bearing models) over ``runs`` draws of prior and noise."""
    world = load_builtin_map("hall")
    rng = np.random.default_rng(seed)
    P0 = np.diag([0.03, 0.03, 0.01]) ** 2
    sigma = 2e-3
    x_hat = (10.0, 8.0, 0.1)
    models = [BearingMeasurement((float(p[0]), float(p[1]), float(r)), MOUNT, sigma**2, gate=chi2.isf(1e-6, 1))
              for p, r in zip(world.reflector_xy, world.reflector_radius, strict=True)]
    total = 0.0
    for _ in range(runs):
        truth = np.array(x_hat) + rng.multivariate_normal(np.zeros(3), P0)
        core = _core(x_hat, P0)
        for m in models[:8]:
            core.update(m, m.h(tuple(truth)) + rng.normal(0.0, sigma))
        e = truth - np.array(core.x)
        e[2] = math.remainder(e[2], 2 * math.pi)
        total += float(e @ np.linalg.solve(np.array(core.P).reshape(3, 3), e))
    return total / runs


def test_nees_of_the_composed_filter_small() -> None:
    runs = 60
    lo, hi = chi2.ppf([0.005, 0.995], 3 * runs) / runs
    assert lo <= _nees(runs, 7) <= hi


@pytest.mark.slow
def test_nees_of_the_composed_filter() -> None:
    runs = 1000
    lo, hi = chi2.ppf([0.005, 0.995], 3 * runs) / runs
    assert lo <= _nees(runs, 8) <= hi
