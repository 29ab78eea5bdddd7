"""Sparse least squares for the mapping graph, and the marginal covariances of its reflectors.

The default solver is Levenberg-Marquardt on the normal equations ``(JᵀJ + λ diag(JᵀJ)) δ = −Jᵀe``
with SciPy's sparse LU (SuperLU, COLAMD ordering): the graph is a chain of poses with a few
reflectors, so the factorisation stays sparse. Warm-started after each chunk of the drive it
is the incremental update (:mod:`agvnav.mapping.slam`); GTSAM's iSAM2 would do the same with
relinearisation of only what changed — measured against this solver in ``agvnav bench mapping``
where ``gtsam`` is installed (the optional ``slam`` extra).

The covariance of the estimate is ``(JᵀJ)⁻¹`` at the solution (the Laplace approximation); the
reflector marginals are the columns of that inverse solved for the reflector block only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from agvnav.mapping.graph import FactorGraph, linearize

__all__ = ["PERMC", "Solution", "factorize", "marginal_covariances", "reflector_covariance", "solve"]

F64 = NDArray[np.float64]

#: Column ordering of the sparse LU. The state is ordered poses (a chain: banded), reflectors, then
#: the odometry's scale and systematic errors, which is already a good elimination order.
PERMC: Literal["NATURAL"] = "NATURAL"


def factorize(A: Any) -> Any:
    """Sparse LU of a symmetric positive definite ``A`` (the information matrix) without pivoting.

    SuperLU's default partial pivoting swapped rows of the badly scaled information matrix
    (radians against metres, the scale's column) and filled the factor 20-fold: 0.4 s instead of
    0.02 s per factorisation on the hall drive. ``A`` is SPD, so the diagonal pivots are safe.
    RuntimeError when ``A`` is singular.
    """
    return spla.splu(sp.csc_matrix(A, dtype=np.float64), permc_spec=PERMC, diag_pivot_thresh=0.0)


@dataclass(frozen=True)
class Solution:
    """Result of :func:`solve`: state ``x``, cost ``½Σe²``, iterations and whether it converged."""

    x: F64
    cost: float
    iterations: int
    converged: bool


def solve(graph: FactorGraph, x0: F64, max_iterations: int = 30, tolerance: float = 1e-9,
          free: NDArray[np.bool_] | None = None, huber: float | None = None) -> Solution:
    """Minimise ``½ Σ e(x)²`` over the graph from ``x0`` (Levenberg-Marquardt, sparse normal equations).

    Converged when the relative cost decrease falls below ``tolerance`` or the step is below
    1e-10 in every variable. ValueError when the information matrix is singular (a gauge is
    not fixed: see :mod:`agvnav.mapping.anchors`). ``free`` (n_vars,) marks the variables to
    solve for (a sliding window); the others are held at ``x0``. ``huber``: a Huber kernel on the
    whitened residuals beyond this many sigma (iteratively reweighted; the returned cost is robust).
    """
    x = np.asarray(x0, dtype=np.float64).copy()
    cols = np.arange(graph.n_vars) if free is None else np.flatnonzero(free)
    e, J = _lin(graph, x, cols if free is not None else None, huber)
    cost = 0.5 * float(e @ e)
    lam = 1e-6
    it = 0
    for it in range(1, max_iterations + 1):
        assert J is not None
        H = (J.T @ J).tocsc()
        g = J.T @ e
        diag = H.diagonal()
        improved = False
        for _ in range(10):
            A = H + sp.diags(lam * np.maximum(diag, 1e-12))
            try:
                step = factorize(A).solve(-g)
            except RuntimeError:
                raise ValueError("the mapping problem is singular: its frame or scale is not fixed") from None
            if not np.all(np.isfinite(step)):
                raise ValueError("the mapping problem is singular: its frame or scale is not fixed")
            x_new = x.copy()
            x_new[cols] += step
            e_new, _ = _lin(graph, x_new, None, huber, jacobian=False)
            cost_new = 0.5 * float(e_new @ e_new)
            if cost_new <= cost:
                improved = True
                break
            lam *= 10.0
        if not improved:
            return Solution(x, cost, it, True)
        decrease = cost - cost_new
        x = x_new
        small_step = float(np.max(np.abs(step))) < 1e-10
        cost_old, cost = cost, cost_new
        lam = max(lam / 10.0, 1e-9)
        e, J = _lin(graph, x, cols if free is not None else None, huber)
        if small_step or decrease <= tolerance * max(cost_old, 1e-300):
            return Solution(x, cost, it, True)
    return Solution(x, cost, it, False)


def _lin(graph: FactorGraph, x: F64, cols: NDArray[np.int64] | None, huber: float | None,
         jacobian: bool = True) -> tuple[F64, Any]:
    """Residuals (Huber-reweighted: ``√w e`` with ``w = min(1, k/|e|)``) and the Jacobian's ``cols``."""
    e, J0 = linearize(graph, x, jacobian)
    J: Any = J0
    if huber is not None:
        w = np.sqrt(np.minimum(1.0, huber / np.maximum(np.abs(e), 1e-300)))
        e = e * w
        if J is not None:
            J = sp.diags(w) @ J
    if J is not None and cols is not None:
        J = J.tocsc()[:, cols]
    return e, J


def marginal_covariances(graph: FactorGraph, x: F64) -> tuple[F64, float]:
    """``(cov (N, 2, 2), scale_var)``: reflector covariances (m²) and the scale variance at ``x``.

    The diagonal blocks of :func:`reflector_covariance`. ValueError when the information matrix is
    singular (the map's frame or scale is not fixed).
    """
    joint, scale_var = reflector_covariance(graph, x)
    n = graph.n_landmarks
    cov = np.zeros((n, 2, 2))
    for j in range(n):
        cov[j] = joint[2 * j:2 * j + 2, 2 * j:2 * j + 2]
    return cov, scale_var


def reflector_covariance(graph: FactorGraph, x: F64) -> tuple[F64, float]:
    """``(cov (2N, 2N), scale_var)``: the joint covariance (m²) of all reflector centres
    ``[x_0, y_0, x_1, ...]`` and the scale variance at ``x``.

    Solves ``(JᵀJ) C = E`` for the reflector and scale columns ``E`` only. The off-diagonal blocks
    matter: the reflectors of one map share the anchor's error and the trajectory's (a surveyed
    reflector 1 mm off shifts every reflector), so their errors are correlated and only the joint
    covariance gives a NEES whose chi-square band is exact. ValueError when the information matrix
    is singular (the map's frame or scale is not fixed).
    """
    _, J = linearize(graph, x)
    assert J is not None
    H = (J.T @ J).tocsc()
    sl = graph.landmark_slice()
    cols = np.r_[np.arange(sl.start, sl.stop), graph.scale_index]
    E = np.zeros((graph.n_vars, cols.size))
    E[cols, np.arange(cols.size)] = 1.0
    try:
        C = factorize(H).solve(E)
    except RuntimeError:
        raise ValueError("the mapping problem is singular: its frame or scale is not fixed") from None
    block = C[cols]
    if not np.all(np.isfinite(block)):
        raise ValueError("the mapping problem is singular: its frame or scale is not fixed")
    scale_var = float(block[-1, -1])
    if not math.isfinite(scale_var):
        raise ValueError("the mapping problem is singular: its frame or scale is not fixed")
    joint = block[:-1, :-1]
    return 0.5 * (joint + joint.T), scale_var
