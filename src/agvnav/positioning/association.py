"""The streaming estimator's association part: which reflector made an anonymous reflection.

:class:`BearingAssociation` holds the map as the compiled gate reads it, the claim times
(a reflector is claimed once per sweep, 3/4 of a revolution) and the line-of-sight mask,
and gates one bearing against every candidate reflector with the chi-square test of
:func:`~agvnav.positioning.bearing_gate.gate_reflection` (one kernel call,
:func:`~agvnav.positioning._fast.gate_rows`; on maps of ``INDEX_MIN_REFLECTORS`` or more
reflectors only the candidates of a :class:`~agvnav.positioning.gating.BearingIndex`
are evaluated). A consider filter's gate takes the Schmidt-Kalman ``S``
(:mod:`agvnav.positioning.ekf`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Sequence

import numpy as np
from numpy.typing import NDArray

from agvnav.positioning import _fast
from agvnav.positioning.bearing_gate import Association
from agvnav.positioning.gating import INDEX_MIN_REFLECTORS, BearingIndex, GateSpec
from agvnav.positioning.integrity import reflectors_in_sight

__all__ = ["BearingAssociation"]

Flat = tuple[float, ...]
_NO_M = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
_NO_C = np.zeros((0, 6))


class BearingAssociation:
    """Gate, claims and sight of the reflectors for one estimator.

    ``spec`` the :class:`~agvnav.positioning.gating.GateSpec`; ``survey_var (N,)`` the survey
    variances a consider gate adds per reflector (None otherwise); ``walls (M, 2, 2)`` the
    map walls that hide reflectors (None: every reflector is in sight); ``max_range`` (m);
    ``sweep`` one revolution (s).
    """

    def __init__(
        self, reflector_xy: NDArray[np.float64], radius: NDArray[np.float64], mount: NDArray[np.float64],
        spec: GateSpec, bearing_var: float, survey_var: NDArray[np.float64] | None,
        walls: NDArray[np.float64] | None, max_range: float, sweep: float,
    ) -> None:
        self.reflector_xy, self.reflector_radius, self.mount = reflector_xy, radius, mount
        self.spec = spec
        self.walls, self.max_range, self.sweep = walls, max_range, sweep
        self.rows = _fast.reflector_rows(reflector_xy, radius)
        self.mount_t = tuple(float(v) for v in mount)
        self.index = BearingIndex(reflector_xy, radius, mount, spec) if len(self.rows) >= INDEX_MIN_REFLECTORS \
            else None
        self.grid_consts = None if self.index is None else self.index.grid_constants()
        self.consts = _fast.gate_constants(spec, self.mount_t, self.grid_consts, bearing_var)
        self.table = _fast.gate_table(self.rows, survey_var)
        self.grid = (np.zeros(2, np.int64), np.zeros(0, np.int64)) if self.index is None else self.index.grid_cells()
        self.in_sight_all = np.ones(len(self.rows), dtype=np.bool_)
        self.claimed = np.full(len(self.rows), -math.inf)  # claim times (s); an array for gate_rows
        self._sight_mask: NDArray[np.bool_] | None = None
        self._sight_t = -math.inf
        self._wide_spec: GateSpec | None = None
        self._wide_index: BearingIndex | None = None

    def reset_claims(self, excluded: Iterable[int] = ()) -> None:
        """No reflector claimed, the ``excluded`` ones claimed forever."""
        self.claimed = np.full(len(self.rows), -math.inf)
        self.exclude(excluded)

    def exclude(self, excluded: Iterable[int]) -> None:
        """Never associate these reflectors again (claimed forever: outside every sweep)."""
        for j in excluded:
            self.claimed[j] = math.inf

    def sight(self, t: float, x: Flat) -> NDArray[np.bool_] | None:
        """``(N,)`` bool: the reflectors in sight of the head at pose ``x``, refreshed once per revolution.

        The goniometer's line-of-sight test (walls, racks and other reflectors hide a
        reflector); None without walls. A reflector hidden behind a rack cannot have made a
        reflection, so it is no candidate: in the racked warehouse aisles the hidden
        reflectors lie within a degree of the visible ones down the aisle and made half of
        each revolution's reflections ambiguous.
        """
        walls = self.walls
        if walls is None or walls.shape[0] == 0 or not math.isfinite(x[0] + x[1] + x[2]):
            return None
        if self._sight_mask is None or not 0.0 <= t - self._sight_t < self.sweep:
            c, sn = math.cos(x[2]), math.sin(x[2])
            mx, my = self.mount_t[0], self.mount_t[1]
            head = (x[0] + c * mx - sn * my, x[1] + sn * mx + c * my)
            self._sight_mask = reflectors_in_sight(self.reflector_xy, self.reflector_radius, head, walls,
                                                   self.max_range)
            self._sight_t = t
        return self._sight_mask

    def gate(self, t: float, z: float, x: Flat, P: Flat, M: Flat = _NO_M,
             C: NDArray[np.float64] = _NO_C) -> Association:
        """Gate bearing ``z`` (rad) at ``t`` (s) for pose ``x``, covariance ``P`` (consider factors ``M, C``)."""
        sight = self.sight(t, x)
        j, y, nis, n_in, h0, h1, h2, S, R = _fast.gate_rows(
            z, t, x, P, M, C, self.claimed, self.in_sight_all if sight is None else sight,
            self.table, self.consts, *self.grid,
        )
        return Association(j, y, nis, n_in, np.array((h0, h1, h2)), S, R)

    def gate_at(
        self, t: float, z: float, x: Flat, P: Flat, consider: tuple[Flat, NDArray[np.float64], Sequence[float]] | None,
        claimed: Sequence[float] | NDArray[np.float64] | None = None, spec: GateSpec | None = None,
        candidates: Iterable[int] | None = None,
    ) -> tuple[int, float, float, int, tuple[float, float, float], float, float]:
        """:func:`~agvnav.positioning._fast.gate_one` for a pose other than the filter's (late, attribution)."""
        return _fast.gate_one(z, x, P, self.mount_t, self.rows, self.spec if spec is None else spec,
                              self.claimed if claimed is None else claimed, t, candidates, consider)

    def attribution(
        self, t: float, z: float, x: Flat, P: Flat, gate: Callable[[], float],
        consider: tuple[Flat, NDArray[np.float64], Sequence[float]] | None,
    ) -> tuple[int, float, float, tuple[float, float, float]] | None:
        """The one unseen reflector in sight a rejected bearing falls on with the wider gate ``gate()``, or None.

        Over every reflector in sight but the excluded ones, claimed in this sweep or not:
        when exactly one lies inside and it is not yet claimed in the sweep, returns its
        ``(j, y, S, H)`` (for the integrity monitor's RAIM only; the filter never uses it).
        """
        spec = self._wide_spec
        if spec is None:
            spec = self._wide_spec = dataclasses.replace(self.spec, gate=gate())
            if self.index is not None:
                self._wide_index = BearingIndex(self.reflector_xy, self.reflector_radius, self.mount, spec)
        cand = None if self._wide_index is None else self._wide_index.candidates(z, x, P)
        sight = self.sight(t, x)
        if sight is not None:
            cand = [j for j in (range(len(self.rows)) if cand is None else cand) if sight[j]]
        seen_or_not = [math.inf if c == math.inf else -math.inf for c in self.claimed]  # excluded: forever
        j, y, _, _, H, S, _ = self.gate_at(t, z, x, P, consider, seen_or_not, spec, cand)
        if j >= 0 and not t - self.claimed[j] < spec.sweep:
            return j, y, S, H
        return None
