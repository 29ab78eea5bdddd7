"""Stateful guidance controllers with one narrow interface (nav2-like).

Every controller is built from a :class:`~agvnav.guidance.paths.Path` (the
planned path of its tracked point) and the wheelbase L, and offers:

* ``command(pose_o, gamma, v) -> gamma_dot`` (rad/s): ``pose_o`` = ``[x, y, psi]``
  of point O (base_link of the tricycle) in ``map``, ``gamma`` the steering
  angle (rad), ``v`` the signed speed of C (m/s);
* ``set_path(path)`` and ``reset()``;
* read-only ``last_errors``: :class:`~agvnav.guidance.errors.TrackingErrors`
  of the last command (eps_c, eps_o, xi, xi_r, s, ...), for recording.

The projection of the tracked point is searched within ``window`` metres of
the previous one, so a self-crossing path does not make the controller jump.
Create controllers by name with :func:`make_controller`. Every controller
accepts ``convergence_distance`` (m): the seed laws place their poles and the
baselines pick their look-ahead/gain so that the linearised lateral error of
the tracked point after an offset stays within 2 % beyond that distance
(:func:`loop_convergence_distance`), so they can be compared on equal terms.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Protocol, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_positive
from agvnav.geometry.angles import wrap_angle_scalar
from agvnav.guidance.baselines import (
    lookahead_for_distance,
    pure_pursuit_steering,
    servo_rate,
    stanley_gain_for_distance,
    stanley_steering,
)
from agvnav.guidance.errors import TrackingErrors, tracking_errors_scalar
from agvnav.guidance.gains import (
    characteristic_coefficients,
    check_routh_hurwitz,
    check_simple_stability,
    envelope_distance,
    general_gains_from_coefficients,
    general_gains_on_arc,
    hidden_real_pole,
    modal_response,
    seed_poles_for_distance,
    simple_gains,
)
from agvnav.guidance.laws import GENERAL_FORMS, SIMPLE_FORMS, general_law, simple_law
from agvnav.guidance.paths import LineSegment, Path

__all__ = [
    "CONTROLLERS",
    "DEFAULT_CONVERGENCE_DISTANCE_M",
    "GuidanceController",
    "PurePursuitController",
    "SeedGeneralController",
    "SeedSimpleController",
    "StanleyController",
    "linearised_loop",
    "linearised_poles_per_metre",
    "loop_convergence_distance",
    "make_controller",
    "tune_for_convergence",
]

DEFAULT_CONVERGENCE_DISTANCE_M = 2.0
"""Default distance (m) within which every controller brings a small error to 2 %."""


class GuidanceController(Protocol):
    """The narrow controller interface the simulator relies on."""

    @property
    def path(self) -> Path: ...

    @property
    def last_errors(self) -> TrackingErrors | None: ...

    def set_path(self, path: Path) -> None: ...

    def reset(self) -> None: ...

    def command(self, pose_o: ArrayLike, gamma: float, v: float) -> float: ...


class _PathFollower:
    """Shared state: path, tracked point, projection hint and the last errors."""

    point: str = "C"

    def __init__(self, path: Path, wheelbase: float, point: str, window: float, feedforward: bool = True):
        if not isinstance(path, Path):
            raise ValueError(f"path must be an agvnav.guidance.Path, got {type(path).__name__}")
        if point not in ("O", "C"):
            raise ValueError(f"point must be 'O' or 'C', got {point!r}")
        self.wheelbase = require_positive("wheelbase", wheelbase)
        self.window = require_positive("window", window)
        self.point = point
        self.feedforward = bool(feedforward)
        self._path = path
        self._s: float | None = None
        self._last: TrackingErrors | None = None

    @property
    def path(self) -> Path:
        """The planned path of the tracked point."""
        return self._path

    @property
    def last_errors(self) -> TrackingErrors | None:
        """Errors computed by the last :meth:`command` (None after a reset)."""
        return self._last

    def set_path(self, path: Path) -> None:
        """Follow a new path from its closest point (resets the controller)."""
        if not isinstance(path, Path):
            raise ValueError(f"path must be an agvnav.guidance.Path, got {type(path).__name__}")
        self._path = path
        self.reset()

    def reset(self) -> None:
        """Forget the projection hint and the last errors."""
        self._s = None
        self._last = None

    def _inputs(self, pose_o: ArrayLike, gamma: float, v: float) -> tuple[tuple[float, float, float], float, float]:
        if isinstance(pose_o, tuple) and len(pose_o) == 3 and all(type(p) is float for p in pose_o):
            pose = cast("tuple[float, float, float]", pose_o)  # plain floats (the followers' call): no array trip
            if not all(math.isfinite(p) for p in pose):
                raise ValueError("pose_o contains NaN or inf")
            return pose, *self._scalars(gamma, v)
        try:
            arr = pose_o if isinstance(pose_o, np.ndarray) else np.asarray(pose_o, dtype=np.float64)
            if arr.shape != (3,):
                raise ValueError(f"pose_o must have shape (3,) = [x_O, y_O, psi], got {arr.shape}")
            pose = (float(arr[0]), float(arr[1]), float(arr[2]))
        except (TypeError, ValueError) as exc:
            if "shape" in str(exc):
                raise
            raise ValueError(f"pose_o must be numeric: {exc}") from None
        if not all(math.isfinite(p) for p in pose):
            raise ValueError("pose_o contains NaN or inf")
        return pose, *self._scalars(gamma, v)

    @staticmethod
    def _scalars(gamma: float, v: float) -> tuple[float, float]:
        """``(gamma, v)`` as checked floats (rad, m/s)."""
        g, vv = float(gamma), float(v)
        if not math.isfinite(g) or abs(g) > math.pi / 2 + 1e-9:
            raise ValueError(f"gamma must be finite and within [-pi/2, pi/2] rad (seed 000 §3.1), got {gamma!r}")
        if not math.isfinite(vv):
            raise ValueError(f"v must be finite, got {v!r}")
        return g, vv

    def _errors(self, pose: tuple[float, float, float], gamma: float) -> TrackingErrors:
        window = None if self._s is None else self.window
        L, ff = self.wheelbase, self.feedforward
        e = tracking_errors_scalar(self._path, pose, gamma, L, self.point, self._s, window, ff)
        if not e.valid:
            raise ValueError(
                f"path radius at s = {float(e.s):.3f} m is below the wheelbase: point C cannot follow it"
            )
        self._s = float(e.s)
        self._last = e
        return e


def _design_choice(
    poles_per_m: ArrayLike | None,
    convergence_distance: float | None,
    gains: Any,
    wheelbase: float,
    law: str,
    point: str,
    direction: int = 1,
) -> NDArray[np.complex128] | None:
    """Poles per metre from the user's choice (None for fixed gains)."""
    given = [x is not None for x in (poles_per_m, convergence_distance, gains)]
    if sum(given) > 1:
        raise ValueError("give only one of poles_per_m, convergence_distance or gains")
    if gains is not None:
        return None
    if poles_per_m is not None:
        return np.asarray(poles_per_m, dtype=np.complex128)
    d = DEFAULT_CONVERGENCE_DISTANCE_M if convergence_distance is None else convergence_distance
    return seed_poles_for_distance(d, wheelbase, law, point, direction=direction)


