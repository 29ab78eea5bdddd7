"""Fixes for a moving vehicle from bearings taken at different instants (seeds 000 §2.2, 001 §2).

A rotating head sees each reflector at its own instant while the vehicle moves, so
"the angles theta_i must be known for one and the same configuration of the robot"
(seed 000 §2.2). Three ways to form a fix at the instant ``t_f`` of the latest
identified reflection, given the odometric pose of base_link at every reflection:

* :class:`NaiveEstimator` -- triangulate three recent bearings as if simultaneous
  (the baseline that shows the problem);
* :class:`AnglePropagationEstimator` -- the seeds' method: simulate the evolution of
  each relative angle from its reflection to ``t_f`` with the kinematics and odometry
  (:func:`propagate_bearings`), then triangulate with absolute angles (seed 000 §2.3);
* :class:`BatchMLEstimator` -- every bearing of the last revolution with the odometry
  between them, solved jointly for the pose at ``t_f`` by Gauss-Newton
  (:func:`batch_ml_fix`), the maximum-likelihood fix when odometry over one revolution
  is taken as exact.

All three share identification, odometric prediction and status with the EKF
(:class:`~agvnav.positioning.estimator.StreamingEstimator`); between fixes the pose is
dead-reckoned from the last fix.
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvnav.geometry import angle_diff, between, circumcentre, compose, inverse, wrap_angle
from agvnav.positioning.bounds import crlb, fisher_information
from agvnav.positioning.edge_bearing import bearing_model, edge_offset, measurement_variance
from agvnav.positioning.estimator import StreamingEstimator
from agvnav.positioning.plausibility import sound_state
from agvnav.positioning.triangulation import triangulate

__all__ = [
    "AnglePropagationEstimator",
    "BatchMLEstimator",
    "NaiveEstimator",
    "batch_ml_fix",
    "centre_bearings",
    "fix_given_heading",
    "near_critical_circle",
    "predicted_position_variances",
    "propagate_bearings",
]

#: A fix whose Mahalanobis distance from the prediction exceeds this (chi-square, 3 dof, false
#: alarm 1e-9: 6.7 sigma; ``scipy.stats.chi2.isf(1e-9, 3)``, a literal so that importing agvnav
#: does not import scipy.stats, issue 11) is refused (:meth:`_FixEstimator._plausible_fix`).
FIX_GATE = 44.841275330562404


def centre_bearings(
    edge_bearing: ArrayLike, pose: ArrayLike, mount: ArrayLike, reflector_xy: ArrayLike, radius: ArrayLike
) -> NDArray[np.float64]:
    """Reported leading-edge bearings (rad) moved to the reflector centres, ``+asin(r/d)``.

    The distance d is taken from the (predicted) base_link ``pose (..., 3)`` at the
    reflection; an error of a few cm in d changes the correction by ``r * dd / d^2``,
    i.e. micro-radians (seed 000 §2.1: the angle is read at the start of the reflection).
    """
    _, _, d = bearing_model(pose, mount, reflector_xy, radius)
    return wrap_angle(np.asarray(edge_bearing, dtype=np.float64) - edge_offset(d, radius))


def propagate_bearings(
    bearings: ArrayLike,
    odom_at_reflection: ArrayLike,
    odom_at_fix: ArrayLike,
    pose_at_fix: ArrayLike,
    mount: ArrayLike,
    reflector_xy: ArrayLike,
) -> NDArray[np.float64]:
    """Bring centre bearings measured at instants t_i to the fix instant t_f (seed 000 §2.2, [7]).

    The vehicle's motion from t_i to t_f is the odometric relative motion
    ``between(odom_f, odom_i)``; composing it with the pose at the fix gives the pose at
    t_i, and the reflector's relative angle changes by the kinematic prediction

        theta_i(t_f) = theta_i(t_i) + [h(x_f, R_i) - h(x_i, R_i)],

    with ``h`` the head-frame centre bearing. The correction is exact when the odometry
    is exact and ``pose_at_fix`` is right; callers iterate it with the new fix (a fixed
    point, since the correction's sensitivity to the pose error is second order).

    Shapes: ``bearings (..., n)``, ``odom_at_reflection (..., n, 3)``, ``odom_at_fix (..., 3)``,
    ``pose_at_fix (..., 3)``, ``reflector_xy (..., n, 2)``; returns ``(..., n)`` (rad).
    """
    x_f = np.asarray(pose_at_fix, dtype=np.float64)[..., None, :]
    rel = between(np.asarray(odom_at_fix, dtype=np.float64)[..., None, :], odom_at_reflection)
    x_i = compose(x_f, rel)
    h_f, _, _ = bearing_model(x_f, mount, reflector_xy, 0.0)
    h_i, _, _ = bearing_model(x_i, mount, reflector_xy, 0.0)
    return wrap_angle(np.asarray(bearings, dtype=np.float64) + angle_diff(h_f, h_i))


def batch_ml_fix(
    pose0: ArrayLike,
    bearings: ArrayLike,
    reflector_xy: ArrayLike,
    radius: ArrayLike,
    relative_motion: ArrayLike,
    mount: ArrayLike,
    bearing_var: ArrayLike,
    iterations: int = 10,
) -> tuple[NDArray[np.float64], NDArray[np.float64], bool]:
    """Joint Gauss-Newton fix of the pose at t_f from bearings taken at their own instants.

    Unknown ``x_f``; the pose at reflection i is ``x_i = x_f ⊕ d_i`` with ``d_i`` the
    odometric motion from t_f back to t_i (``relative_motion (n, 3)``). Minimises
    ``sum_i wrap(z_i - h(x_i, R_i))^2 / sigma^2`` with ``h`` the leading-edge bearing
    (:func:`~agvnav.positioning.edge_bearing.bearing_model`), Jacobian
    ``dh/dx_f = H_i J_i``, ``J_i = d(x_f ⊕ d_i)/dx_f``.

    ``bearings (n,)`` edge bearings (rad), ``reflector_xy (n, 2)``, ``radius (n,)``,
    ``bearing_var`` scalar or ``(n,)`` variances (rad²) weighting each residual.
    Returns ``(pose (3,), covariance (3, 3), valid)``; invalid when the normal matrix is
    singular (fewer than three independent directions) or the iteration diverges.
    """
    x = np.array(pose0, dtype=np.float64)
    z = np.asarray(bearings, dtype=np.float64)
    rel = np.asarray(relative_motion, dtype=np.float64)
    w = 1.0 / np.broadcast_to(np.asarray(bearing_var, dtype=np.float64), z.shape)
    for _ in range(iterations):
        A, r = _ml_system(x, z, reflector_xy, radius, rel, mount)
        N = A.T @ (A * w[:, None])
        if np.linalg.cond(N) > 1e12:
            return x, np.full((3, 3), np.nan), False
        step = np.linalg.solve(N, A.T @ (r * w))
        x = x + step
        x[2] = wrap_angle(x[2])
        if np.max(np.abs(step)) < 1e-10:
            break
    A, r = _ml_system(x, z, reflector_xy, radius, rel, mount)
    cov = np.linalg.inv(A.T @ (A * w[:, None]))
    valid = bool(np.all(np.isfinite(x)) and np.max(np.abs(r)) < 0.5)
    return x, 0.5 * (cov + cov.T), valid


def _ml_system(
    x: NDArray[np.float64],
    z: NDArray[np.float64],
    xy: ArrayLike,
    radius: ArrayLike,
    rel: NDArray[np.float64],
    mount: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Stacked Jacobian ``(n, 3)`` with respect to ``x_f`` and residuals ``(n,)``."""
    x_i = compose(x, rel)
    h, H, _ = bearing_model(x_i, mount, xy, radius)
    c, s = np.cos(x[2]), np.sin(x[2])
    J = np.zeros((rel.shape[0], 3, 3))
    J[:, 0, 0] = J[:, 1, 1] = J[:, 2, 2] = 1.0
    J[:, 0, 2] = -s * rel[:, 0] - c * rel[:, 1]
    J[:, 1, 2] = c * rel[:, 0] - s * rel[:, 1]
    return np.einsum("ni,nij->nj", H, J), angle_diff(z, h)


def near_critical_circle(reflector_xy: ArrayLike, head_xy: ArrayLike, margin: float) -> bool:
    """True when P lies within ``margin`` (relative to the radius) of the circle through three reflectors.

    ``reflector_xy (3, 2)``, ``head_xy (2,)`` (m). Collinear reflectors (no circle) give False.
    Seed 000 §2.2: the relative-angle triangulation is indeterminate on that circle.
    """
    centre, valid = circumcentre(*np.asarray(reflector_xy, dtype=np.float64))
    if not valid:
        return False
    radius = np.hypot(*(np.asarray(reflector_xy)[0] - centre))
    return bool(abs(np.hypot(*(np.asarray(head_xy) - centre)) - radius) < margin * radius)


def predicted_position_variances(
    reflector_xy: ArrayLike, head_pose: ArrayLike, bearing_std: float, heading_std: float
) -> tuple[float, float]:
    """Predicted position variance (m², trace of the x-y block) of the two methods at a head pose.

    Seed 000 §5 plans to "alternate the absolute and the relative methods according to the
    error associated with the goniometer's angular resolution" [seed000 §5]. The two
    predictions, from the linearised bearings ``J`` (``(3, 3)`` Fisher information
    ``J^T J / sigma^2``, blocks ``A`` (x-y) and ``b`` (x-y with heading)):

    * relative (three bearings only, heading from them): ``(J^T J / sigma^2)^-1``, which
      grows without bound near the critical circle [seed000 §2.2];
    * absolute with the odometric heading held [seed000 §2.3]: ``A^-1 + g g^T heading_std^2``
      with ``g = -A^-1 b`` (the position error a heading error causes).

    ``reflector_xy (3, 2)`` m, ``head_pose (3,)`` (m, m, rad), stds in rad. Returns
    ``(relative, absolute)``; ``inf`` where a prediction is singular.
    """
    info = fisher_information(np.asarray(reflector_xy, dtype=np.float64), np.asarray(head_pose, dtype=np.float64),
                              float(bearing_std))
    a, b = info[:2, :2], info[:2, 2]
    relative = float(np.trace(np.linalg.inv(info)[:2, :2])) if np.linalg.cond(info) < 1e12 else math.inf
    if np.linalg.cond(a) >= 1e12:
        return relative, math.inf
    a_inv = np.linalg.inv(a)
    g = -a_inv @ b
    return relative, float(np.trace(a_inv) + heading_std**2 * float(g @ g))


def fix_given_heading(
    reflector_xy: ArrayLike, bearings: ArrayLike, heading: float, weights: ArrayLike | None = None
) -> NDArray[np.float64] | None:
    """Head position (m) from the lines of absolute angle ``heading + theta_i`` through each reflector.

    The absolute-angle construction with the heading held at ``heading`` [seed000 §2.3]:
    the weighted least-squares intersection of the lines (``weights (n,)``, default 1);
    None when the lines are (nearly) parallel.
    """
    xy = np.asarray(reflector_xy, dtype=np.float64)
    phi = heading + np.asarray(bearings, dtype=np.float64)
    normal = np.column_stack([-np.sin(phi), np.cos(phi)])
    w = np.ones(len(phi)) if weights is None else np.asarray(weights, dtype=np.float64)
    lhs = normal.T @ (normal * w[:, None])
    if np.linalg.cond(lhs) >= 1e12:
        return None
    rhs = normal.T @ (w * np.sum(normal * xy, axis=1))
    return np.asarray(np.linalg.solve(lhs, rhs), dtype=np.float64)


def _triangulate_head(
    reflector_xy: NDArray[np.float64], bearings: NDArray[np.float64], heading_estimate: float, method: str
) -> tuple[NDArray[np.float64], bool]:
    """Head pose from three (made-)simultaneous centre bearings via the issue-2 triangulation."""
    res = triangulate(reflector_xy, bearings, method=method, heading_estimate=np.float64(heading_estimate))
    pose = np.array([float(res.x), float(res.y), float(res.heading)])
    return pose, bool(res.valid) and bool(np.all(np.isfinite(pose)))


class _FixEstimator(StreamingEstimator):
    """Shared machinery of the fix-based methods: a buffer of identified reflections.

    Each entry is ``(t, edge bearing, reflector row, odometric pose of base_link)``;
    ``_fix`` forms a fix at the latest entry and returns ``(pose, covariance)`` or None. A
    fix replaces the estimate only when it is plausible (:meth:`_plausible_fix`); a refused
    one is counted in ``n_fixes_refused`` and in :attr:`n_dropped` as ``"implausible_fix"``.
    """

    def __init__(self, world: Any, mount: ArrayLike = (0.0, 0.0, 0.0), **kwargs: Any) -> None:
        super().__init__(world, mount, **kwargs)
        self._entries: deque[tuple[float, float, int, NDArray[np.float64]]] = deque()
        self.n_fixes = 0
        self.n_fixes_refused = 0

    def _accept(self, t: float, bearing: float, assoc: Any) -> tuple[float, float, float]:
        """Buffer the identified reflection and replace the pose by a plausible fix; no gain (NaN)."""
        self._take_fix(t, bearing, assoc)
        return (math.nan, math.nan, math.nan)

    def _take_fix(self, t: float, bearing: float, assoc: Any) -> None:
        self._entries.append((t, bearing, assoc.index, self._odom.copy()))
        while self._entries and t - self._entries[0][0] > 2.0 / self.rate_hz + 1.0:
            self._entries.popleft()
        fix = self._fix()
        if fix is None:
            return
        if not self._plausible_fix(*fix):
            self.n_fixes_refused += 1
            self.drops.drop(t, "implausible_fix")  # counted, never raised: a fix is no input
            return
        self._x, self._P = fix
        self.n_fixes += 1

    def _plausible_fix(self, pose: NDArray[np.float64], cov: NDArray[np.float64]) -> bool:
        """Whether the fix ``pose (3,)`` with ``cov (3, 3)`` may replace the prediction.

        It must be finite with a finite, symmetric, positive-definite covariance
        (:func:`~agvnav.positioning.plausibility.sound_state`), and agree with the predicted
        pose: ``e^T (P + cov + diag(slack_m², slack_m², slack_rad²))^-1 e <= FIX_GATE`` with
        ``e`` the difference (heading wrapped). A triangulation of three bearings near the
        critical circle, or of a misidentified reflection, can land kilometres away; the
        prediction's own covariance grows with the odometry, so a vehicle that really moved
        is still followed. The same test as the EKF's gate, on the whole fix at once.
        """
        if not sound_state(tuple(pose.tolist()), tuple(cov.reshape(9).tolist())):
            return False
        lim = self.plausibility
        S = self._P + cov + np.diag([lim.slack_m**2, lim.slack_m**2, lim.slack_rad**2])
        e = pose - self._x
        e[2] = wrap_angle(e[2])
        try:
            d2 = float(e @ np.linalg.solve(S, e))
        except np.linalg.LinAlgError:
            return False
        return d2 <= FIX_GATE

    def _on_start(self) -> None:
        self._entries.clear()

    def _best_triple(self) -> list[tuple[float, float, int, NDArray[np.float64]]]:
        """Three identified reflections to triangulate, oldest first (empty when fewer than 3 reflectors).

        Among the reflectors seen in the last revolution (latest reflection of each), the
        triple that contains the newest reflection and has the smallest position CRLB at
        the predicted pose; seed 000 §2.3 notes the accuracy depends on where P lies
        relative to the three reflectors, and near their circle the heading -- hence the
        position -- of a three-bearing fix is poorly determined. Falls back to the three
        most recently seen reflectors when the last revolution holds fewer than three.
        """
        latest: dict[int, tuple[float, float, int, NDArray[np.float64]]] = {}
        for entry in reversed(self._entries):
            if entry[2] not in latest and (len(latest) < 3 or self._entries[-1][0] - entry[0] < 1.0 / self.rate_hz):
                latest[entry[2]] = entry
        if len(latest) < 3:
            return []
        cand = list(latest.values())
        newest, others = cand[0], cand[1:]
        triples = [(newest, a, b) for a, b in itertools.combinations(others, 2)]
        if len(triples) > 1:
            xy = self.reflector_xy[np.array([[e[2] for e in tri] for tri in triples])]
            cov = crlb(xy, compose(self._x, self.mount), self.bearing_std)
            score = np.where(np.isfinite(cov[:, 0, 0]), cov[:, 0, 0] + cov[:, 1, 1], np.inf)
            best = triples[int(np.argmin(score))]
        else:
            best = triples[0]
        return sorted(best, key=lambda e: e[0])

    def _reflectors(self, entries: list) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Map centres ``(n, 2)`` (m) and radii ``(n,)`` (m) of the entries' reflectors."""
        idx = [e[2] for e in entries]
        return self.reflector_xy[idx], self.reflector_radius[idx]

    def _fix_covariance(
        self, pose: NDArray[np.float64], entries: list, rel: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Bearing-noise covariance ``(A^T A / sigma^2)^-1`` of a fix from ``entries``."""
        z = np.array([e[1] for e in entries])
        A, _ = _ml_system(pose, z, *self._reflectors(entries), rel, self.mount)
        N = A.T @ (A / self._variances(pose, entries, rel)[:, None])
        if np.linalg.cond(N) > 1e12:
            return self._P
        cov = np.linalg.inv(N)
        return 0.5 * (cov + cov.T)

    def _variances(self, pose: NDArray[np.float64], entries: list, rel: NDArray[np.float64]) -> NDArray[np.float64]:
        """Measurement variance (rad²) of each entry: bearing noise plus map survey error."""
        idx = [e[2] for e in entries]
        _, _, d = bearing_model(compose(pose, rel), self.mount, self.reflector_xy[idx], 0.0)
        return measurement_variance(self.bearing_std**2, self.map_std, d)

    def _relative(self, entries: list) -> NDArray[np.float64]:
        """Odometric pose at each entry seen from the current odometric pose, ``(n, 3)``."""
        return between(self._odom, np.array([e[3] for e in entries]))

    def _fix(self) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:  # pragma: no cover - abstract
        raise NotImplementedError


class NaiveEstimator(_FixEstimator):
    """Triangulate three recent identified bearings as if they were simultaneous.

    The baseline of seed 000 §2.2: correct at standstill, wrong in motion. The three are
    chosen as for the angle propagation (:meth:`_FixEstimator._best_triple`: the newest
    and the best-conditioned pair of the last revolution) so the two methods differ only
    by the propagation; "the last three bearings" verbatim would also pick ill-conditioned
    triples at standstill and blur the comparison. Its covariance
    adds, to the bearing-noise part, the pose change of one revolution (distance, forward
    and sideways, and turn driven at the current odometric rate), so that its own gate
    stays honest at speed.
    """

    method = "naive"

    def __init__(
        self, world: Any, mount: ArrayLike = (0.0, 0.0, 0.0), *, triangulation_method: str = "absolute_angles",
        **kwargs: Any,
    ) -> None:
        super().__init__(world, mount, **kwargs)
        self.triangulation_method = triangulation_method

    def _fix(self) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        entries = self._best_triple()
        if not entries:
            return None
        xy, radius = self._reflectors(entries)
        z = centre_bearings([e[1] for e in entries], self._x, self.mount, xy, radius)
        head_est = compose(self._x, self.mount)[2]
        head, ok = _triangulate_head(xy, z, head_est, self.triangulation_method)
        if not ok:
            return None
        pose = compose(head, inverse(self.mount))
        cov = self._fix_covariance(pose, entries, np.zeros((3, 3)))
        rate = self.inputs.rate
        per_rev = np.array([math.hypot(rate[0], rate[2]), abs(rate[1])]) / self.rate_hz
        return pose, cov + np.diag([per_rev[0] ** 2, per_rev[0] ** 2, per_rev[1] ** 2])


class AnglePropagationEstimator(_FixEstimator):
    """The seeds' method: propagate the last three bearings to the fix instant, then triangulate.

    Each bearing is brought from its reflection to ``t_f`` by :func:`propagate_bearings`
    (odometry between them, map, predicted pose), then the three are triangulated with
    ``absolute_angles`` (seed 000 §2.3), the odometric heading estimate being the
    predicted one. With ``triangulation_method="relative_angles"`` the geometric method is
    used away from the critical circle and absolute angles within ``critical_margin``
    (relative distance) of it (seed 000 §2.2: the relative-angle method is indeterminate
    on the circle through the three reflectors and inaccurate near it). With
    ``triangulation_method="predicted"`` the choice is made on the predicted error instead
    (seed 000 §5, :func:`predicted_position_variances`): the three-bearing fix when its
    predicted position variance is the smaller, else the lines at the odometric heading
    (:func:`fix_given_heading`); ``n_relative``/``n_held`` count the choices.
    The propagation is iterated ``iterations`` times with the new fix as the pose at t_f.
    """

    method = "angle_propagation"

    def __init__(
        self,
        world: Any,
        mount: ArrayLike = (0.0, 0.0, 0.0),
        *,
        triangulation_method: str = "absolute_angles",
        iterations: int = 2,
        critical_margin: float = 0.1,
        **kwargs: Any,
    ) -> None:
        super().__init__(world, mount, **kwargs)
        if triangulation_method not in ("absolute_angles", "relative_angles", "predicted"):
            raise ValueError(
                "triangulation_method must be 'absolute_angles', 'relative_angles' or 'predicted', "
                f"got {triangulation_method!r}"
            )
        self.triangulation_method = triangulation_method
        self.iterations = int(iterations)
        self.critical_margin = float(critical_margin)
        self.n_relative = 0
        self.n_held = 0

    def _fix(self) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        entries = self._best_triple()
        if not entries:
            return None
        xy, radius = self._reflectors(entries)
        rel = self._relative(entries)
        odom_i = np.array([e[3] for e in entries])
        pose = self._x.copy()
        ok = False
        for _ in range(max(self.iterations, 1)):
            z = centre_bearings([e[1] for e in entries], compose(pose, rel), self.mount, xy, radius)
            z_f = propagate_bearings(z, odom_i, self._odom, pose, self.mount, xy)
            head_pred = compose(pose, self.mount)
            method = self.triangulation_method
            if method == "relative_angles" and near_critical_circle(xy, head_pred[:2], self.critical_margin):
                method = "absolute_angles"
            held_cov = None
            if method == "predicted":
                head, ok, held_cov = self._predicted_choice(xy, z_f, head_pred)
            else:
                head, ok = _triangulate_head(xy, z_f, head_pred[2], method)
            if not ok:
                return None
            pose = compose(head, inverse(self.mount))
        if held_cov is not None:  # the heading was held: its variance is the prediction's, not the bearings'
            return pose, self._head_to_base(held_cov, head[2])
        return pose, self._fix_covariance(pose, entries, rel)


    def _predicted_choice(
        self, xy: NDArray[np.float64], z_f: NDArray[np.float64], head_pred: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], bool, NDArray[np.float64] | None]:
        """Seed 000 §5 switch on the predicted error (see :func:`predicted_position_variances`).

        Returns the head pose, whether it is valid, and (when the heading was held) the
        head covariance of that fix: ``[[A^-1 + g g^T s^2, g s^2], [g^T s^2, s^2]]``.
        """
        var_h = max(float(self._P[2, 2]), 0.0)
        relative, held = predicted_position_variances(xy, head_pred, self.bearing_std, math.sqrt(var_h))
        if relative <= held:
            self.n_relative += 1
            head, ok = _triangulate_head(xy, z_f, head_pred[2], "relative_angles")
            return head, ok, None
        self.n_held += 1
        dist = np.hypot(*(xy - head_pred[:2]).T)
        p = fix_given_heading(xy, z_f, float(head_pred[2]), 1.0 / np.maximum(dist, 1e-9) ** 2)
        if p is None:
            return head_pred, False, None
        info = fisher_information(xy, head_pred, self.bearing_std)
        a_inv = np.linalg.inv(info[:2, :2])
        g = -a_inv @ info[:2, 2]
        cov = np.zeros((3, 3))
        cov[:2, :2] = a_inv + var_h * np.outer(g, g)
        cov[:2, 2] = cov[2, :2] = var_h * g
        cov[2, 2] = var_h
        return np.array([p[0], p[1], head_pred[2]]), True, cov

    def _head_to_base(self, cov_head: NDArray[np.float64], head_heading: float) -> NDArray[np.float64]:
        """Covariance of base_link = head (+) mount^-1 from the head's (first order in the heading)."""
        t = inverse(self.mount)
        s, c = math.sin(head_heading), math.cos(head_heading)
        jac = np.eye(3)
        jac[0, 2], jac[1, 2] = -s * t[0] - c * t[1], c * t[0] - s * t[1]
        return np.asarray(jac @ cov_head @ jac.T, dtype=np.float64)


class BatchMLEstimator(_FixEstimator):
    """Motion-compensated maximum-likelihood fix over the last revolution (:func:`batch_ml_fix`).

    Uses every identified reflection of the last ``1 / rate_hz`` seconds (at least three
    distinct reflectors), with the odometric motion between each and ``t_f``, started from
    the predicted pose.
    """

    method = "batch_ml"

    def _fix(self) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        t_f = self._entries[-1][0]
        entries = [e for e in self._entries if t_f - e[0] < 1.0 / self.rate_hz]
        if len({e[2] for e in entries}) < 3:
            return None
        rel = self._relative(entries)
        pose, cov, ok = batch_ml_fix(
            self._x, np.array([e[1] for e in entries]), *self._reflectors(entries),
            rel, self.mount, self._variances(self._x, entries, rel),
        )
        return (pose, cov) if ok else None
