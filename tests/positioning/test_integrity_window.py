"""The integrity monitor's window store and its one-pass sums (issue 11: a 256-reflector window in NumPy)."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from agvnav import _jit
from agvnav.positioning.integrity import _Window, _window_tally

WIDTH = 20


def _rows(n: int, seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    rows = rng.normal(size=(n, WIDTH))
    rows[:, 0] = np.arange(n) * 0.01
    rows[:, 2] = rng.integers(0, 12, n)
    rows[:, [7, 8, 14]] = rng.integers(0, 2, (n, 3))
    return rows


def test_the_window_keeps_its_rows_in_order_through_pops_and_filters() -> None:
    rows = _rows(700)
    w = _Window()
    for r in rows:
        w.append(tuple(r))
    for _ in range(400):  # past the compaction threshold
        w.popleft()
    assert len(w) == 300 and w.first_t() == rows[400, 0]
    assert np.array_equal(w.rows(), rows[400:]) and w.row(5) == rows[405].tolist()
    assert w.indices() == rows[400:, 2].astype(int).tolist()
    w.keep(rows[400:, 2] != 3)
    assert np.array_equal(w.rows(), rows[400:][rows[400:, 2] != 3])
    w.clear()
    assert len(w) == 0 and w.rows().shape == (0, WIDTH)


@pytest.mark.parametrize("on", [False, True])
def test_the_tally_is_the_plain_loop_s_sums(on: bool) -> None:
    rows = _rows(500)
    w = _Window()
    for r in rows:
        w.append(tuple(r))
    for _ in range(300):
        w.popleft()
    live = rows[300:]
    excluded = np.zeros(12, dtype=np.int64)
    excluded[4] = 1
    t, window_s, rev = 5.0, 1.2, 0.3
    before = _jit.compiled()
    try:
        _jit.set_compiled(on)
        buf, start = w.buffer()
        count, first, nis, innov, newest, corr, late = _window_tally(buf, start, len(w), t, window_s, rev, excluded)
    finally:
        _jit.set_compiled(before)
    for j in range(12):
        mine = live[live[:, 2] == j]
        assert count[j] == len(mine)
        assert first[j] == (np.flatnonzero(live[:, 2] == j)[0] if len(mine) else -1)
        total = 0.0
        for v in mine[:, 1]:
            total += v
        assert nis[j] == total  # in window order, bit for bit
        sel = mine[(mine[:, 14] != 0) & (t - mine[:, 0] <= window_s)] if j != 4 else mine[:0]
        assert innov[j, 5] == len(sel)
        assert np.allclose(innov[j, :5], sel[:, 15:20].sum(axis=0), rtol=1e-12, atol=1e-12)
        recent = np.flatnonzero((live[:, 2] == j) & (t - live[:, 0] <= rev))
        assert newest[j] == (recent[-1] if len(recent) else -1)
    with_c = live[live[:, 8] != 0]
    assert corr[5] == len(with_c) and np.allclose(corr[:5], with_c[:, 9:14].sum(axis=0), rtol=1e-12, atol=1e-12)
    assert late == int(np.count_nonzero(live[:, 7] == 0))


def test_drop_older_keeps_the_rows_within_the_window() -> None:
    rows = _rows(900)
    rows[:, 0] = np.arange(900) / 128.0  # stamps 1/128 s apart, exact in binary
    w = _Window()
    for k, r in enumerate(rows):
        w.append(tuple(r))
        w.drop_older(float(r[0]), 1.0)
        assert w.first_t() == rows[max(0, k - 128), 0]  # 1.0 s back: 128 rows, the row at exactly 1 s stays
    assert np.array_equal(w.rows(), rows[-129:])
    w.drop_older(100.0, 1.0)
    assert len(w) == 0


def test_the_in_range_count_is_hypot_s_on_the_boundary() -> None:
    """Reflectors exactly at, just inside and just outside max_range: counted as math.hypot decides."""
    import math

    from agvnav.positioning.integrity import IntegrityMonitor

    rng = np.random.default_rng(8)
    ang = rng.uniform(-math.pi, math.pi, 400)
    dist = 7.5 * (1.0 + rng.choice([-1e-15, 0.0, 1e-15, -1e-3, 1e-3, 0.5, -0.5], 400))
    xy = np.column_stack([1.0 + dist * np.cos(ang), 2.0 + dist * np.sin(ang)])
    mon = IntegrityMonitor(xy, np.full(400, 0.04), np.zeros(3), 1e-3, 0.125, max_range=7.5)
    want = sum(math.hypot(x - 1.0, y - 2.0) <= 7.5 for x, y in xy.tolist())
    assert 0 < want < 400 and mon._in_range(1.0, 2.0) == want
    mon.excluded = (int(np.argmin(dist)),)
    assert mon._in_range(1.0, 2.0) == want - 1
    assert mon._in_range(math.nan, 2.0) == 0


def _fresh(w: _Window) -> np.ndarray:
    """The window's rows read afresh from its flat buffer (no cached copy)."""
    return np.array(w._flat[w._head * WIDTH:], dtype=np.float64)


