"""Gain design for the seed-000 guidance laws from closed-loop poles per metre travelled.

Error dynamics (seed 000 §3.2). Linearised, [seed000 eq14] [seed000 eq15] [seed000 eq16] read
``eps_c' = v xi_r``, ``eps_o' = v xi``, ``xi' = (v/L) gamma``; with the
general law [seed000 eq11], ``gamma' = -a eps_o - b xi - c gamma``, and ``q = eps_o``:
``q' = v xi``, ``q'' = (v^2/L) gamma``, ``q''' = (v^2/L) gamma'
= -(v^2/L) a q - (v/L) b q' - c q''``, i.e.::

    q''' + c q'' + (v/L) b q' + (v^2/L) a q = 0          [seed000 eq17]

The extracted text of that equation is garbled (it reads ``q'' + c q' + (v/L) b q' + ...``);
the derivation above, repeated for eps_c, xi, xi_r and gamma (all linear
combinations of eps_o and its derivatives), confirms the third-order form.
Routh-Hurwitz on ``s^3 + c s^2 + (v b/L) s + v^2 a/L`` gives ``c > 0``,
``v b > 0``, ``a > 0`` and ``c (v b / L) > v^2 a / L``, i.e. [seed000 eq18] (v > 0) and
[seed000 eq19] (v < 0): the sign of b must follow the direction of travel.

Poles per metre. Writing the dynamics against the distance travelled
``sigma = |v| t`` makes the poles ``lambda_i = p_i / |v|`` (1/m) independent of
speed; then ``c = |v| e1``, ``b = L v e2``, ``a = L |v| e3`` where
``prod(s - lambda_i) = s^3 + e1 s^2 + e2 s + e3``. The convergence distance
stays fixed and a, b, c scale with v.

On an arc (seed ref. [13], not in seed 000) the linearisation about the steady
turn adds curvature terms. With ``k = d kappa`` (curvature in the reference
body frame), ``gamma_ss`` the feed-forward and ``dgamma = gamma - gamma_ss``:

* tracked O, state (eps_o, xi, dgamma):
  ``eps_o' = v cos(gamma_ss) xi``,
  ``xi' = v / (L cos(gamma_ss)) dgamma - k^2 v cos(gamma_ss) eps_o``;
* tracked C, state (eps_c, xi_r, dgamma):
  ``eps_c' = v xi_r``,
  ``xi_r' = (v cos(gamma_ss) / L) dgamma + dgamma' - k^2 v eps_c``;

and ``dgamma' = -a eps_o - b xi - c dgamma`` (the three forms are one law).
:func:`general_gains_on_arc` solves for a, b, c placing the poles of this
model (the characteristic coefficients are affine in a, b, c: a single-input
loop), so the designed poles per metre hold on arcs too; on a line it
reduces to :func:`general_gains`.

Convergence distance. The seed does not say how far the poles should be.
Here every controller is tuned by one measure (:func:`envelope_distance`):
the distance beyond which the envelope ``sum |r_i| exp(Re(p_i) s)`` of the
linearised lateral error of the tracked point, after a unit lateral offset,
stays below 2 %. :func:`seed_poles_for_distance` scales the seed's pole
pattern (one real pole and a complex pair) to a given distance.

Pole pattern of the general law on point C (cruising, v > 0). Per metre
(v = 1) with ``chi(s) = s^3 + e1 s^2 + e2 s + e3``, a lateral offset of C
(``eps_c(0) = eps0``, ``xi_r = gamma = 0``) is not a "natural" initial
condition of [seed000 eq17]: ``eps_c''(0) = -v a eps0``. Its Laplace transform is
``eps_c(s) / eps0 = N(s) / chi(s)`` with ``N(s) = s^2 + e1 s + (e2 - L e3)``
(time domain: ``s^2 + c s + (v b/L - v a)``), and ``chi(s) = s N(s) + e3 (L s + 1)``.
So N and chi share a root only at ``s = -1/L``: a real pole ``lambda_r`` away
from ``-1/L`` always shows in eps_c with a residue that grows with
``|L lambda_r - 1|``. The old pattern (real pole = real part of the pair,
damping 0.707) placed at 1.5 m (L = 1 m) swung eps_c to -126 % of the
offset; the 2 % envelope then asked for even faster poles (the residues grow
with the pole scale), a vicious circle that ended with the wheel at its
+/-90 deg stop. Scanning ratio and damping does not cure it (overshoot
> 100 % for every ratio in 0.2-1.5 and damping in 0.5-1 at 1.5 m); only the
real pole at ``-1/L`` does. There ``c - b + a L = 1/L`` (i.e. ``v/L``), [seed000 eq13]
becomes ``gamma' = -a eps_c - (b - a L) xi_r - (v/L) gamma``: the simple law
[seed000 eq20] (linearised) with ``a_s = a``, ``b_s = b - a L``. The pair (eps_c,
xi_r) is then a closed second-order loop [seed000 eq23] and the real mode lives
only in eps_o, xi, gamma [seed000 eq24]: hidden from eps_c for *every* initial
condition, a steering error at the start included. eps_c then follows
``q'' + 2 zeta w q' + w^2 q = 0`` from ``(1, 0)``, whose undershoot is
``exp(-pi zeta / sqrt(1 - zeta^2))``: 4.3 % at the default damping 0.707
(the simple law's pair at the same distance; the general law on C is then
the simple law). :data:`BAND_DAMPING` = 0.78 makes it exactly the 2 %
convergence band (once inside the band eps_c stays there) but lengthens the
tail: in ``agvnav bench guidance`` its RMS lateral error after the 10 %
band is ~12 % higher on the line (2.07 vs 1.84 mm, 4 seeds), so it is an
option, not the default.
On an arc the hidden pole is ``-cos(gamma_ss)/L`` (same argument on the arc
model: ``c - b + a L = v cos(gamma_ss)/L``), see :func:`hidden_real_pole`.
Hence :func:`seed_poles_for_distance` for the general law on C, forward:
real pole at :func:`hidden_real_pole`, pair with damping
0.707 scaled to the distance (the real pole does not count
in the eps_c envelope, so the envelope measure no longer forces fast poles:
the pair comes out as the simple law's). Far from the linear range (the
wheel straight at the start of a tight arc) the controller also uses [seed000 eq13]
with the body rotation written exactly (:func:`agvnav.guidance.laws.general_law`),
which keeps the cancellation. The real pole per metre is fixed
by L, so in time it is ``-v/L``: it scales with v as the pair does.

Point O (manoeuvres, either direction) needs no such care: a lateral offset
of O is a natural initial condition of [seed000 eq17] (eps_o' = v xi = 0, eps_o'' =
(v^2/L) gamma = 0), the response is the free response of chi with
``(s^2 + e1 s + e2) / chi(s)``, and the seed-like pattern (real pole = real
part of the pair, damping 0.707) has no undershoot. Reverse driving on C
cannot hide the real pole (the common root would be ``+1/L``): it keeps the
ratio pattern.

Simple law (seed 000 §3.3, [seed000 eq23]): ``q'' + b q' + a v q = 0`` for
``q = eps_c, xi_r``; with poles per metre ``mu_i``: ``b = v f1``, ``a = v f2``
where ``prod(s - mu_i) = s^2 + f1 s + f2``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav._validate import require_positive

__all__ = [
    "BAND_DAMPING",
    "SETTLING_FRACTION",
    "GeneralGains",
    "SimpleGains",
    "arc_linear_model",
    "characteristic_coefficients",
    "check_routh_hurwitz",
    "check_simple_stability",
    "convergence_distance",
    "envelope_distance",
    "general_characteristic",
    "general_gains",
    "general_gains_from_coefficients",
    "general_gains_on_arc",
    "hidden_real_pole",
    "modal_response",
    "poles_for_convergence",
    "routh_hurwitz_ok",
    "seed_loop_matrix",
    "seed_poles_for_distance",
    "simple_characteristic",
    "simple_gains",
]

SETTLING_FRACTION = 0.02
"""Convergence means an error down to 2 % of its initial value."""

BAND_DAMPING = math.log(1.0 / SETTLING_FRACTION) / math.hypot(math.pi, math.log(1.0 / SETTLING_FRACTION))
"""Damping ratio (0.7797) whose second-order free response from (1, 0) undershoots by exactly 2 %.