def _gain_or_tuned(
    gain_name: str,
    gain: float | None,
    convergence_distance: float | None,
    law: str,
    wheelbase: float,
    v_nominal: float,
    **params: Any,
) -> float:
    """A servo law's gain (lookahead m, or gain 1/m): as given, else tuned.

    Tuned by :func:`tune_for_convergence` for ``convergence_distance`` (m,
    default DEFAULT_CONVERGENCE_DISTANCE_M) at ``v_nominal`` (m/s); giving
    both raises ValueError.
    """
    if gain is not None and convergence_distance is not None:
        raise ValueError(f"give {gain_name} or convergence_distance, not both")
    if gain is None:
        d = DEFAULT_CONVERGENCE_DISTANCE_M if convergence_distance is None else convergence_distance
        gain = tune_for_convergence(law, d, wheelbase, v_nominal, **params)
    return require_positive(gain_name, gain)


def _has_real_pole_at(poles: NDArray[np.complex128], pole: float) -> bool:
    return bool(np.any(np.abs(poles - pole) <= 1e-9 * abs(pole)))


class SeedGeneralController(_PathFollower):
    """General three-parameter law of seed 000 with curvature feed-forward.

    [seed000 eq11] [seed000 eq12] [seed000 eq13].

    Gains from closed-loop poles per metre (``poles_per_m``, or
    ``convergence_distance``, designed for each direction of travel:
    attributes ``poles_per_m`` and ``poles_per_m_reverse``; a, b, c are
    recomputed from |v| at every command so the convergence distance does not
    change with speed and b follows the sign of v), or fixed ``gains=(a, |b|, c)`` checked by
    Routh-Hurwitz ([seed000 eq18] [seed000 eq19]) up to ``v_max`` (m/s) in both directions.
    ``point`` "O" (manoeuvres, default form [seed000 eq11]) or "C" (cruising, default form
    [seed000 eq13]). At v = 0 the command is 0.
    With ``curvature_compensation`` (and designed poles) the gains on an arc
    come from :func:`~agvnav.guidance.gains.general_gains_on_arc`, so the
    linearised poles per metre are the designed ones on arcs too; without it
    the line gains are used everywhere (on tight arcs, where gamma_ss is large,
    that loop can lose its damping or even its stability).

    For point C the law answers a lateral offset of C with an immediate
    steering rate ``-a eps_c`` ([seed000 eq17] started from eps_c'' != 0), and with a
    real pole away from ``-1/L`` eps_c swings far past zero. The design from
    ``convergence_distance`` therefore puts the forward real pole at
    :func:`~agvnav.guidance.gains.hidden_real_pole`, where [seed000 eq13] reduces to
    the simple law and the real mode does not show in eps_c (see
    :mod:`agvnav.guidance.gains`). Whenever the forward poles on C have their
    real pole there (designed, or given at ``-1/L`` in ``poles_per_m``;
    attribute ``hides_real_pole``), the arc gains move it to the arc's
    ``-cos(gamma_ss)/L`` so it stays hidden on arcs.
    """

    def __init__(
        self,
        path: Path,
        wheelbase: float,
        *,
        poles_per_m: ArrayLike | None = None,
        convergence_distance: float | None = None,
        gains: tuple[float, float, float] | None = None,
        v_max: float | None = None,
        point: str = "C",
        form: int | None = None,
        feedforward: bool = True,
        curvature_compensation: bool = True,
        exact_rotation: bool = True,
        window: float = 1.0,
    ):
        super().__init__(path, wheelbase, point, window, feedforward)
        self.curvature_compensation = bool(curvature_compensation)
        self.exact_rotation = bool(exact_rotation)
        self._arc_gains: dict[tuple[float, float], tuple[float, float, float]] = {}
        self.form = (11 if point == "O" else 13) if form is None else form
        if self.form not in GENERAL_FORMS:
            raise ValueError(f"form must be one of {GENERAL_FORMS} (seed 000 eqs 11-13), got {form!r}")
        choice = (poles_per_m, convergence_distance, gains, self.wheelbase, "general", point)
        self.poles_per_m = _design_choice(*choice)  # forward (v > 0)
        self.poles_per_m_reverse = _design_choice(*choice, direction=-1)  # differs from forward for C only
        self.v_max: float | None = None
        self.fixed_gains: tuple[float, float, float] | None = None
        self.hides_real_pole = False
        if self.poles_per_m is not None:
            assert self.poles_per_m_reverse is not None
            self._coeffs = {  # validates the poles
                1.0: characteristic_coefficients(self.poles_per_m, 3),
                -1.0: characteristic_coefficients(self.poles_per_m_reverse, 3),
            }
            for sign, coeffs in self._coeffs.items():
                g = general_gains_from_coefficients(coeffs, sign, self.wheelbase)
                check_routh_hurwitz(g.a, g.b, g.c, sign)
            hidden = hidden_real_pole(self.wheelbase)
            self.hides_real_pole = point == "C" and _has_real_pole_at(self.poles_per_m, hidden)
        else:
            assert gains is not None
            a, b, c = (float(x) for x in gains)
            self.v_max = require_positive("v_max (needed with fixed gains)", v_max if v_max is not None else 0.0)
            for v in (self.v_max, -self.v_max):
                check_routh_hurwitz(a, math.copysign(abs(b), v), c, v)
            self.fixed_gains = (a, abs(b), c)

    def gains_at(self, v: float, kappa_ref: float = 0.0) -> tuple[float, float, float]:
        """(a, b, c) used at speed ``v`` (m/s) on curvature ``kappa_ref`` = d kappa (1/m); b ~ sign of v."""
        if self.fixed_gains is None:
            sign = math.copysign(1.0, v)
            if kappa_ref == 0.0 or not self.curvature_compensation:
                g = general_gains_from_coefficients(self._coeffs[sign], v, self.wheelbase)
                return g.a, g.b, g.c
            key = (kappa_ref, sign)
            if key not in self._arc_gains:  # per unit |v|: the gains scale with |v|
                g = general_gains_on_arc(self._arc_poles(sign, kappa_ref), sign, self.wheelbase, kappa_ref, self.point)
                self._arc_gains[key] = (g.a, g.b, g.c)
            a, b, c = self._arc_gains[key]
            return a * abs(v), b * abs(v), c * abs(v)
        a, b, c = self.fixed_gains
        if self.v_max is not None and abs(v) > self.v_max:
            raise ValueError(f"|v| = {abs(v):g} m/s exceeds v_max = {self.v_max:g} m/s checked for these gains")
        return a, math.copysign(b, v), c

    def _arc_poles(self, sign: float, kappa_ref: float) -> NDArray[np.complex128]:
        """Designed poles per metre for the arc; the hidden real pole follows the curvature (class doc)."""
        poles = self.poles_per_m if sign > 0 else self.poles_per_m_reverse
        assert poles is not None
        if sign > 0 and self.hides_real_pole:
            line = hidden_real_pole(self.wheelbase)
            j = int(np.argmin(np.abs(poles - line)))
            poles = poles.copy()
            poles[j] = hidden_real_pole(self.wheelbase, kappa_ref)
        return poles

    def command(self, pose_o: ArrayLike, gamma: float, v: float) -> float:
        """Steering rate (rad/s) from [seed000 eq11], [seed000 eq12] or [seed000 eq13] (see class doc)."""
        pose, gamma, v = self._inputs(pose_o, gamma, v)
        e = self._errors(pose, gamma)
        if v == 0.0:
            return 0.0
        kappa_ref = float(e.direction * e.kappa) if self.feedforward else 0.0
        a, b, c = self.gains_at(v, kappa_ref)
        dgamma = gamma - e.gamma_ss
        exact = {"v": v, "gamma_ss": e.gamma_ss} if self.exact_rotation else {}
        return float(
            general_law(self.form, e.eps_c, e.eps_o, e.xi, e.xi_r, dgamma, a, b, c, self.wheelbase, **exact)
        )


