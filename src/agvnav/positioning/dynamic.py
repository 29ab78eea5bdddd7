"""Fixes for a moving vehicle from bearings taken at different instants (seeds 000 §2.2, 001 §2).

A rotating head sees each reflector at its own instant while the vehicle moves, so
"the angles theta_i must be known for one and the same configuration of the robot"
(seed 000 §2.2). Three ways to form a fix at the instant ``t_f`` of the latest
identified reflection, given the odometric pose of base_link at every reflection:

* :class:`NaiveEstimator` -- triangulate three recent bearings as if simultaneous
  (the baseline that shows the problem);
* :class:`AnglePropagationEstimator` -- the seeds' method: simulate the evolution of
  each relative angle from its reflection to ``t_f`` with the kinematics and odometry
  (:func:`~agvnav.positioning.bearing_propagation.propagate_bearings`), then triangulate
  with absolute angles (seed 000 §2.3), or choose the fix by its predicted error
  (:mod:`agvnav.positioning.fix_switch`, seed 000 §5);
* :class:`BatchMLEstimator` -- every bearing of the last revolution with the odometry
  between them, solved jointly for the pose at ``t_f`` by Gauss-Newton
  (:func:`~agvnav.positioning.bearing_propagation.batch_ml_fix`), the maximum-likelihood
  fix when odometry over one revolution is taken as exact.

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

from agvnav.geometry import between, compose, inverse, wrap_angle
from agvnav.positioning.bearing_propagation import batch_ml_fix, centre_bearings, ml_system, propagate_bearings
from agvnav.positioning.bounds import crlb, fisher_information
from agvnav.positioning.edge_bearing import bearing_model, measurement_variance
from agvnav.positioning.estimator import StreamingEstimator
from agvnav.positioning.fix_switch import fix_given_heading, near_critical_circle, predicted_position_variances
from agvnav.positioning.plausibility import sound_state
from agvnav.positioning.triangulation import triangulate

__all__ = ["AnglePropagationEstimator", "BatchMLEstimator", "NaiveEstimator"]

#: A fix whose Mahalanobis distance from the prediction exceeds this (chi-square, 3 dof, false
#: alarm 1e-9: 6.7 sigma; ``scipy.stats.chi2.isf(1e-9, 3)``, a literal so that importing agvnav
#: does not import scipy.stats, issue 11) is refused (:meth:`_FixEstimator._plausible_fix`).
FIX_GATE = 44.841275330562404


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
        A, _ = ml_system(pose, z, *self._reflectors(entries), rel, self.mount)
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