``exp(-pi zeta / sqrt(1 - zeta^2)) = SETTLING_FRACTION``; an option for the
pair of the general law on point C (module docstring; the default is 0.707).
"""


@dataclass(frozen=True)
class GeneralGains:
    """Gains a (1/(m s)), b (1/s, sign of v), c (1/s) of the general law.

    [seed000 eq11] [seed000 eq12] [seed000 eq13].
    """

    a: float
    b: float
    c: float


@dataclass(frozen=True)
class SimpleGains:
    """Gains a (1/(m s)) and b (1/s) of the simple law [seed000 eq20] [seed000 eq21] [seed000 eq22]."""

    a: float
    b: float


def poles_for_convergence(
    distance: float, damping: float = 1.0 / math.sqrt(2.0), order: int = 3, real_ratio: float = 1.0
) -> NDArray[np.complex128]:
    """Closed-loop poles per metre (1/m) converging within ``distance`` (m).

    As the seed chooses (§3.2), one real pole and a complex pair (``order=3``),
    or only the pair (``order=2``, simple law). The pair has damping ratio
    ``damping`` and real part ``-sigma`` with ``sigma = ln(1/0.02) / distance``;
    the real pole is ``-real_ratio * sigma``.
    """
    d = require_positive("distance", distance)
    if not (0.0 < damping <= 1.0):
        raise ValueError(f"damping must be in (0, 1], got {damping!r}")
    if order not in (2, 3):
        raise ValueError(f"order must be 2 or 3, got {order!r}")
    sigma = math.log(1.0 / SETTLING_FRACTION) / d
    omega_d = sigma * math.sqrt(1.0 - damping**2) / damping
    pair = [complex(-sigma, omega_d), complex(-sigma, -omega_d)]
    if order == 2:
        return np.array(pair)
    return np.array([complex(-require_positive("real_ratio", real_ratio) * sigma, 0.0), *pair])


def convergence_distance(poles_per_m: ArrayLike) -> float:
    """Distance (m) for the slowest mode of ``poles_per_m`` (1/m) to decay to 2 %; inf if unstable.

    This is the pole-only measure; :func:`envelope_distance` also weighs how
    much each mode shows in the error (the one the controllers are tuned by).
    """
    p = np.asarray(poles_per_m, dtype=np.complex128)
    sigma = -float(np.max(p.real))
    return math.log(1.0 / SETTLING_FRACTION) / sigma if sigma > 0 else math.inf


def modal_response(
    a_matrix: ArrayLike, out: ArrayLike, x0: ArrayLike
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """Poles and residues of ``y = out @ x`` for ``x' = A x``, ``x(0) = x0``: ``y = sum r_i exp(p_i t)``."""
    lam, vecs = np.linalg.eig(np.asarray(a_matrix, dtype=np.float64))
    residues = (np.asarray(out, dtype=np.float64) @ vecs) * np.linalg.solve(vecs, np.asarray(x0, dtype=np.float64))
    return lam, residues