class SeedSimpleController(_PathFollower):
    """Simple two-parameter law of seed 000, point C, v > 0 only: [seed000 eq20] [seed000 eq21] [seed000 eq22].

    Gains from two poles per metre (``poles_per_m`` or ``convergence_distance``)
    or fixed ``gains=(a, b)``. With ``curvature_compensation`` the gain a is
    lowered by ``kappa^2 v`` on arcs, which cancels the curvature term of the
    linearised arc dynamics (``eps_c'' + b eps_c' + (a + kappa^2 v) v eps_c = 0``)
    so the designed poles hold on arcs as on lines. v < 0 raises ValueError
    (the law is unstable there, seed 000 §3.3); at v = 0 the command is 0.
    """

    def __init__(
        self,
        path: Path,
        wheelbase: float,
        *,
        poles_per_m: ArrayLike | None = None,
        convergence_distance: float | None = None,
        gains: tuple[float, float] | None = None,
        form: int = 20,
        feedforward: bool = True,
        curvature_compensation: bool = True,
        window: float = 1.0,
    ):
        super().__init__(path, wheelbase, "C", window, feedforward)
        if form not in SIMPLE_FORMS:
            raise ValueError(f"form must be one of {SIMPLE_FORMS} (seed 000 eqs 20-22), got {form!r}")
        self.form = form
        self.curvature_compensation = bool(curvature_compensation)
        self.poles_per_m = _design_choice(poles_per_m, convergence_distance, gains, self.wheelbase, "simple", "C")
        self.fixed_gains: tuple[float, float] | None = None
        if self.poles_per_m is not None:
            _, self._f1, self._f2 = characteristic_coefficients(self.poles_per_m, 2)
            g = simple_gains(self.poles_per_m, 1.0)
            check_simple_stability(g.a, g.b, 1.0)
        else:
            assert gains is not None
            a, b = (float(x) for x in gains)
            check_simple_stability(a, b, 1.0)
            self.fixed_gains = (a, b)

    def command(self, pose_o: ArrayLike, gamma: float, v: float) -> float:
        """Steering rate (rad/s) from [seed000 eq20], [seed000 eq21] or [seed000 eq22] (see class doc)."""
        pose, gamma, v = self._inputs(pose_o, gamma, v)
        e = self._errors(pose, gamma)
        if v == 0.0:
            return 0.0
        if v < 0.0:
            check_simple_stability(1.0, 1.0, v)
        if self.fixed_gains is None:
            a, b = v * self._f2, v * self._f1  # simple_gains, without re-validating the poles
        else:
            a, b = self.fixed_gains
        if self.curvature_compensation and self.feedforward:
            a -= e.kappa**2 * v
        return float(
            simple_law(self.form, e.eps_c, e.eps_o, e.xi, e.xi_r, gamma, e.gamma_ss, a, b, v, self.wheelbase)
        )


