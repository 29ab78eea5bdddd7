"""Kernels of the multi-vehicle planner (:mod:`agvnav.traffic.plan`) on compact integer arrays.

Resources are numbered: node ``i`` is resource ``i``, edge ``j`` (in the network's order) is
resource ``n_nodes + j``. The conflict relation of a pair of models is a CSR
(``conf_ptr``, ``conf_idx``): the resources of model ``b`` made busy by model ``a`` holding ``q``
are ``conf_idx[conf_ptr[q]:conf_ptr[q + 1]]``. Reservations of one model are three ``(R, cap)``
arrays (busy start, end in s, owner) sorted by start, and a count per resource.

The SIPP search (Phillips & Likhachev 2011) runs on states ``(goal index, node, heading class,
direction, safe interval)``; its rules are the module doc of :mod:`agvnav.traffic.plan`. Written in
the subset numba compiles (lists, dicts and ``heapq`` typed on first use) so it runs compiled or as
plain Python alike.
"""

from __future__ import annotations

import heapq
import math

import numpy as np
from numpy.typing import NDArray

from agvnav._jit import jit

__all__ = ["dijkstra_to", "release", "reserve", "safe_intervals", "sipp"]

_TWO_PI = 2.0 * math.pi


@jit
def dijkstra_to(goal: int, rev_ptr: NDArray[np.int64], rev_from: NDArray[np.int64], rev_w: NDArray[np.float64],
                n: int) -> NDArray[np.float64]:
    """Static shortest drive time (s) from every node to ``goal`` over the reversed traversals (inf: none)."""
    dist = np.full(n, np.inf)
    dist[goal] = 0.0
    heap = [(0.0, goal)]
    while len(heap) > 0:
        d, u = heapq.heappop(heap)
        if d > dist[u]:
            continue
        for i in range(rev_ptr[u], rev_ptr[u + 1]):
            v = rev_from[i]
            nd = d + rev_w[i]
            if nd < dist[v]:
                dist[v] = nd
                heapq.heappush(heap, (nd, v))
    return dist


@jit
def reserve(conf_ptr: NDArray[np.int64], conf_idx: NDArray[np.int64], qs: NDArray[np.int64],
            t0s: NDArray[np.float64], t1s: NDArray[np.float64], owner: int, b0: NDArray[np.float64],
            b1: NDArray[np.float64], bo: NDArray[np.int64], bn: NDArray[np.int64]) -> int:
    """Reserve every occupation ``(qs[i], t0s[i], t1s[i])``; the index of the first that did not fit (the
    capacity ``b0.shape[1]`` is reached: grow and call again from there), ``len(qs)`` when all did."""
    cap = b0.shape[1]
    for i in range(len(qs)):
        q = qs[i]
        for c in range(conf_ptr[q], conf_ptr[q + 1]):
            if bn[conf_idx[c]] >= cap:
                return i
        t0, t1 = t0s[i], t1s[i]
        for c in range(conf_ptr[q], conf_ptr[q + 1]):
            r = conf_idx[c]
            j = bn[r]
            while j > 0 and b0[r, j - 1] > t0:
                b0[r, j] = b0[r, j - 1]
                b1[r, j] = b1[r, j - 1]
                bo[r, j] = bo[r, j - 1]
                j -= 1
            b0[r, j] = t0
            b1[r, j] = t1
            bo[r, j] = owner
            bn[r] += 1
    return len(qs)


@jit
def release(rows: NDArray[np.int64], owner: int, b0: NDArray[np.float64], b1: NDArray[np.float64],
            bo: NDArray[np.int64], bn: NDArray[np.int64]) -> None:
    """Forget ``owner``'s reservations of the resources ``rows`` (order kept)."""
    for r in rows:
        m = 0
        for j in range(bn[r]):
            if bo[r, j] != owner:
                b0[r, m] = b0[r, j]
                b1[r, m] = b1[r, j]
                bo[r, m] = bo[r, j]
                m += 1
        bn[r] = m


@jit
def safe_intervals(b0: NDArray[np.float64], b1: NDArray[np.float64], count: int, out_a: NDArray[np.float64],
                   out_b: NDArray[np.float64]) -> int:
    """The complement on ``[0, inf)`` of the busy intervals (sorted by start) into ``out_a``, ``out_b``; how many."""
    m = 0
    t = 0.0
    for i in range(count):
        if b0[i] > t:
            out_a[m] = t
            out_b[m] = b0[i]
            m += 1
        if b1[i] > t:
            t = b1[i]
    if t < math.inf:
        out_a[m] = t
        out_b[m] = math.inf
        m += 1
    return m