def envelope_distance(poles_per_m: ArrayLike, residues: ArrayLike, fraction: float = SETTLING_FRACTION) -> float:
    """Distance (m) beyond which ``sum |r_i| exp(Re(p_i) s)`` stays below ``fraction`` (2 %).

    With ``poles_per_m`` (1/m) and ``residues`` of the tracked point's lateral
    error after a unit lateral offset (:func:`modal_response`), this bounds the
    linearised error: the convergence distance every controller is tuned to.
    One mode of residue 1 gives ``ln(1/fraction) / sigma``, as
    :func:`convergence_distance`; modes hidden from the error (zero residue,
    like the -1/L pole of [seed000 eq24] in eps_c) do not count. inf if a visible mode
    is not decaying.
    """
    p = np.asarray(poles_per_m, dtype=np.complex128)
    r = np.abs(np.asarray(residues, dtype=np.complex128))
    keep = r > 1e-9 * max(1.0, float(np.max(r)))
    sigma, r = p[keep].real, r[keep]  # decay rates (1/m) of the visible modes
    if np.any(sigma >= 0.0):
        return math.inf
    total = float(np.sum(r))
    if total <= fraction:
        return 0.0
    lo, hi = 0.0, float(np.max(np.log(total / fraction) / -sigma))  # envelope(hi) <= fraction
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if float(np.sum(r * np.exp(sigma * mid))) > fraction:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-12 * hi:
            break
    return hi


def _monic_real(poles: ArrayLike, order: int) -> NDArray[np.float64]:
    p = np.asarray(poles, dtype=np.complex128).ravel()
    if p.size != order:
        raise ValueError(f"poles_per_m must hold {order} poles, got {p.size}")
    if not np.all(np.isfinite(p)):
        raise ValueError("poles_per_m contains NaN or inf")
    coeffs = np.poly(p)
    if np.max(np.abs(coeffs.imag)) > 1e-9 * max(1.0, float(np.max(np.abs(coeffs)))):
        raise ValueError("poles_per_m must be real or come in complex-conjugate pairs")
    if np.any(p.real >= 0.0):
        raise ValueError(f"poles_per_m must all have negative real parts, got {_format_poles(p)}")
    return np.asarray(coeffs.real, dtype=np.float64)


