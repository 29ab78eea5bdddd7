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

__all__ = ["chain_occupations", "dijkstra_to", "release", "release_held", "reserve", "safe_intervals", "scratch_size",
           "sipp"]

_TWO_PI = 2.0 * math.pi


@jit
def dijkstra_to(goal: int, rev_ptr: NDArray[np.int64], rev_from: NDArray[np.int64], rev_w: NDArray[np.float64],
                n: int) -> NDArray[np.float64]:
    """Static shortest drive time (s) from every node to ``goal`` over the reversed traversals (inf: none).

    The queue is a binary heap of nodes on arrays with each node's place in it (a node is queued once and
    moved up when its time improves): no tuples, no stale entries.
    """
    dist = np.full(n, np.inf)
    heap = np.empty(n, np.int64)
    place = np.full(n, -1, np.int64)  # -1: never queued, -2: settled
    dist[goal] = 0.0
    heap[0] = goal
    place[goal] = 0
    size = 1
    while size > 0:
        u = heap[0]
        place[u] = -2
        size -= 1
        if size > 0:
            _heap_down(heap, place, dist, size, heap[size])
        d = dist[u]
        for i in range(rev_ptr[u], rev_ptr[u + 1]):
            v = rev_from[i]
            nd = d + rev_w[i]
            if nd < dist[v] and place[v] != -2:
                dist[v] = nd
                if place[v] == -1:
                    place[v] = size
                    size += 1
                _heap_up(heap, place, dist, place[v], v)
    return dist


@jit
def _heap_up(heap: NDArray[np.int64], place: NDArray[np.int64], key: NDArray[np.float64], i: int, x: int) -> None:
    """Put node ``x`` at heap place ``i`` or above, moving the parents with larger keys down."""
    kx = key[x]
    while i > 0:
        p = (i - 1) >> 1
        y = heap[p]
        if key[y] <= kx:
            break
        heap[i] = y
        place[y] = i
        i = p
    heap[i] = x
    place[x] = i


@jit
def _heap_down(heap: NDArray[np.int64], place: NDArray[np.int64], key: NDArray[np.float64], size: int, x: int
               ) -> None:
    """Put node ``x`` at the root's place or below (a heap of ``size``), moving smaller children up."""
    kx = key[x]
    i = 0
    while True:
        c = 2 * i + 1
        if c >= size:
            break
        if c + 1 < size and key[heap[c + 1]] < key[heap[c]]:
            c += 1
        y = heap[c]
        if key[y] >= kx:
            break
        heap[i] = y
        place[y] = i
        i = c
    heap[i] = x
    place[x] = i


@jit
def reserve(conf_ptr: NDArray[np.int64], conf_idx: NDArray[np.int64], qs: NDArray[np.int64],
            t0s: NDArray[np.float64], t1s: NDArray[np.float64], owner: int, b0: NDArray[np.float64],
            b1: NDArray[np.float64], bo: NDArray[np.int64], bn: NDArray[np.int64]) -> int:
    """Reserve every occupation ``(qs[i], t0s[i], t1s[i])``; the index of the first that did not fit (the
    capacity ``b0.shape[1]`` is reached: grow and call again from there), ``len(qs)`` when all did.

    A busy interval that overlaps or touches the one of the same owner just before it on a resource
    extends that one (their union: the same busy time in fewer intervals, so shorter rows to search;
    a vehicle's occupations come in time order and hold each conflict row over consecutive steps).
    """
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
                j -= 1
            if j > 0 and bo[r, j - 1] == owner and b1[r, j - 1] >= t0:
                if t1 > b1[r, j - 1]:  # the owner's busy interval just before goes on: one interval, not two
                    b1[r, j - 1] = t1
                continue
            for x in range(bn[r], j, -1):
                b0[r, x] = b0[r, x - 1]
                b1[r, x] = b1[r, x - 1]
                bo[r, x] = bo[r, x - 1]
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
def release_held(conf_ptr: NDArray[np.int64], conf_idx: NDArray[np.int64], qs: NDArray[np.int64], owner: int,
                 b0: NDArray[np.float64], b1: NDArray[np.float64], bo: NDArray[np.int64], bn: NDArray[np.int64]
                 ) -> None:
    """Forget ``owner``'s reservations of every resource made busy by holding one of ``qs`` (:func:`release`
    on their conflict rows)."""
    for q in qs:
        release(conf_idx[conf_ptr[q]:conf_ptr[q + 1]], owner, b0, b1, bo, bn)