@pytest.mark.usefixtures("restore_jit_mode")
def test_the_compiled_buffer_copy_follows_every_change_of_the_window() -> None:
    """Each way the window changes (append, the monitor's inlined extend, drop_older, popleft and its
    compaction, keep, clear) voids the copy :meth:`_Window.buffer` hands the compiled kernels."""
    _jit.set_compiled(True)
    rows = _rows(900)
    w = _Window()
    steps = 0

    def same() -> None:
        nonlocal steps
        buf, start = w.buffer()
        assert start == 0 and buf.tobytes() == _fresh(w).tobytes()
        again, _ = w.buffer()
        assert again is buf  # unchanged window: the copy is reused
        steps += 1

    same()
    for k in range(600):
        if k % 3:
            w.append(tuple(rows[k]))
        else:
            w._flat.extend(rows[k])  # as IntegrityMonitor.accepted does
        same()
        if k % 7 == 0:
            w.popleft()
            same()
    compacted = False
    while len(w) > 200:  # past the compaction (head >= 256 and half the buffer dropped)
        head = w._head
        w.popleft()
        compacted |= w._head < head
        same()
    assert compacted
    w.drop_older(float(rows[599, 0]), 1.0)  # stamps 0.01 s apart: 100 rows stay
    assert len(w) == 101
    same()
    w.clear()
    same()
    for r in rows[600:700]:
        w.append(tuple(r))  # as many rows as before the clear could leave the same length and head
    same()
    w.keep(w.rows()[:, 2] != 5)
    same()
    w.keep(np.ones(len(w), dtype=bool))
    same()
    w.clear()
    for r in rows[:10]:
        w.append(tuple(r))
    same()
    w.clear()  # the same length and head as before, other rows
    for r in rows[10:20]:
        w.append(tuple(r))
    same()
    w.keep(np.arange(10) != 4)
    w.append(tuple(rows[30]))  # the same length and head again
    same()
    assert steps > 900


@pytest.mark.usefixtures("restore_jit_mode")
@pytest.mark.parametrize("on", [False, True])
def test_the_offset_inside_a_check_that_excludes_a_reflector_reads_the_window_afresh(on: bool) -> None:
    """The RAIM excludes a biased reflector in mid-check (``_drop`` rewrites the window); the common offset
    the same check computes afterwards is the one a fresh monitor call gives on the window left."""
    from agvnav.positioning import bearing_model
    from agvnav.positioning._integrity_fast import revolution_offset
    from agvnav.positioning.integrity import IntegrityLimits, IntegrityMonitor

    _jit.set_compiled(on)
    xy = np.array([[9.0, 3.0], [4.0, 9.0], [-1.0, 4.0], [5.0, -2.0], [8.0, 8.0], [0.0, -1.0], [9.0, -1.0]])
    pose, std, n = np.array([4.0, 3.0, 0.3]), 1e-3, 7
    mon = IntegrityMonitor(xy, np.zeros(n), np.zeros(3), std, 0.125, IntegrityLimits(max_latency_s=1.0))
    h = bearing_model(pose, np.zeros(3), xy, np.zeros(n))[0]
    d = xy - pose[:2]
    d2 = np.sum(d * d, axis=1)
    H = np.column_stack([d[:, 1] / d2, -d[:, 0] / d2, -np.ones(n)])
    seen: list[tuple[bool, object, object]] = []
    raim, offset = mon._raim_failures, mon.offset

    def raim_spy(t: float, sums: object = None) -> list[str]:
        before = mon.excluded
        out = raim(t, sums)  # type: ignore[arg-type]
        mon._dropped_now = mon.excluded != before  # type: ignore[attr-defined]
        return out

    def offset_spy(t: float) -> object:
        got = offset(t)
        flat = mon._entries.rows().reshape(-1)  # the window as it is now, copied afresh
        flags = np.zeros(n, dtype=np.int64)
        flags[list(mon.excluded)] = 1
        ok, dx0, dx1, dx2, stat = revolution_offset(flat, 0, len(mon._entries), t, mon.revolution_s, flags,
                                                    np.zeros((0, 7)), 0, mon._tables[3], std**2)
        want = (np.array([dx0, dx1, dx2]), stat) if ok else None
        seen.append((mon._dropped_now, got, want))  # type: ignore[attr-defined]
        return got

    mon._raim_failures = raim_spy  # type: ignore[method-assign]
    mon.offset = offset_spy  # type: ignore[method-assign]
    rng = np.random.default_rng(7)
    for k in range(40 * n):
        i = k % n
        if i in mon.excluded:
            continue
        t = (k + 1) * 0.125 / n
        y = rng.normal(0.0, std) + (8 * std if i == 2 else 0.0)
        mon.accepted(t, y * y / std**2, i, float(h[i]), (0.0, 0.0, 0.0), None, (y, std**2, *H[i]))
        if mon.due(t):
            mon.check(t, pose, np.diag([1e-4, 1e-4, 1e-5]), (0.0, 0.0, 0.0), False)
    assert mon.excluded == (2,)
    dropped = [s for s in seen if s[0]]
    assert len(dropped) == 1 and len(seen) > 20
    for _, got, want in seen:
        assert (got is None) == (want is None)
        if got is not None and want is not None:
            assert got[0].tobytes() == want[0].tobytes() and float(got[1]).hex() == float(want[1]).hex()