def _format_poles(p: NDArray[np.complex128]) -> str:
    """Poles (1/m) as ``[3, -3]`` or ``[-2+1.5j, -2-1.5j]``: 3 significant figures, no ``+0j``."""

    def one(z: complex) -> str:
        if z.imag == 0.0:
            return f"{z.real:.3g}"
        return f"{z.real:.3g}{z.imag:+.3g}j"

    return "[" + ", ".join(one(complex(z)) for z in p) + "]"


def characteristic_coefficients(poles_per_m: ArrayLike, order: int) -> NDArray[np.float64]:
    """Real coefficients ``[1, e1, ..., e_order]`` of ``prod(s - lambda_i)`` for poles per metre (1/m).

    Raises ValueError unless there are ``order`` finite poles, real or in
    conjugate pairs, all with negative real parts.
    """
    return _monic_real(poles_per_m, order)


def general_gains_from_coefficients(coeffs: NDArray[np.float64], v: float, wheelbase: float) -> GeneralGains:
    """``c = |v| e1``, ``b = L v e2``, ``a = L |v| e3`` from ``coeffs = [1, e1, e2, e3]`` (module docstring)."""
    _, e1, e2, e3 = (float(x) for x in coeffs)
    return GeneralGains(a=wheelbase * abs(v) * e3, b=wheelbase * v * e2, c=abs(v) * e1)


def general_gains(poles_per_m: ArrayLike, v: float, wheelbase: float) -> GeneralGains:
    """a, b, c of the general law placing the poles of [seed000 eq17] at ``poles_per_m`` (1/m), speed ``v`` (m/s).

    ``c = |v| e1``, ``b = L v e2``, ``a = L |v| e3`` (module docstring). At
    ``v = 0`` all gains are 0 (nothing moves, nothing to correct).
    """
    L = require_positive("wheelbase", wheelbase)
    return general_gains_from_coefficients(_monic_real(poles_per_m, 3), float(v), L)