class PurePursuitController(_PathFollower):
    """Pure pursuit on point O (default) or C, both directions, through a first-order servo.

    ``lookahead`` (m) or ``convergence_distance`` (m, tuned at ``v_nominal``
    with the servo by :func:`tune_for_convergence`); ``servo_tau`` (s).
    """

    def __init__(
        self,
        path: Path,
        wheelbase: float,
        *,
        lookahead: float | None = None,
        convergence_distance: float | None = None,
        v_nominal: float = 0.2,
        servo_tau: float = 0.1,
        point: str = "O",
        window: float = 1.0,
    ):
        super().__init__(path, wheelbase, point, window)
        self.servo_tau = require_positive("servo_tau", servo_tau)
        tuning = ("pure_pursuit", wheelbase, v_nominal)
        self.lookahead = _gain_or_tuned(
            "lookahead", lookahead, convergence_distance, *tuning, servo_tau=servo_tau, point=point
        )

    def command(self, pose_o: ArrayLike, gamma: float, v: float) -> float:
        """Steering rate (rad/s): servo towards the pure-pursuit steering angle."""
        pose, gamma, v = self._inputs(pose_o, gamma, v)
        e = self._errors(pose, gamma)
        d = int(e.direction)
        x, y, psi = pose
        if self.point == "C":
            x, y = x + self.wheelbase * math.cos(psi), y + self.wheelbase * math.sin(psi)
        gx, gy = self._path.extrapolate_point(float(e.s) + self.lookahead)
        psi_motion = psi + (math.pi if d < 0 else 0.0)
        beta = wrap_angle_scalar(math.atan2(gy - y, gx - x) - psi_motion)
        target = pure_pursuit_steering(beta, self.lookahead, self.wheelbase, self.point, d)
        return float(servo_rate(target, gamma, self.servo_tau))