@jit
def chain_occupations(tr: NDArray[np.int64], dep: NDArray[np.float64], t: NDArray[np.float64],
                      tr_src: NDArray[np.int64], tr_dst: NDArray[np.int64], tr_res: NDArray[np.int64], start: int,
                      ready_s: float) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """The occupations ``(resource, t0, t1)`` of the chain :func:`sipp` returned, in time order: the start node
    until the first step, each step's source node, edge and target node over its drive, the target node
    from the arrival to the next step when the vehicle stands there (inf after the last step: it parks)."""
    steps = np.flatnonzero(tr >= 0)
    n = len(steps)
    q, t0, t1 = np.empty(1 + 4 * n, np.int64), np.empty(1 + 4 * n), np.empty(1 + 4 * n)
    q[0], t0[0], t1[0] = start, ready_s, dep[steps[0]] if n > 0 else math.inf
    m = 1
    for i in range(n):
        s = steps[i]
        e = tr[s]
        for r in (tr_src[e], tr_res[e], tr_dst[e]):
            q[m], t0[m], t1[m] = r, dep[s], t[s]
            m += 1
        nxt = dep[steps[i + 1]] if i + 1 < n else math.inf
        if nxt > t[s]:
            q[m], t0[m], t1[m] = tr_dst[e], t[s], nxt
            m += 1
    return q[:m], t0[:m], t1[:m]


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
         max_expansions: int, best_at: NDArray[np.int64], iv_at: NDArray[np.int64]
         ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64], int]:
    """SIPP over all goals in turn (``goal_mode`` 2: any direction); the chain of states from the start.

    Returns ``(tr, t_dep, t, expansions)``: per state of the chain, the traversal driven to it (-1: a
    goal reached and left, -2: the start) with its departure, and the state's time (s); empty arrays
    when the goals cannot all be reached within ``max_expansions``.

    ``best_at`` (at least :func:`scratch_size` long) and ``iv_at`` (one per node) are scratch tables kept
    by the caller from one search to the next, all -1 on entry and left so: the search touches the
    entries of the nodes it reaches only, so it costs no table the size of the network per call.
    """
    n_nodes = len(cls_ptr) - 1
    out = _search(out_ptr, tr_dst, tr_dur, tr_k0, tr_k1, tr_mode, tr_res, cls_ptr, cls_h, turn_rate, turns_on_spot,
                  cusp_s, goal_node, goal_dwell, goal_nb, goal_mode, h, rest, b0, b1, bn, start, k_start, ready_s,
                  max_expansions, best_at, iv_at)
    n_cls = _n_classes(cls_ptr)
    for node in range(n_nodes):
        if iv_at[node] >= 0:
            iv_at[node] = -1
            for gi in range(len(goal_node) + 1):
                row = (gi * n_nodes + node) * n_cls * 3
                best_at[row:row + n_cls * 3] = -1
    return out


@jit
def _n_classes(cls_ptr: NDArray[np.int64]) -> int:
    """Heading classes per node plus one (no class: a vehicle without heading at its start), at most."""
    n_cls = 1
    for i in range(len(cls_ptr) - 1):
        n_cls = max(n_cls, cls_ptr[i + 1] - cls_ptr[i] + 1)
    return n_cls


@jit
def scratch_size(cls_ptr: NDArray[np.int64], n_goals: int) -> int:
    """Length of the ``best_at`` scratch table :func:`sipp` needs for ``n_goals`` goals."""
    return (n_goals + 1) * (len(cls_ptr) - 1) * _n_classes(cls_ptr) * 3


