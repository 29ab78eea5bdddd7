"""Every model: Jacobians vs numerical ones, shapes, batching, step accuracy, constraints, DOF, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.kinematics import numerical_jacobian, rk4_step


def test_jacobian_state_matches_numerical(model, sampler):
    rng = np.random.default_rng(1)
    x, u = sampler(model, rng, 20)
    num = numerical_jacobian(lambda s: model.derivative(s, u), x)
    np.testing.assert_allclose(model.jacobian_state(x, u), num, atol=1e-7)


def test_jacobian_input_matches_numerical(model, sampler):
    rng = np.random.default_rng(2)
    x, u = sampler(model, rng, 20)
    num = numerical_jacobian(lambda v: model.derivative(x, v), u)
    np.testing.assert_allclose(model.jacobian_input(x, u), num, atol=1e-7)


def test_shapes_and_batch_consistency(model, sampler):
    rng = np.random.default_rng(3)
    x, u = sampler(model, rng, 12)
    xb, ub = x.reshape(3, 4, -1), u.reshape(3, 4, -1)
    assert model.derivative(xb, ub).shape == (3, 4, model.n_state)
    assert model.jacobian_state(xb, ub).shape == (3, 4, model.n_state, model.n_state)
    assert model.jacobian_input(xb, ub).shape == (3, 4, model.n_state, model.n_input)
    batch = model.step(x, u, 0.1)
    single = np.stack([model.step(x[i], u[i], 0.1) for i in range(len(x))])
    np.testing.assert_allclose(batch, single, rtol=0, atol=1e-13)
    # Broadcasting one input over many states, and one state over many inputs.
    assert model.step(x, u[0], 0.1).shape == x.shape
    assert model.jacobian_state(x, u[0]).shape == (12, model.n_state, model.n_state)
    assert model.jacobian_input(x, u[0]).shape == (12, model.n_state, model.n_input)
    assert model.jacobian_state(x[0], u).shape == (12, model.n_state, model.n_state)
    assert model.derivative(x[0], u).shape == (12, model.n_state)
    assert model.step(x[0], u, 0.1).shape == (12, model.n_state)


def test_step_matches_fine_rk4(model, sampler):
    rng = np.random.default_rng(4)
    x, u = sampler(model, rng, 30)
    ref = rk4_step(model.derivative, x, u, 0.1, substeps=500)
    np.testing.assert_allclose(model.step(x, u, 0.1), ref, atol=1e-10)


def test_constraints_hold_along_trajectory(model, sampler):
    """Seed 003: A(q)·q' = 0 at every point of a simulated trajectory (1e-9)."""
    rng = np.random.default_rng(5)
    x, _ = sampler(model, rng, 8)
    for _ in range(50):
        _, u = sampler(model, rng, 8)
        u *= 0.3
        a = model.constraint_matrix(x)
        qd = model.derivative(x, u)
        assert np.max(np.abs(np.einsum("...kn,...n->...k", a, qd)), initial=0.0) < 1e-9
        x = model.step(x, u, 0.05)


def test_dof_equals_inputs_and_constraints_independent(model, sampler):
    """DOF = configuration variables − independent constraints = number of inputs (seed 003 counts)."""
    rng = np.random.default_rng(6)
    x, _ = sampler(model, rng, 5)
    a = model.constraint_matrix(x)
    assert a.shape == (5, model.n_constraints, model.n_state)
    if model.n_constraints:
        assert np.all(np.linalg.matrix_rank(a) == model.n_constraints)
    assert model.dof == model.n_input


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_nonfinite_input_is_named(model, bad):
    u = np.zeros(model.n_input)
    u[0] = bad
    with pytest.raises(ValueError, match=model.input_names[0]):
        model.check_input(u)
    assert not model.input_valid(u)


def test_wrong_shapes_raise(model, sampler):
    with pytest.raises(ValueError, match="u must have shape"):
        model.check_input(np.zeros(model.n_input + 1))
    with pytest.raises(ValueError, match="state must have shape"):
        model.check_state(np.zeros((2, model.n_state + 1)))
    with pytest.raises(ValueError, match="dt"):
        model.checked_step(np.zeros(model.n_state), np.zeros(model.n_input), -0.1)


def test_input_valid_flags_only_bad_elements(model, sampler):
    u = np.zeros((3, model.n_input))
    u[1, 0] = np.nan
    np.testing.assert_array_equal(model.input_valid(u), [True, False, True])