class StanleyController(_PathFollower):
    """Stanley law on point C (the steered wheel), v > 0, through a first-order servo.

    ``gain_per_m`` (1/m) or ``convergence_distance`` (m, tuned at ``v_nominal``
    with the servo); ``servo_tau`` (s). v < 0 raises ValueError: with the
    steered wheel trailing, Stanley's front-axle law is not defined (use
    pure pursuit or the seed's general law on O for reverse manoeuvres).
    """

    def __init__(
        self,
        path: Path,
        wheelbase: float,
        *,
        gain_per_m: float | None = None,
        convergence_distance: float | None = None,
        v_nominal: float = 0.2,
        servo_tau: float = 0.1,
        window: float = 1.0,
    ):
        super().__init__(path, wheelbase, "C", window)
        self.servo_tau = require_positive("servo_tau", servo_tau)
        tuning = ("stanley", wheelbase, v_nominal)
        self.gain_per_m = _gain_or_tuned("gain_per_m", gain_per_m, convergence_distance, *tuning, servo_tau=servo_tau)

    def command(self, pose_o: ArrayLike, gamma: float, v: float) -> float:
        """Steering rate (rad/s): servo towards the Stanley steering angle."""
        pose, gamma, v = self._inputs(pose_o, gamma, v)
        e = self._errors(pose, gamma)
        if v < 0.0 or int(e.direction) < 0:
            raise ValueError("stanley: defined for forward driving only (v > 0, steered wheel leading)")
        heading_error = e.xi - e.gamma_ss  # psi - tangent at C
        target = stanley_steering(heading_error, e.eps_c, self.gain_per_m)
        return float(servo_rate(target, gamma, self.servo_tau))