@pytest.mark.usefixtures("restore_jit_mode")
@pytest.mark.parametrize("on", [False, True])
def test_the_tally_s_innovations_are_revolution_innovations_over_the_window(on: bool) -> None:
    """The one-pass tally sums the innovations as ``revolution_innovations`` does (its time bound ``window_s``,
    no attributed sightings): the two loops kept apart (one pass over the window each) give the same bits."""
    from agvnav.positioning._integrity_fast import revolution_innovations

    _jit.set_compiled(on)
    rng = np.random.default_rng(12)
    for _ in range(50):
        rows = _rows(int(rng.integers(0, 400)), int(rng.integers(0, 1000)))
        rows[:, 0] = np.sort(rng.uniform(3.0, 5.0, rows.shape[0]))
        excluded = (rng.uniform(size=12) < 0.2).astype(np.int64)
        buf = rows.reshape(-1) if on else rows.reshape(-1).tolist()
        window_s = float(rng.uniform(0.2, 1.5))
        tally = _window_tally(buf, 0, rows.shape[0], 5.0, window_s, 0.125, excluded)
        att = np.zeros((0, 7)) if on else []
        want = revolution_innovations(buf, 0, rows.shape[0], 5.0, window_s, excluded, att, 0)
        assert tally[3].tobytes() == want.tobytes()


@pytest.mark.usefixtures("restore_jit_mode")
@pytest.mark.parametrize("on", [True, False])
def test_the_window_grows_while_a_profiler_holds_its_frames(on: bool) -> None:
    """A sampling profiler keeps the frames it took alive, with their locals: the window must still grow.

    Dask's worker profiler takes the running thread's stack every 10 ms; an ``np.frombuffer`` view
    of the live buffer left in such a frame made the next append raise BufferError (a campaign
    run's outcome ``error`` now and then). Here a profile hook keeps every returning frame.
    """
    _jit.set_compiled(on)
    w = _Window()
    for k in range(5):
        w.append((float(k),) + (0.5,) * (WIDTH - 1))
    held: list[object] = []

    def keep(frame: object, event: str, arg: object) -> None:
        if event == "return":
            held.append(frame)

    sys.setprofile(keep)
    try:
        buf, start = w.buffer()
        rows = w.rows()
    finally:
        sys.setprofile(None)
    assert held
    w.append((5.0,) + (0.5,) * (WIDTH - 1))  # BufferError while a held frame had a view of the buffer
    w.drop_older(5.0, 2.5)
    assert len(w) == 3 and w.first_t() == 3.0
    assert [buf[start + k * WIDTH] for k in range(5)] == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert rows[:, 0].tolist() == [0.0, 1.0, 2.0, 3.0, 4.0]


def test_window_rows_are_typed_records_with_named_fields() -> None:
    """:func:`window_row` builds a row by name; :meth:`_Window.records` reads it back by name."""
    from agvnav.positioning.integrity_window import WINDOW_DTYPE, WINDOW_FIELDS, window_row

    assert len(WINDOW_FIELDS) == WIDTH and WINDOW_DTYPE.itemsize == 8 * WIDTH
    w = _Window()
    w.append(window_row(1.5, 0.7, 4, 0.25, (1.0, 2.0, 0.3), True, (0.01, -0.02, 1e-4, 2e-5, 3e-4), None))
    w.append(window_row(1.6, 1.2, 9, -0.5, (1.1, 2.0, 0.31), False, None, (1e-3, 4e-6, 0.1, -0.2, -1.0)))
    rec = w.records()
    assert rec.dtype == WINDOW_DTYPE and rec.shape == (2,)
    np.testing.assert_array_equal(rec["t"], [1.5, 1.6])
    np.testing.assert_array_equal(rec["reflector"], [4, 9])
    np.testing.assert_array_equal(rec["on_time"], [1.0, 0.0])
    assert (rec["has_correction"][0], rec["dx"][0], rec["dP11"][0]) == (1.0, 0.01, 3e-4)
    assert (rec["has_innovation"][1], rec["y"][1], rec["S"][1], rec["H2"][1]) == (1.0, 1e-3, 4e-6, -1.0)
    assert rec["has_correction"][1] == 0.0 and rec["has_innovation"][0] == 0.0
    np.testing.assert_array_equal(rec.view(np.float64).reshape(2, WIDTH), w.rows())
