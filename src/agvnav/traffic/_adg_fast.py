"""The ADG's pair visit as a kernel (:func:`agvnav.traffic.adg.build_adg`): order of passage and latest giving-up.

Occupations are rows of arrays (vehicle index, planned ``[t0, t1]`` in s, acquire and release events);
``members[indptr[q]:indptr[q + 1]]`` lists, in the plans' order, the occupations whose resource conflicts
with resource key ``q`` (a model and a resource), and ``key_of[b]`` is occupation ``b``'s own key (-1:
nothing conflicts with it). For every ``b`` in order and every ``a`` of its list held by another
vehicle, the one planned first gives the order of passage; the later one's step start (an even acquire
event) waits for the first one's release. Per (later vehicle, its event, first vehicle) the latest release
is kept, the first met among equals (the dependency's resource is the later occupation's); slots are
numbered in the order their keys are first met. The first invalid pair stops the visit: overlapping
times (code 1) or a wait on a vehicle that parks holding the resource (code 2).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from agvnav._jit import jit

__all__ = ["visit_pairs"]


@jit
def visit_pairs(indptr: NDArray[np.int64], members: NDArray[np.int64], key_of: NDArray[np.int64],
                veh: NDArray[np.int64], t0: NDArray[np.float64], t1: NDArray[np.float64], acq: NDArray[np.int64],
                rel: NDArray[np.int64], slot_base: NDArray[np.int64], n_veh: int, never: int,
                best_rel: NDArray[np.int64], best_later: NDArray[np.int64], best_first: NDArray[np.int64],
                order: NDArray[np.int64], bad: NDArray[np.int64]) -> int:
    """Fill the kept dependencies per slot ``(slot_base[later vehicle] + event) * n_veh + first vehicle``
    (``order`` -1 where none); return how many slots were filled; ``bad``: code and the pair, or 0 (module doc)."""
    count = 0
    for b in range(len(key_of)):
        q = key_of[b]
        if q < 0:
            continue
        for p in range(indptr[q], indptr[q + 1]):
            a = members[p]
            if veh[a] == veh[b]:
                continue
            if t1[a] <= t0[b]:
                first, later = a, b
            elif t1[b] <= t0[a]:
                first, later = b, a
            else:
                bad[0], bad[1], bad[2] = 1, a, b
                return count
            if acq[later] < 0 or acq[later] % 2 == 1:
                continue
            if rel[first] >= never:
                bad[0], bad[1], bad[2] = 2, first, later
                return count
            slot = (slot_base[veh[later]] + acq[later]) * n_veh + veh[first]
            if order[slot] < 0:
                order[slot] = count
                count += 1
                best_rel[slot], best_later[slot], best_first[slot] = rel[first], later, first
            elif best_rel[slot] < rel[first]:
                best_rel[slot], best_later[slot], best_first[slot] = rel[first], later, first
    return count