CONTROLLERS: dict[str, Callable[..., GuidanceController]] = {
    "seed_general": SeedGeneralController,
    "seed_simple": SeedSimpleController,
    "pure_pursuit": PurePursuitController,
    "stanley": StanleyController,
}


def make_controller(name: str, path: Path, wheelbase: float, **params: Any) -> GuidanceController:
    """Create a controller by name ("seed_general", "seed_simple", "pure_pursuit", "stanley").

    ``params`` go to the controller's constructor; an unknown name or
    parameter is a ValueError naming it. ``convergence_distance`` (m) is
    understood by all four, so they can be tuned alike.
    """
    if name not in CONTROLLERS:
        raise ValueError(f"unknown controller {name!r}; choose one of {sorted(CONTROLLERS)}")
    try:
        return CONTROLLERS[name](path, wheelbase, **params)
    except TypeError as exc:
        raise ValueError(f"controller {name!r}: {exc}") from None


def linearised_loop(
    controller: GuidanceController, v: float, wheelbase: float, eps: float = 1e-6
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """Poles (1/m) and lateral-error residues of the closed loop linearised numerically on a line.

    The controller is given a 100 m straight path along x (its segment
    direction = sign of v) and the nonlinear tricycle [seed000 eq8] with
    state ``(y_O, psi, gamma)`` is differentiated by central differences
    about zero error. Returns the eigenvalues divided by |v| and, for each,
    its residue in the tracked point's lateral error after a unit lateral
    offset of that point (:func:`~agvnav.guidance.gains.modal_response`).
    For the seed's laws the poles are the roots of [seed000 eq17] or [seed000 eq23] [seed000 eq24]. The
    controller's own path is restored afterwards (and the controller reset).
    """
    d = 1 if v > 0 else -1
    L = require_positive("wheelbase", wheelbase)
    original = controller.path
    controller.set_path(Path([LineSegment(np.array([-50.0, 0.0]), 0.0, 100.0, d)]))
    psi0 = 0.0 if d > 0 else math.pi

    def f(z: NDArray[np.float64]) -> NDArray[np.float64]:
        y, psi, gamma = z
        controller.reset()
        u = controller.command(np.array([0.0, y, psi0 + psi]), gamma, v)
        return np.array([v * math.cos(gamma) * math.sin(psi0 + psi), v * math.sin(gamma) / L, u])

    try:
        jac = np.empty((3, 3))
        for j in range(3):
            dz = np.zeros(3)
            dz[j] = eps
            jac[:, j] = (f(dz) - f(-dz)) / (2.0 * eps)
    finally:
        controller.set_path(original)
    # lateral error of the tracked point in the reference frame: eps_o = d y_O, eps_c = d y_O + L psi
    out = np.array([float(d), L if getattr(controller, "point", "C") == "C" else 0.0, 0.0])
    lam, residues = modal_response(jac, out, np.array([d, 0.0, 0.0]))
    return lam / abs(v), residues


def linearised_poles_per_metre(controller: GuidanceController, v: float, wheelbase: float) -> NDArray[np.complex128]:
    """Poles (1/m) of the closed loop linearised on a line (see :func:`linearised_loop`)."""
    return linearised_loop(controller, v, wheelbase)[0]


def loop_convergence_distance(controller: GuidanceController, v: float, wheelbase: float) -> float:
    """Convergence distance (m) of a controller at speed ``v``: :func:`~agvnav.guidance.gains.envelope_distance`.

    The bound on the linearised lateral error of the tracked point after a
    lateral offset falls below 2 % beyond this distance. Used to tune every
    controller alike.
    """
    return envelope_distance(*linearised_loop(controller, v, wheelbase))


def tune_for_convergence(name: str, distance: float, wheelbase: float, v: float = 0.2, **params: Any) -> float:
    """Look-ahead (m, pure pursuit) or gain (1/m, Stanley) converging within ``distance`` (m).

    Convergence as in :func:`loop_convergence_distance` (servo included, at
    speed ``v``), the same measure the seed laws are designed by
    (:func:`~agvnav.guidance.gains.seed_poles_for_distance`). The parameter
    is scanned from gentle to aggressive on a log grid around the
    ideal-servo formula of :mod:`agvnav.guidance.baselines` up to the first
    crossing, then bisected. Raises ValueError if the distance is not reachable.
    """
    require_positive("distance", distance)
    path = Path([LineSegment(np.array([-50.0, 0.0]), 0.0, 100.0, 1 if v > 0 else -1)])
    if name == "pure_pursuit":
        key, guess, aggressive = "lookahead", lookahead_for_distance(distance), -1.0
    elif name == "stanley":
        key, guess, aggressive = "gain_per_m", stanley_gain_for_distance(distance), 1.0
    else:
        raise ValueError(f"tune_for_convergence: no tuning for {name!r} (use pure_pursuit or stanley)")

    def excess(logx: float) -> float:
        ctrl = CONTROLLERS[name](path, wheelbase, **{key: math.exp(logx)}, **params)
        return distance - loop_convergence_distance(ctrl, v, wheelbase)

    grid = math.log(guess) + aggressive * np.linspace(-3.0, 3.0, 31)
    prev = grid[0]
    if excess(prev) >= 0:
        raise ValueError(f"{name}: scan start already converges within {distance:g} m; widen the grid")
    for x in grid[1:]:
        if excess(x) >= 0:
            lo, hi = prev, x
            break
        prev = x
    else:
        raise ValueError(f"{name}: convergence within {distance:g} m is not reachable at v = {v:g} m/s")
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if excess(mid) >= 0:
            hi = mid
        else:
            lo = mid
    return math.exp(hi)
