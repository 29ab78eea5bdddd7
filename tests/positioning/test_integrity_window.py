"""The integrity monitor's window store and its one-pass sums (issue 11: a 256-reflector window in NumPy)."""

from __future__ import annotations

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
