"""The EKF core: the pose state, its prediction from odometry and its update by any measurement model.

State ``x = [x, y, psi]`` of base_link in ``map`` (m, m, rad), covariance ``P`` (3x3), and,
for the Schmidt-Kalman consider filter of :mod:`agvnav.positioning.ekf`, the factored
cross-covariance with the reflectors' survey errors ``P_xp = M C^T`` and with the odometry
calibration errors ``P_xc`` (:class:`ConsiderState`). The symbols are filterpy's:

* :meth:`EkfCore.predict` -- ``x <- f(x, u)``, ``P <- F P F^T + Q`` [seed002 eq14] with the
  SE(2) exponential of the body-twist increment [seed002 eq25] and seed 002's noise model
  ``Q`` [seed002 eq17] (one kernel call, :func:`~agvnav.positioning._fast.move_state`);
* :meth:`EkfCore.update` -- for a :class:`~agvnav.positioning.measurement.MeasurementModel`:
  ``y = residual(z, h(x))``, ``H``, ``R``, and for a model that sees a consider parameter
  ``v = P_xp H_p^T``, ``b = H_p P_pp H_p^T``; ``S = H P H^T + 2 H v + b + R``,
  ``K = (P H^T + v) / S``, ``x <- x + K y``, ``P <- A P A^T - A v K^T - K v^T A^T + (b + R) K K^T``
  with ``A = I - K H`` (:func:`~agvnav.positioning._fast.schmidt_update`; the Joseph form when
  ``v = b = 0``), ``P_xp <- A P_xp - K H_p P_pp``, ``P_xc <- A P_xc``.

Every update returns an :class:`EkfStep`: prior and posterior, innovation, its variance,
gain, whether it was accepted and why not. The estimators keep the latest one
(``last_step``) and hand each to a recorder when one is attached
(:meth:`~agvnav.positioning.estimator.StreamingEstimator.record_steps`).

Matrices are flat row-major tuples of 9 floats (``P[3 * i + j]``) in the state, as the
kernels take them; :class:`EkfStep` gives arrays.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvnav.odometry import OdometryNoise, SteeredOdometryNoise
from agvnav.positioning import _fast
from agvnav.positioning.measurement import MeasurementModel

__all__ = [
    "CONSIDER_MAX_ENTRY", "CONSIDER_MIN_DET", "ConsiderState", "EkfCore", "EkfStep", "Linearisation", "noise_constants",
]

#: ``M`` of the factored ``P_xp = M C^T`` is folded into ``C`` below this ``|det M|`` ...
CONSIDER_MIN_DET = 0.05
#: ... or above this largest ``|M_ik|`` (keeps ``M^-1`` well conditioned, :mod:`agvnav.positioning.ekf`).
CONSIDER_MAX_ENTRY = 20.0

IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
_NO_X = (0.0,) * 6

Flat = tuple[float, ...]


@dataclass(frozen=True, eq=False)
class EkfStep:
    """One measurement's update, as the filter saw it (arrays read-only; compared by identity).

    ``accepted`` False leaves ``x_posterior``/``P_posterior`` equal to the prior; ``reason`` says
    why (``"accepted"``, ``"outside_gate"``, ``"ambiguous"``, ``"no_candidate"``, ``"not_tracking"``).
    ``K`` is NaN when no update was made; ``S`` and ``innovation`` NaN when no model was in the gate.
    """

    t: float  #: time (s) of the measurement
    measurement: str  #: the model's name (``"bearing"``, ``"wall_range"``)
    index: int  #: the map row it was associated with (reflector, wall), -1 for none
    z: float  #: the reading (rad or m)
    x_prior: NDArray[np.float64]  #: (3,) pose before (m, m, rad)
    P_prior: NDArray[np.float64]  #: (3, 3) covariance before
    innovation: float  #: y = residual(z, h(x_prior))
    S: float  #: innovation variance
    K: NDArray[np.float64]  #: (3,) gain
    x_posterior: NDArray[np.float64]  #: (3,) pose after
    P_posterior: NDArray[np.float64]  #: (3, 3) covariance after
    accepted: bool
    reason: str

    @property
    def nis(self) -> float:
        """Normalised innovation squared ``y^2 / S``."""
        return self.innovation * self.innovation / self.S if self.S > 0.0 else math.inf


def _ro(values: Sequence[float], shape: tuple[int, ...]) -> NDArray[np.float64]:
    a = np.array(values, dtype=np.float64).reshape(shape)
    a.flags.writeable = False
    return a


#: The raw form of a step kept on the hot path (no arrays made until asked): the fields of
#: :class:`EkfStep` in order, matrices as flat tuples.
RawStep = tuple[float, str, int, float, Flat, Flat, float, float, Sequence[float], Flat, Flat, bool, str]


def make_step(raw: RawStep) -> EkfStep:
    """:class:`EkfStep` of a raw tuple (:data:`RawStep`)."""
    t, name, j, z, x0, P0, y, S, K, x1, P1, accepted, reason = raw
    return EkfStep(float(t), name, int(j), float(z), _ro(x0, (3,)), _ro(P0, (3, 3)), float(y), float(S),
                   _ro(K, (3,)), _ro(x1, (3,)), _ro(P1, (3, 3)), bool(accepted), reason)


@dataclass(frozen=True)
class Linearisation:
    """A scalar measurement linearised at the prior: residual ``y``, row ``H`` (3,), noise ``R``,
    and the consider block it sees (``index`` >= 0, ``H_p = hp`` (2,)) or none (``index = -1``)."""

    y: float
    H: tuple[float, float, float]
    R: float
    index: int = -1
    hp: tuple[float, float] = (0.0, 0.0)


class ConsiderState:
    """The consider parameters' cross-covariances: survey errors ``P_xp = M C^T``, calibration ``P_xc``.

    ``svar (N,)`` the survey variances ``P_pp,j`` (m² per axis), ``calibrated`` whether the
    odometry calibration errors are carried (``P_xc``, 3x2 row-major). See
    :mod:`agvnav.positioning.ekf` for the factoring and the fold of ``M``.
    """

    def __init__(self, svar: Sequence[float], calibrated: bool) -> None:
        self.svar: list[float] = [float(v) for v in svar]
        self.calibrated = bool(calibrated)
        self.M: Flat = IDENTITY
        self.C = np.zeros((len(self.svar), 6))
        self.Pxc: Flat = _NO_X

    def cross_covariance(self) -> NDArray[np.float64]:
        """``(3, 2N)`` ``P_xp`` (m², m rad); columns ``2j, 2j+1`` reflector j's x and y error."""
        return np.asarray(self.M).reshape(3, 3) @ self.C.reshape(-1, 3).T

    def fold(self, M: Flat) -> None:
        """``C <- C M^T`` (``P_xp = M C^T`` unchanged) and ``M <- I``: O(N), rare."""
        C3 = self.C.reshape(-1, 3)
        C3[...] = C3 @ np.asarray(M).reshape(3, 3).T
        self.M = IDENTITY

    def fold_into_row(self, M: Flat, K: Sequence[float], j: int, h0: float, h1: float) -> None:
        """Fold ``M``, then add reflector ``j``'s new ``P_xp`` columns ``K (h0, h1) svar_j`` (``h = -H_p``)."""
        self.fold(M)
        svar = self.svar[j]
        u0, u1, u2 = K
        row = self.C[j].tolist()
        ax, ay = h0 * svar, h1 * svar
        self.C[j] = (row[0] + u0 * ax, row[1] + u1 * ax, row[2] + u2 * ax, row[3] + u0 * ay, row[4] + u1 * ay,
                     row[5] + u2 * ay)

    def keep(self, M: Flat, K: Sequence[float], fold: bool, j: int, h0: float, h1: float) -> None:
        """Keep the ``M`` a compiled bearing update returned, folding it (and writing row ``j``) when asked."""
        if fold:
            self.fold_into_row(M, K, j, h0, h1)
        else:
            self.M = M

    def cross(self, j: int, hp: tuple[float, float]) -> tuple[tuple[float, float, float], float]:
        """``v = P_xp,j H_p^T`` (3,) and ``b = H_p P_pp,j H_p^T`` of a reading that sees reflector ``j``."""
        C = self.C
        v = _fast.consider_cross(self.M, (C[j, 0], C[j, 1], C[j, 2]), (C[j, 3], C[j, 4], C[j, 5]), hp[0], hp[1])
        return v, self.svar[j] * (hp[0] * hp[0] + hp[1] * hp[1])

    def after_update(self, K: Sequence[float], H: Sequence[float], j: int, hp: tuple[float, float]) -> None:
        """``P_xc <- A P_xc``, ``P_xp <- A P_xp - K H_p P_pp,j`` (``A = I - K H``; row ``j`` only when ``j >= 0``)."""
        if self.calibrated:
            self.Pxc = _fast.calibration_update(self.Pxc, K, H)
        M = _fast.left_update(self.M, K, H)
        det = _fast.det3(M)
        if not (abs(det) >= CONSIDER_MIN_DET and max(map(abs, M)) <= CONSIDER_MAX_ENTRY):
            if j >= 0:
                self.fold_into_row(M, K, j, -hp[0], -hp[1])
            else:
                self.fold(M)
            return
        self.M = M
        if j >= 0:
            s0, s1, s2 = _fast.solve3(M, K, det)  # M^-1 K
            ax, ay = -hp[0] * self.svar[j], -hp[1] * self.svar[j]
            C = self.C
            C[j, 0], C[j, 1], C[j, 2] = C[j, 0] + s0 * ax, C[j, 1] + s1 * ax, C[j, 2] + s2 * ax
            C[j, 3], C[j, 4], C[j, 5] = C[j, 3] + s0 * ay, C[j, 4] + s1 * ay, C[j, 5] + s2 * ay


