"""Block recorder and decimated recording (issue 11, memory of long runs)."""

from __future__ import annotations

import numpy as np
import pytest

from agvnav.sim.build import build
from agvnav.sim.engine import MAX_RECORDED_ROWS, record_stride
from agvnav.sim.recorder import EventLog, Recorder
from agvnav.world.scenario import default_scenario


def test_recorder_grows_by_blocks_and_reads_back_every_row() -> None:
    rec = Recorder(("a", "b", "c"), 4)
    rows = np.arange(33.0).reshape(11, 3)
    for row in rows:
        rec.append(tuple(row))
    assert rec.n == len(rec) == 11
    np.testing.assert_array_equal(rec.data, rows)
    np.testing.assert_array_equal(rec["b"], rows[:, 1])
    d = rec.as_dict()
    assert list(d) == ["a", "b", "c"]
    for i, name in enumerate("abc"):
        np.testing.assert_array_equal(d[name], rows[:, i])
        assert d[name].flags.c_contiguous


def test_recorder_refuses_bad_shapes() -> None:
    with pytest.raises(ValueError, match="unique"):
        Recorder(("a", "a"), 3)
    with pytest.raises(ValueError, match="block"):
        Recorder(("a",), 0)


def test_drain_gives_as_dict_and_empties_the_table() -> None:
    rec = Recorder(("a", "b"), 3)
    rows = np.arange(14.0).reshape(7, 2)
    for row in rows:
        rec.append(tuple(row))
    ref = rec.as_dict()
    out = rec.drain()
    for name in ("a", "b"):
        np.testing.assert_array_equal(out[name], ref[name])
    assert len(rec) == 0 and rec.drain()["a"].shape == (0,)


def test_event_log_spans_blocks() -> None:
    log = EventLog(("t", "x"), block=3)
    rows = np.column_stack([np.arange(10.0), 10 * np.arange(10.0)])
    log.extend(rows[:7])
    log.extend(rows[7:])
    assert len(log) == 10
    np.testing.assert_array_equal(log.data, rows)
    np.testing.assert_array_equal(log.as_dict()["x"], rows[:, 1])


def test_record_stride() -> None:
    assert record_stride(100, None) == 1
    assert record_stride(MAX_RECORDED_ROWS, None) == 1
    assert record_stride(MAX_RECORDED_ROWS + 1, None) == 2
    assert record_stride(24 * 3600 * 20, None) == 18  # 24 h at 20 Hz: 96k rows
    assert record_stride(10, 3) == 3
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="record_every"):
            record_stride(10, bad)  # type: ignore[arg-type]


def test_decimated_run_records_every_kth_row_of_the_full_run_and_the_last() -> None:
    sc = default_scenario()
    full = build(sc).loop.run(3.0)
    b = build(sc)
    b.loop.record_every = 7
    dec = b.loop.run(3.0)
    n = full.series["t"].size  # 61 rows: t = 0, 0.05, ..., 3.0
    keep = [0, *range(7, n, 7)]
    if keep[-1] != n - 1:
        keep.append(n - 1)
    for name, col in full.series.items():
        np.testing.assert_array_equal(dec.series[name], col[keep], err_msg=name)
    # the decimated run keeps the events of its recorded steps: those in (t_k - dt, t_k] of a kept row
    t_ev = full.events["reflections"]["t"]
    kept_t = full.series["t"][keep[1:]]
    mask = np.zeros(t_ev.size, bool)
    for tk in kept_t[kept_t > 0]:
        mask |= (t_ev > tk - 0.05 + 1e-12) & (t_ev <= tk + 1e-12)
    if keep[-1] != keep[-2] + 7:  # the last row is recorded for itself, not for its step's events
        mask &= ~((t_ev > full.series["t"][-1] - 0.05 + 1e-12) & (t_ev <= full.series["t"][-1] + 1e-12))
    assert 0 < mask.sum() < t_ev.size
    for name, col in full.events["reflections"].items():
        np.testing.assert_array_equal(dec.events["reflections"][name], col[mask])