@jit
def _search(out_ptr: NDArray[np.int64], tr_dst: NDArray[np.int64], tr_dur: NDArray[np.float64],
            tr_k0: NDArray[np.int64], tr_k1: NDArray[np.int64], tr_mode: NDArray[np.int64], tr_res: NDArray[np.int64],
            cls_ptr: NDArray[np.int64], cls_h: NDArray[np.float64], turn_rate: float, turns_on_spot: bool,
            cusp_s: float, goal_node: NDArray[np.int64], goal_dwell: NDArray[np.float64],
            goal_nb: NDArray[np.float64], goal_mode: NDArray[np.int64], h: NDArray[np.float64],
            rest: NDArray[np.float64], b0: NDArray[np.float64], b1: NDArray[np.float64], bn: NDArray[np.int64],
            start: int, k_start: int, ready_s: float, max_expansions: int, best_at: NDArray[np.int64],
            iv_at: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64], int]:
    """The search of :func:`sipp` (its scratch tables left dirty)."""
    n_goals = len(goal_node)
    n_nodes = len(cls_ptr) - 1
    cap = b0.shape[1] + 1
    n_cls = _n_classes(cls_ptr)
    sa, sb = np.empty(cap), np.empty(cap)
    # the safe intervals of each node, computed once per search: node -> offset into iv_a, iv_b
    iv_n = np.zeros(n_nodes, np.int64)
    iv_a, iv_b = [0.0], [0.0]
    o0 = _node_intervals(start, b0, b1, bn, iv_at, iv_n, iv_a, iv_b, sa, sb)
    iv0 = -1
    for j in range(iv_n[start]):
        if iv_a[o0 + j] <= ready_s < iv_b[o0 + j]:
            iv0 = j
    if iv0 < 0:
        return np.empty(0, np.int64), np.empty(0), np.empty(0), 0
    # the states: parent, traversal (-1 goal, -2 start), departure, time, goal, node, class, direction, interval
    s_par, s_tr, s_dep, s_t = [-1], [-2], [ready_s], [ready_s]
    s_gi, s_node, s_k, s_mode, s_iv = [0], [start], [k_start], [0], [iv0]
    # the best time of each state: a dense table of (goal, node, class, direction) -> the offset of one slot per
    # safe interval of the node in best_t (allocated on the first visit; a table, not a hash map: no hashing).
    # The hot loop below indexes these tables itself and calls a helper only on a first visit: a call that
    # passes arrays and lists costs reference counting that would outweigh the work of an expansion.
    best_t = [0.0]
    best_t[_slot(0, start, k_start, 0, iv0, n_nodes, n_cls, iv_n, best_at, best_t)] = ready_s
    heap = [(ready_s + (h[0, start] + rest[0] if n_goals > 0 else 0.0), -ready_s, 0)]
    expansions = 0
    while len(heap) > 0 and expansions < max_expansions:
        _, _, sid = heapq.heappop(heap)
        t = s_t[sid]
        gi, node, k, mode, iv = s_gi[sid], s_node[sid], s_k[sid], s_mode[sid], s_iv[sid]
        if best_t[best_at[((gi * n_nodes + node) * n_cls + (k + 1)) * 3 + (mode + 1)] + iv] < t:
            continue
        expansions += 1
        iv_end = iv_b[iv_at[node] + iv]
        if gi < n_goals and node == goal_node[gi] and (goal_mode[gi] == 2 or goal_mode[gi] == mode):
            leave = max(t, goal_nb[gi]) + goal_dwell[gi]
            last = gi + 1 == n_goals
            if (last and iv_end == math.inf) or (not last and leave <= iv_end):
                key = _slot(gi + 1, node, k, mode, iv, n_nodes, n_cls, iv_n, best_at, best_t)
                if last or leave < best_t[key]:
                    best_t[key] = leave
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
            v, dur, er, k1 = tr_dst[e], tr_dur[e], tr_res[e], tr_k1[e]
            if iv_at[v] < 0:
                _node_intervals(v, b0, b1, bn, iv_at, iv_n, iv_a, iv_b, sa, sb)
            o = iv_at[v]
            t_ready = t + prep
            row = ((gi * n_nodes + v) * n_cls + (k1 + 1)) * 3 + (m + 1)
            for j in range(iv_n[v]):
                a_j, b_j = iv_a[o + j], iv_b[o + j]
                if b_j <= t_ready:
                    continue
                td = max(t_ready, a_j)
                while td + dur <= iv_end and td < b_j:  # past every busy interval of the edge it would overlap
                    c = -1.0
                    for i in range(bn[er]):
                        if b0[er, i] >= td + dur:
                            break
                        if b1[er, i] > td and b1[er, i] > c:
                            c = b1[er, i]
                    if c < 0.0:
                        break
                    td = c
                if td + dur > iv_end:
                    break
                if td < b_j and td + dur < b_j:
                    ta_ = td + dur
                    if best_at[row] < 0:
                        _slot(gi, v, k1, m, j, n_nodes, n_cls, iv_n, best_at, best_t)
                    key = best_at[row] + j
                    if ta_ < best_t[key]:
                        best_t[key] = ta_
                        s_par.append(sid)
                        s_tr.append(e)
                        s_dep.append(td)
                        s_t.append(ta_)
                        s_gi.append(gi)
                        s_node.append(v)
                        s_k.append(k1)
                        s_mode.append(m)
                        s_iv.append(j)
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
def _slot(gi: int, node: int, k: int, mode: int, iv: int, n_nodes: int, n_cls: int, iv_n: NDArray[np.int64],
          best_at: NDArray[np.int64], best_t: list[float]) -> int:
    """Index in ``best_t`` of state ``(gi, node, k, mode, iv)``: the node's slots are added (inf) on first use;
    the node's safe intervals must be known (``iv_n``)."""
    row = ((gi * n_nodes + node) * n_cls + (k + 1)) * 3 + (mode + 1)
    at = best_at[row]
    if at < 0:
        at = len(best_t)
        best_at[row] = at
        for _ in range(iv_n[node]):
            best_t.append(math.inf)
    return at + iv


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