def noise_constants(
    noise: OdometryNoise, k_lateral: float, consider: bool
) -> tuple[NDArray[np.float64], tuple[float, float]]:
    """The noise model for :func:`~agvnav.positioning._fast.move_state`, and the calibration variances.

    A :class:`~agvnav.odometry.SteeredOdometryNoise` gives a consider filter the exact
    steered-wheel model (:func:`~agvnav.positioning._fast.steered_noise`) and its
    calibration errors as consider parameters, ``(radius_scale_std², steering_offset_std²)``
    (zeros otherwise); the other methods take its Crowley bound (the inherited ``k_d,
    k_dtheta, k_theta``). ``k_lateral`` (m²/m) the holonomic term.
    """
    steered: tuple[bool, float, float, float, float] | None = None
    cvar = (0.0, 0.0)
    if isinstance(noise, SteeredOdometryNoise) and consider:
        steered = (noise.front, noise.wheelbase_m, noise.slip_k, noise.steering_std**2 * noise.step_m,
                   noise.min_roll_per_rad)
        cvar = (noise.radius_scale_std**2, noise.steering_offset_std**2)
    consts = _fast.move_constants((noise.k_d, noise.k_dtheta, noise.k_theta, k_lateral), steered, consider,
                                  cvar != (0.0, 0.0), cvar)
    return consts, cvar


