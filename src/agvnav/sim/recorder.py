"""Recording of every signal of a fixed-step run, in blocks that grow with the run.

The closed loop writes one row per recorded step into the current block of a
``(block, n_columns)`` float64 table (one ``ndarray.__setitem__`` per row, no Python
lists growing in the hot loop); a full block is kept and a new one started, so memory
follows what was recorded, not the run's planned duration (a 24-hour run no longer
preallocates for every step up front). Variable-rate events (goniometer reflections)
go into a table of the same kind. Reading the signals by name concatenates the blocks
column by column (one copy of the data, never two).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = ["EventLog", "Recorder"]


class _Blocks:
    """Rows of ``len(columns)`` floats stored in blocks of ``block`` rows (the shared core)."""

    def __init__(self, columns: Sequence[str], block: int) -> None:
        if int(block) < 1:
            raise ValueError(f"block (capacity) must be >= 1 row, got {block}")
        if len(set(columns)) != len(columns):
            raise ValueError("recorder column names must be unique")
        self.columns: tuple[str, ...] = tuple(columns)
        self.index = {name: i for i, name in enumerate(self.columns)}
        self._block = int(block)
        self._full: list[NDArray[np.float64]] = []
        self._cur = np.full((self._block, len(self.columns)), np.nan)
        self._n_cur = 0

    def _next_block(self) -> None:
        self._full.append(self._cur)
        self._cur = np.full((self._block, len(self.columns)), np.nan)
        self._n_cur = 0

    def __len__(self) -> int:
        return len(self._full) * self._block + self._n_cur

    def _parts(self) -> list[NDArray[np.float64]]:
        return [*self._full, self._cur[: self._n_cur]]

    @property
    def data(self) -> NDArray[np.float64]:
        """All rows so far, ``(n, n_columns)`` (a view of the single block, else a new array)."""
        return self._cur[: self._n_cur] if not self._full else np.concatenate(self._parts(), axis=0)

    def __getitem__(self, name: str) -> NDArray[np.float64]:
        """One column by name, ``(n,)`` (a new array)."""
        i = self.index[name]
        return np.concatenate([p[:, i] for p in self._parts()])

    def as_dict(self) -> dict[str, NDArray[np.float64]]:
        """Every column by name, each ``(n,)`` (contiguous copies)."""
        parts = self._parts()
        return {name: np.concatenate([p[:, i] for p in parts]) for i, name in enumerate(self.columns)}

    def drain(self) -> dict[str, NDArray[np.float64]]:
        """:meth:`as_dict`, releasing each block once copied (peak: the data once plus one block); empties the table."""
        n = len(self)
        out = {name: np.empty(n) for name in self.columns}
        parts, self._full = [*self._full, self._cur[: self._n_cur]], []
        self._cur, self._n_cur = np.full((self._block, len(self.columns)), np.nan), 0
        row = 0
        parts.reverse()
        while parts:
            block = parts.pop()
            for i, name in enumerate(self.columns):
                out[name][row : row + block.shape[0]] = block[:, i]
            row += block.shape[0]
            del block
        return out


class Recorder(_Blocks):
    """Fixed-step signal table: ``columns`` named, stored in blocks of ``capacity`` rows.

    Parameters
    ----------
    columns
        Signal names, in row order (SI units; the name carries the unit suffix).
    capacity
        Rows per block (>= 1); the table grows by whole blocks as rows arrive.
    """

    def __init__(self, columns: Sequence[str], capacity: int) -> None:
        super().__init__(columns, capacity)

    @property
    def n(self) -> int:
        """Rows written so far."""
        return len(self)

    def append(self, row: Sequence[float]) -> None:
        """Store one row (a tuple of ``len(columns)`` floats) at the next index."""
        self._cur[self._n_cur] = row
        self._n_cur += 1
        if self._n_cur == self._block:
            self._next_block()


class EventLog(_Blocks):
    """Growable table of events with a fixed set of float columns, stored in blocks."""

    def __init__(self, columns: Sequence[str], block: int = 4096) -> None:
        super().__init__(columns, block)

    def extend(self, rows: NDArray[np.float64]) -> None:
        """Append ``rows`` of shape ``(k, n_columns)``."""
        rows = np.asarray(rows, dtype=np.float64)
        while rows.shape[0]:
            take = min(self._block - self._n_cur, rows.shape[0])
            self._cur[self._n_cur : self._n_cur + take] = rows[:take]
            self._n_cur += take
            rows = rows[take:]
            if self._n_cur == self._block:
                self._next_block()