@jit
def _clash_end(b0: NDArray[np.float64], b1: NDArray[np.float64], count: int, t0: float, t1: float) -> float:
    """End (s) of the latest busy interval overlapping ``[t0, t1]``; -1 when none does."""
    end = -1.0
    for i in range(count):
        if b0[i] >= t1:
            break
        if b1[i] > t0 and b1[i] > end:
            end = b1[i]
    return end


@jit
def _turn(h0: float, h1: float) -> float:
    """``|wrap(h1 - h0)|`` (rad)."""
    d = h1 - h0
    d -= _TWO_PI * math.floor((d + math.pi) / _TWO_PI)
    return abs(d)


@jit
def sipp(out_ptr: NDArray[np.int64], tr_dst: NDArray[np.int64], tr_dur: NDArray[np.float64],
         tr_k0: NDArray[np.int64], tr_k1: NDArray[np.int64], tr_mode: NDArray[np.int64], tr_res: NDArray[np.int64],
         cls_ptr: NDArray[np.int64], cls_h: NDArray[np.float64], turn_rate: float, turns_on_spot: bool,
         cusp_s: float, goal_node: NDArray[np.int64], goal_dwell: NDArray[np.float64], goal_nb: NDArray[np.float64],
         goal_mode: NDArray[np.int64], h: NDArray[np.float64], rest: NDArray[np.float64], b0: NDArray[np.float64],
         b1: NDArray[np.float64], bn: NDArray[np.int64], start: int, k_start: int, ready_s: float,
         max_expansions: int) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64], int]:
    """SIPP over all goals in turn (``goal_mode`` 2: any direction); the chain of states from the start.

    Returns ``(tr, t_dep, t, expansions)``: per state of the chain, the traversal driven to it (-1: a
    goal reached and left, -2: the start) with its departure, and the state's time (s); empty arrays
    when the goals cannot all be reached within ``max_expansions``.
    """
    n_goals = len(goal_node)
    n_nodes = len(cls_ptr) - 1
    cap = b0.shape[1] + 1
    n_cls = 1
    for i in range(n_nodes):
        n_cls = max(n_cls, cls_ptr[i + 1] - cls_ptr[i] + 1)
    sa, sb = np.empty(cap), np.empty(cap)
    # the safe intervals of each node, computed once per search: node -> offset into iv_a, iv_b
    iv_at = np.full(n_nodes, -1, np.int64)
    iv_n = np.zeros(n_nodes, np.int64)
    iv_a, iv_b = [0.0], [0.0]
    m0 = safe_intervals(b0[start], b1[start], bn[start], sa, sb)
    iv0 = -1
    for j in range(m0):
        if sa[j] <= ready_s < sb[j]:
            iv0 = j
    if iv0 < 0:
        return np.empty(0, np.int64), np.empty(0), np.empty(0), 0
    # the states: parent, traversal (-1 goal, -2 start), departure, time, goal, node, class, direction, interval
    s_par, s_tr, s_dep, s_t = [-1], [-2], [ready_s], [ready_s]
    s_gi, s_node, s_k, s_mode, s_iv = [0], [start], [k_start], [0], [iv0]
    best = dict()  # noqa: C408 - numba types an empty dict() on its first store
    best[_key(0, start, k_start, 0, iv0, n_nodes, n_cls, cap)] = ready_s
    heap = [(ready_s + (h[0, start] + rest[0] if n_goals > 0 else 0.0), -ready_s, 0)]
    expansions = 0
    while len(heap) > 0 and expansions < max_expansions:
        _, _, sid = heapq.heappop(heap)
        t = s_t[sid]
        gi, node, k, mode, iv = s_gi[sid], s_node[sid], s_k[sid], s_mode[sid], s_iv[sid]
        if best[_key(gi, node, k, mode, iv, n_nodes, n_cls, cap)] < t:
            continue
        expansions += 1
        iv_end = iv_b[_node_intervals(node, b0, b1, bn, iv_at, iv_n, iv_a, iv_b, sa, sb) + iv]
        if gi < n_goals and node == goal_node[gi] and (goal_mode[gi] == 2 or goal_mode[gi] == mode):
            leave = max(t, goal_nb[gi]) + goal_dwell[gi]
            last = gi + 1 == n_goals
            if (last and iv_end == math.inf) or (not last and leave <= iv_end):
                key = _key(gi + 1, node, k, mode, iv, n_nodes, n_cls, cap)
                if last or leave < best.get(key, math.inf):
                    best[key] = leave
                    _push_state(s_par, s_tr, s_dep, s_t, s_gi, s_node, s_k, s_mode, s_iv, sid, -1, leave, leave,
                                gi + 1, node, k, mode, iv)
                    if last:
                        tr, dep, tt = _chain(s_par, s_tr, s_dep, s_t, len(s_t) - 1)
                        return tr, dep, tt, expansions
                    heapq.heappush(heap, (leave + h[gi + 1, node] + rest[gi + 1], -leave, len(s_t) - 1))
        if gi >= n_goals:
            continue
        for e in range(out_ptr[node], out_ptr[node + 1]):
            k0, m = tr_k0[e], tr_mode[e]
            prep = 0.0
            if k != k0 and k >= 0:
                if not turns_on_spot:
                    continue
                prep += _turn(cls_h[cls_ptr[node] + k], cls_h[cls_ptr[node] + k0]) / turn_rate
            if mode != 0 and m != mode:
                prep += cusp_s
            v, dur, er = tr_dst[e], tr_dur[e], tr_res[e]
            o = _node_intervals(v, b0, b1, bn, iv_at, iv_n, iv_a, iv_b, sa, sb)
            t_ready = t + prep
            for j in range(iv_n[v]):
                a_j, b_j = iv_a[o + j], iv_b[o + j]
                if b_j <= t_ready:
                    continue
                td = max(t_ready, a_j)
                while td + dur <= iv_end and td < b_j:
                    c = _clash_end(b0[er], b1[er], bn[er], td, td + dur)
                    if c < 0.0:
                        break
                    td = c
                if td + dur > iv_end:
                    break
                if td < b_j and td + dur < b_j:
                    ta_ = td + dur
                    key = _key(gi, v, tr_k1[e], m, j, n_nodes, n_cls, cap)
                    if ta_ < best.get(key, math.inf):
                        best[key] = ta_
                        _push_state(s_par, s_tr, s_dep, s_t, s_gi, s_node, s_k, s_mode, s_iv, sid, e, td, ta_, gi, v,
                                    tr_k1[e], m, j)
                        heapq.heappush(heap, (ta_ + h[gi, v] + rest[gi], -ta_, len(s_t) - 1))
    return np.empty(0, np.int64), np.empty(0), np.empty(0), expansions


