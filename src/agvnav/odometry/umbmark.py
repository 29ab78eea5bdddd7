"""UMBmark calibration of a differential vehicle (Borenstein and Feng 1996; cited by seed 002).

The vehicle drives an ``L × L`` square by its own odometry, clockwise and
counter-clockwise, and the true stopping point is compared with the start
(the odometry believes it returned). Two dominant systematic errors explain
the return errors to first order:

* ``E_b`` (wheelbase error) makes every nominal 90° turn ``90° − α`` in truth;
* ``E_d = D_R/D_L`` curves every straight leg by an angle ``β``.

With REP-103 axes, the square started along +x and turning left (CCW) or right
(CW), a first-order analysis of the return errors ``ε = true − odometry`` gives
``x_cw = y_cw = −2L(α + β)``, ``x_ccw = 2L(β − α)``, ``y_ccw = −2L(β − α)``, so

``α = (x_cw + x_ccw)/(−4L) = (y_cw − y_ccw)/(−4L)``,
``β = (x_cw − x_ccw)/(−4L) = (y_cw + y_ccw)/(−4L)``

— Borenstein and Feng's formulas; both estimates are averaged here. Then
``R = (L/2)/sin(β/2)``, ``E_d = (R + b/2)/(R − b/2)``, ``E_b = 90°/(90° − α)``,
and the corrected geometry is ``b = E_b b_n``, ``D_L = 2/(E_d + 1) D_a``,
``D_R = 2/(1/E_d + 1) D_a``. The wheel-path radii use the corrected track
(the paper's nominal ``b`` differs by a factor ``E_b`` in ``E_d − 1``).
Because the formulas are linearised, ``iterations > 1`` repeats the test
with the corrected geometry and composes the corrections.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_positive
from agvnav.kinematics.base import twist_step
from agvnav.odometry.errors import DifferentialGeometry, NonSystematicErrors
from agvnav.odometry.increments import differential_increments
from agvnav.odometry.integrate import integrate_pose

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class UMBmarkResult:
    """Outcome of one bidirectional square test.

    alpha, beta : turn and leg-curvature errors (rad).
    e_d, e_b : estimated ``D_R/D_L`` and ``b_actual/b_nominal``.
    centroid_cw, centroid_ccw : mean return errors (m), shape (2,).
    e_max_syst : Borenstein's measure of systematic odometry error, the larger centroid distance (m).
    """

    alpha: float
    beta: float
    e_d: float
    e_b: float
    centroid_cw: FloatArray
    centroid_ccw: FloatArray

    @property
    def e_max_syst(self) -> float:
        """``max(|centroid_cw|, |centroid_ccw|)`` (m)."""
        return float(max(np.hypot(*self.centroid_cw), np.hypot(*self.centroid_ccw)))

    def corrected(self, nominal: DifferentialGeometry) -> DifferentialGeometry:
        """``nominal`` corrected by ``E_d`` and ``E_b``.

        The radius ratio is multiplied by ``E_d`` with the mean radius kept, the track by ``E_b``.
        For equal nominal radii this is Borenstein and Feng's ``D_R = 2/(1/E_d + 1) D_a``, ``D_L = 2/(E_d + 1) D_a``.
        """
        r_a = 0.5 * (nominal.radius_right + nominal.radius_left)
        r_r = nominal.radius_right * 2.0 / (1.0 / self.e_d + 1.0)
        r_l = nominal.radius_left * 2.0 / (self.e_d + 1.0)
        k = r_a / (0.5 * (r_r + r_l))
        return DifferentialGeometry(k * r_r, k * r_l, self.e_b * nominal.track)


def estimate_errors(errors_cw: ArrayLike, errors_ccw: ArrayLike, side: float, track: float) -> UMBmarkResult:
    """``α, β, E_d, E_b`` from return errors ``(n, 2)`` (true − odometry, m) of CW and CCW runs."""
    side = require_positive("side", side)
    track = require_positive("track", track)
    cw = np.atleast_2d(np.asarray(errors_cw, dtype=np.float64)).mean(axis=0)
    ccw = np.atleast_2d(np.asarray(errors_ccw, dtype=np.float64)).mean(axis=0)
    alpha = 0.5 * ((cw[0] + ccw[0]) + (cw[1] - ccw[1])) / (-4.0 * side)
    beta = 0.5 * ((cw[0] - ccw[0]) + (cw[1] + ccw[1])) / (-4.0 * side)
    e_b = (np.pi / 2) / (np.pi / 2 - alpha)
    b = e_b * track
    if beta == 0.0:
        e_d = 1.0
    else:
        radius = (side / 2.0) / np.sin(beta / 2.0)
        e_d = (radius + b / 2.0) / (radius - b / 2.0)
    return UMBmarkResult(float(alpha), float(beta), float(e_d), float(e_b), cw, ccw)


def square_run(true: DifferentialGeometry, believed: DifferentialGeometry, side: float, clockwise: bool,
               steps_per_leg: int = 20, nonsystematic: NonSystematicErrors | None = None,
               rng: np.random.Generator | None = None) -> FloatArray:
    """Return error ``(2,)`` (true − odometry, m) after driving the square by odometry with ``believed`` geometry.

    Each leg is ``steps_per_leg`` straight steps then a turn on the spot in
    ``steps_per_leg // 2`` steps; wheel rotations are those that make the
    believed odometry trace the square exactly.
    """
    rng = rng if rng is not None else np.random.default_rng(0)
    turn = -np.pi / 2 if clockwise else np.pi / 2
    straight = np.full(steps_per_leg, side / steps_per_leg)
    n_turn = max(steps_per_leg // 2, 1)
    d_arc = 0.5 * believed.track * turn / n_turn
    leg_r = np.concatenate([straight, np.full(n_turn, d_arc)]) / believed.radius_right
    leg_l = np.concatenate([straight, np.full(n_turn, -d_arc)]) / believed.radius_left
    phi_r, phi_l = np.tile(leg_r, 4), np.tile(leg_l, 4)
    odo = np.zeros(3)
    truth = np.zeros(3)
    for pr, pl in zip(phi_r, phi_l, strict=True):
        odo = integrate_pose(odo, *believed.increments(pr, pl), rule="arc")
        d_r, d_l = pr * true.radius_right, pl * true.radius_left
        if nonsystematic is not None:
            d_r, d_l = nonsystematic.perturb(d_r, rng), nonsystematic.perturb(d_l, rng)
        dd, dth = differential_increments(d_r, d_l, true.track)
        truth = twist_step(truth, dd, 0.0, dth, 1.0)
    return truth[:2] - odo[:2]


def umbmark(true: DifferentialGeometry, nominal: DifferentialGeometry, side: float = 4.0, runs: int = 5,
            nonsystematic: NonSystematicErrors | None = None, seed: int | np.random.Generator | None = 0,
            iterations: int = 1) -> tuple[UMBmarkResult, DifferentialGeometry]:
    """Run the bidirectional square test ``runs`` times each way; return the estimate and the corrected geometry.

    With ``iterations > 1`` the test is repeated with the corrected geometry and
    the residual corrections are composed (``E_d`` and ``E_b`` multiply).
    """
    if runs < 1 or iterations < 1:
        raise ValueError("runs and iterations must be >= 1")
    rng = np.random.default_rng(seed)
    believed = nominal
    e_d_total, e_b_total = 1.0, 1.0
    result = None
    for _ in range(iterations):
        cw = [square_run(true, believed, side, True, nonsystematic=nonsystematic, rng=rng) for _ in range(runs)]
        ccw = [square_run(true, believed, side, False, nonsystematic=nonsystematic, rng=rng) for _ in range(runs)]
        step = estimate_errors(cw, ccw, side, believed.track)
        believed = step.corrected(believed)
        e_d_total *= step.e_d
        e_b_total *= step.e_b
        result = step if result is None else result
    assert result is not None
    first = UMBmarkResult(result.alpha, result.beta, e_d_total, e_b_total, result.centroid_cw, result.centroid_ccw)
    return first, believed