def arc_linear_model(
    point: str, kappa_ref: float, v: float, wheelbase: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Linearised error dynamics about the steady turn (module docstring): ``(A0, B, R)``.

    On a line (``kappa_ref = 0``) ``A0`` is [seed000 eq14] or [seed000 eq15] with [seed000 eq16],
    and ``R`` is [seed000 eq9] [seed000 eq10] linearised.

    ``x' = A0 x + B u`` with ``x`` = (eps_o, xi, dgamma) for point O or
    (eps_c, xi_r, dgamma) for point C, ``u = dgamma'``; ``R`` (3, 3) holds the
    rows expressing (eps_o, xi, dgamma) in ``x`` so that the general law is
    ``u = -[a, b, c] @ R @ x``. ``kappa_ref`` = direction * curvature (1/m).
    """
    L = require_positive("wheelbase", wheelbase)
    k = float(kappa_ref)
    if point == "O":
        cg = 1.0 / math.sqrt(1.0 + (L * k) ** 2)  # cos(gamma_ss), tan(gamma_ss) = L k
        a0 = np.array([[0.0, v * cg, 0.0], [-k * k * v * cg, 0.0, v / (L * cg)], [0.0, 0.0, 0.0]])
        return a0, np.array([0.0, 0.0, 1.0]), np.eye(3)
    if point != "C":
        raise ValueError(f"point must be 'O' or 'C', got {point!r}")
    if abs(L * k) >= 1.0:
        raise ValueError(f"point C cannot follow curvature {kappa_ref:g} 1/m with wheelbase {L:g} m")
    cg = math.sqrt(1.0 - (L * k) ** 2)  # cos(gamma_ss), sin(gamma_ss) = L k
    a0 = np.array([[0.0, v, 0.0], [-k * k * v, 0.0, v * cg / L], [0.0, 0.0, 0.0]])
    rows = np.array([[1.0, -L, L], [0.0, 1.0, -1.0], [0.0, 0.0, 1.0]])  # eps_o, xi from eqs 9-10
    return a0, np.array([0.0, 1.0, 1.0]), rows


def general_gains_on_arc(
    poles_per_m: ArrayLike, v: float, wheelbase: float, kappa_ref: float, point: str
) -> GeneralGains:
    """a, b, c placing the poles of the arc-linearised loop (module docstring) at ``poles_per_m`` (1/m).

    ``kappa_ref`` = direction * curvature (1/m); ``point`` "O" or "C". Gains
    scale with |v| as on a line; at ``kappa_ref = 0`` equal :func:`general_gains`.
    """
    coeffs = _monic_real(poles_per_m, 3)
    v = float(v)
    if v == 0.0:
        return GeneralGains(0.0, 0.0, 0.0)
    sv = math.copysign(1.0, v)
    a0, bvec, rows = arc_linear_model(point, kappa_ref, sv, wheelbase)  # unit speed, then scale

    def charpoly(k: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(np.poly(a0 - np.outer(bvec, k @ rows)).real[1:], dtype=np.float64)

    base = charpoly(np.zeros(3))
    m = np.column_stack([charpoly(e) - base for e in np.eye(3)])
    a, b, c = np.linalg.solve(m, coeffs[1:] - base)
    s = abs(v)
    return GeneralGains(a=float(a) * s, b=float(b) * s, c=float(c) * s)


def seed_loop_matrix(
    poles_per_m: ArrayLike, wheelbase: float, law: str, point: str, direction: int = 1
) -> NDArray[np.float64]:
    """Closed-loop matrix per metre (v = direction m/s) on a line, state (eps, heading error, gamma) of ``point``.

    ``law`` "general" ([seed000 eq17]) or "simple" ([seed000 eq20], point C, forward).
    """
    v = 1.0 if direction > 0 else -1.0
    a0, bvec, rows = arc_linear_model(point, 0.0, v, wheelbase)
    if law == "general":
        g = general_gains(poles_per_m, v, wheelbase)
        return a0 - np.outer(bvec, np.array([g.a, g.b, g.c]) @ rows)
    if law == "simple":
        if point != "C" or v < 0:
            raise ValueError("the simple law guides point C forward (seed 000 §3.3)")
        g2 = simple_gains(poles_per_m, 1.0)
        return a0 - np.outer(bvec, [g2.a, g2.b, 1.0 / wheelbase])
    raise ValueError(f"law must be 'general' or 'simple', got {law!r}")


def hidden_real_pole(wheelbase: float, kappa_ref: float = 0.0) -> float:
    """Real pole per metre (1/m) that the general law on point C, forward, hides from eps_c and xi_r.

    ``-cos(gamma_ss) / L`` with ``sin(gamma_ss) = L kappa_ref`` (``-1/L`` on a
    line). With this real pole [seed000 eq13] reduces to the simple law [seed000 eq20] (module
    docstring): ``c - b + a L = v cos(gamma_ss) / L``.
    """
    L = require_positive("wheelbase", wheelbase)
    lk = L * float(kappa_ref)
    if not abs(lk) < 1.0:
        raise ValueError(f"point C cannot follow curvature {kappa_ref:g} 1/m with wheelbase {L:g} m")
    return -math.sqrt(1.0 - lk * lk) / L


def _hides_real_pole(law: str, point: str, direction: int, real_ratio: float | None) -> bool:
    return law == "general" and point == "C" and direction > 0 and real_ratio is None


def seed_poles_for_distance(
    distance: float,
    wheelbase: float,
    law: str = "general",
    point: str = "C",
    damping: float | None = None,
    real_ratio: float | None = None,
    direction: int = 1,
) -> NDArray[np.complex128]:
    """Poles per metre (1/m) whose :func:`envelope_distance` is ``distance`` (m).

    The tracked point's lateral error after a unit lateral offset (the seed's
    110 mm start, scaled) stays within 2 % beyond ``distance``, in the
    linearised loop on a line, driving in ``direction`` (+1/-1). Patterns
    (module docstring):

    * general law, point C, forward, ``real_ratio`` None: real pole at
      :func:`hidden_real_pole` (-1/L), complex pair of damping ``damping``
      (default 0.707; :data:`BAND_DAMPING` for at most 2 % undershoot) scaled
      to the distance;
    * otherwise (point O, reverse on C, or an explicit ``real_ratio``): the
      shape of :func:`poles_for_convergence` (damping default 0.707, real pole
      ``real_ratio`` (default 1) times the pair's real part) scaled as a whole;
    * simple law: the pair alone (damping default 0.707).

    Found by bisection on the scale. Raises ValueError if not reachable.
    """
    d = require_positive("distance", distance)
    order = 3 if law == "general" else 2
    hide = _hides_real_pole(law, point, direction, real_ratio)
    if damping is None:
        damping = 1.0 / math.sqrt(2.0)
    if hide:
        fixed = np.array([complex(hidden_real_pole(wheelbase), 0.0)])
        shape = poles_for_convergence(1.0, damping=damping, order=2)
    else:
        fixed = np.zeros(0, dtype=np.complex128)
        shape = poles_for_convergence(1.0, damping=damping, order=order, real_ratio=real_ratio or 1.0)

    def poles(log_k: float) -> NDArray[np.complex128]:
        return np.concatenate([fixed, math.exp(log_k) * shape])

    def dist(log_k: float) -> float:
        a_cl = seed_loop_matrix(poles(log_k), wheelbase, law, point, direction)
        lam, res = modal_response(a_cl, [1, 0, 0], [1, 0, 0])
        return envelope_distance(lam, res)

    lo, hi = math.log(1.0 / d) - 6.0, math.log(1.0 / d) + 6.0
    if not dist(lo) > d > dist(hi):
        raise ValueError(f"cannot design {law}-law poles converging within {distance:g} m")
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if dist(mid) > d:
            lo = mid
        else:
            hi = mid
    return poles(hi)


def general_characteristic(a: float, b: float, c: float, v: float, wheelbase: float) -> NDArray[np.float64]:
    """Coefficients ``[1, c, v b / L, v^2 a / L]`` of the characteristic polynomial of [seed000 eq17]."""
    L = require_positive("wheelbase", wheelbase)
    return np.array([1.0, c, v * b / L, v * v * a / L])


def routh_hurwitz_ok(a: ArrayLike, b: ArrayLike, c: ArrayLike, v: ArrayLike) -> NDArray[np.bool_]:
    """Vectorised Routh-Hurwitz test of [seed000 eq17]: [seed000 eq18] [seed000 eq19]; False at v = 0."""
    a, b, c, v = (np.asarray(x, dtype=np.float64) for x in (a, b, c, v))
    return (a > 0) & (c > 0) & (v * b > 0) & (c * np.abs(b) > np.abs(v) * a)


def check_routh_hurwitz(a: float, b: float, c: float, v: float) -> None:
    """Raise ValueError naming the violated condition of [seed000 eq18] (v > 0) or [seed000 eq19] (v < 0)."""
    if v == 0:
        raise ValueError("Routh-Hurwitz check needs v != 0 (eq. 17 degenerates at standstill)")
    eq = "18" if v > 0 else "19"
    if not a > 0:
        raise ValueError(f"unstable guidance gains: a = {a:g} must be > 0 (seed 000 eq. {eq})")
    if not c > 0:
        raise ValueError(f"unstable guidance gains: c = {c:g} must be > 0 (seed 000 eq. {eq})")
    if not v * b > 0:
        need = "> 0 for v > 0" if v > 0 else "< 0 for v < 0"
        raise ValueError(f"unstable guidance gains: b = {b:g} must be {need} (seed 000 eq. {eq})")
    if not abs(b) * c / a > abs(v):
        raise ValueError(
            f"unstable guidance gains: |b| c / a = {abs(b) * c / a:g} m/s must exceed |v| = {abs(v):g} m/s "
            f"(seed 000 eq. {eq})"
        )


def simple_gains(poles_per_m: ArrayLike, v: float) -> SimpleGains:
    """a, b of the simple law placing the poles of [seed000 eq23] at ``poles_per_m`` (1/m), ``v`` > 0 (m/s)."""
    if v < 0:
        raise ValueError(f"the simple law is for v > 0 (seed 000 §3.3), got v = {v:g} m/s")
    _, f1, f2 = _monic_real(poles_per_m, 2)
    return SimpleGains(a=float(v) * f2, b=float(v) * f1)


def simple_characteristic(a: float, b: float, v: float) -> NDArray[np.float64]:
    """Coefficients ``[1, b, a v]`` of the characteristic polynomial of [seed000 eq23] (time domain)."""
    return np.array([1.0, b, a * v])


def check_simple_stability(a: float, b: float, v: float) -> None:
    """Raise ValueError unless v > 0 and a, b > 0: stability of [seed000 eq23] and [seed000 eq24]."""
    if not v > 0:
        raise ValueError(
            f"the simple law is stable only for v > 0 (seed 000 §3.3); got v = {v:g} m/s: use the general law"
        )
    if not (a > 0 and b > 0):
        raise ValueError(f"unstable simple-law gains: need a > 0 and b > 0 (seed 000 eq. 23), got a={a:g}, b={b:g}")