@jit
def _node_intervals(node: int, b0: NDArray[np.float64], b1: NDArray[np.float64], bn: NDArray[np.int64],
                    iv_at: NDArray[np.int64], iv_n: NDArray[np.int64], iv_a: list[float], iv_b: list[float],
                    sa: NDArray[np.float64], sb: NDArray[np.float64]) -> int:
    """Offset of ``node``'s safe intervals in ``iv_a``, ``iv_b`` (computed on the first call)."""
    if iv_at[node] < 0:
        m = safe_intervals(b0[node], b1[node], bn[node], sa, sb)
        iv_at[node] = len(iv_a)
        iv_n[node] = m
        for j in range(m):
            iv_a.append(sa[j])
            iv_b.append(sb[j])
    return iv_at[node]


@jit
def _key(gi: int, node: int, k: int, mode: int, iv: int, n_nodes: int, n_cls: int, cap: int) -> int:
    return (((gi * n_nodes + node) * n_cls + (k + 1)) * 3 + (mode + 1)) * cap + iv


@jit
def _push_state(s_par: list[int], s_tr: list[int], s_dep: list[float], s_t: list[float], s_gi: list[int],
                s_node: list[int], s_k: list[int], s_mode: list[int], s_iv: list[int], parent: int, tr: int,
                dep: float, t: float, gi: int, node: int, k: int, mode: int, iv: int) -> None:
    s_par.append(parent)
    s_tr.append(tr)
    s_dep.append(dep)
    s_t.append(t)
    s_gi.append(gi)
    s_node.append(node)
    s_k.append(k)
    s_mode.append(mode)
    s_iv.append(iv)


@jit
def _chain(s_par: list[int], s_tr: list[int], s_dep: list[float], s_t: list[float], end: int
           ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    n = 0
    i = end
    while i >= 0:
        n += 1
        i = s_par[i]
    tr, dep, t = np.empty(n, np.int64), np.empty(n), np.empty(n)
    i = end
    for j in range(n - 1, -1, -1):
        tr[j], dep[j], t[j] = s_tr[i], s_dep[i], s_t[i]
        i = s_par[i]
    return tr, dep, t