class EkfCore:
    """The pose filter: odometric pose, ``x``, ``P`` and the optional :class:`ConsiderState`.

    ``move_consts`` are :func:`~agvnav.positioning._fast.move_constants` (the noise model,
    fixed for the run). The estimators hold one core and read ``x``, ``P`` from it.
    """

    def __init__(self, move_consts: NDArray[np.float64], consider: ConsiderState | None = None) -> None:
        self.move_consts = move_consts
        self.consider = consider
        self.odom: Flat = (0.0, 0.0, 0.0)
        self.x: Flat = (math.nan,) * 3
        self.P: Flat = (math.nan,) * 9

    def has_pose(self) -> bool:
        """Whether the pose is set (finite)."""
        x, y, psi = self.x
        return math.isfinite(x) and math.isfinite(y) and math.isfinite(psi)

    def predict(self, dd: float, dth: float, dl: float) -> None:
        """``x <- f(x, u)``, ``P <- F P F^T + Q`` for the body-twist increment ``u = (dd, dth, dl)`` (m, rad, m).

        The SE(2) exponential [seed002 eq25], ``P' = F P F^T + Q`` [seed002 eq14] with seed 002's
        noise model [seed002 eq17]. The odometric pose moves too; a consider state moves
        ``M <- F M`` and ``P_xc``.
        One kernel call (:func:`~agvnav.positioning._fast.move_state`).
        """
        c = self.consider
        M, X = (IDENTITY, _NO_X) if c is None else (c.M, c.Pxc)
        self.odom, self.x, self.P, M, X = _fast.MOVE_STATE.bound()(
            self.odom, self.x, self.P, M, X, dd, dth, dl, self.move_consts
        )
        if c is not None:
            c.M, c.Pxc = M, X

    def linearise(self, model: MeasurementModel, z: float) -> Linearisation:
        """``y``, ``H``, ``R`` (and ``H_p`` of a consider block) of ``model`` at the current pose."""
        x = self.x
        y = model.residual(z, model.h(x))
        H = model.jacobian(x)
        j = model.consider_index if self.consider is not None else -1
        hp = model.consider_jacobian(x) if j >= 0 else (0.0, 0.0)
        return Linearisation(y, H, model.noise(x), j, hp)

    def innovation_variance(self, lin: Linearisation) -> tuple[float, tuple[float, float, float], float]:
        """``S = H P H^T + 2 H v + b + R`` with the consider ``v`` (3,) and ``b``."""
        v, b = (0.0, 0.0, 0.0), 0.0
        if lin.index >= 0 and self.consider is not None:
            v, b = self.consider.cross(lin.index, lin.hp)
        H = lin.H
        S = _fast.quadratic_form(H, self.P) + 2.0 * (H[0] * v[0] + H[1] * v[1] + H[2] * v[2]) + b + lin.R
        return S, v, b

    def update(
        self, model: MeasurementModel, z: float, t: float = math.nan, gated: bool = True
    ) -> RawStep:
        """One reading ``z`` of ``model``: gate ``y^2 / S < model.gate`` (unless ``gated`` is False), then update.

        Returns the raw step (:func:`make_step` gives the :class:`EkfStep`).
        """
        lin = self.linearise(model, z)
        index = model.index
        if gated:
            S, _, _ = self.innovation_variance(lin)
            if not lin.y * lin.y / S < model.gate:
                return (t, model.name, index, z, self.x, self.P, lin.y, S, (math.nan,) * 3, self.x, self.P, False,
                        "outside_gate")
        return self.apply(lin, t, model.name, index, z)

    def apply(self, lin: Linearisation, t: float = math.nan, name: str = "", index: int = -1,
              z: float = math.nan) -> RawStep:
        """The update of one linearised reading (module docstring); returns the raw step."""
        x0, P0 = self.x, self.P
        v, b = (0.0, 0.0, 0.0), 0.0
        c = self.consider
        if lin.index >= 0 and c is not None:
            v, b = c.cross(lin.index, lin.hp)
        self.x, self.P, K, S = _fast.schmidt_update(x0, P0, lin.y, lin.H, lin.R, v, b)
        if c is not None:
            c.after_update(K, lin.H, lin.index, lin.hp)
        return (t, name, index, z, x0, P0, lin.y, S, K, self.x, self.P, True, "accepted")
