"""Preallocated recording of every signal of a fixed-step run.

The closed loop writes one row per step into a preallocated ``(n_steps, n_columns)``
float64 array (one ``ndarray.__setitem__`` per step, no Python lists growing in the
hot loop); variable-rate events (goniometer reflections) go into a chunked event
table that grows by whole blocks.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray


class Recorder:
    """Fixed-step signal table: ``columns`` named, ``capacity`` rows preallocated.

    Parameters
    ----------
    columns
        Signal names, in row order (SI units; the name carries the unit suffix).
    capacity
        Maximum number of rows (steps + 1 for the initial row).
    """

    def __init__(self, columns: Sequence[str], capacity: int) -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity}")
        if len(set(columns)) != len(columns):
            raise ValueError("recorder column names must be unique")
        self.columns: tuple[str, ...] = tuple(columns)
        self.index = {name: i for i, name in enumerate(self.columns)}
        self._data = np.full((capacity, len(self.columns)), np.nan)
        self.n = 0

    def append(self, row: Sequence[float]) -> None:
        """Store one row (a tuple of ``len(columns)`` floats) at the next index."""
        self._data[self.n] = row
        self.n += 1

    @property
    def data(self) -> NDArray[np.float64]:
        """The rows written so far, ``(n, n_columns)`` (a view, not a copy)."""
        return self._data[: self.n]

    def __getitem__(self, name: str) -> NDArray[np.float64]:
        """One recorded signal, shape ``(n,)``."""
        return self._data[: self.n, self.index[name]]

    def as_dict(self) -> dict[str, NDArray[np.float64]]:
        """Every signal by name (copies), each ``(n,)``."""
        return {name: self._data[: self.n, i].copy() for i, name in enumerate(self.columns)}


class EventLog:
    """Growable table of events with a fixed set of float columns, stored in blocks."""

    def __init__(self, columns: Sequence[str], block: int = 4096) -> None:
        self.columns: tuple[str, ...] = tuple(columns)
        self._block = int(block)
        self._blocks: list[NDArray[np.float64]] = []
        self._cur = np.empty((self._block, len(self.columns)))
        self._n_cur = 0

    def extend(self, rows: NDArray[np.float64]) -> None:
        """Append ``rows`` of shape ``(k, n_columns)``."""
        rows = np.asarray(rows, dtype=np.float64)
        while rows.shape[0]:
            room = self._block - self._n_cur
            take = min(room, rows.shape[0])
            self._cur[self._n_cur : self._n_cur + take] = rows[:take]
            self._n_cur += take
            rows = rows[take:]
            if self._n_cur == self._block:
                self._blocks.append(self._cur)
                self._cur = np.empty((self._block, len(self.columns)))
                self._n_cur = 0

    def __len__(self) -> int:
        return len(self._blocks) * self._block + self._n_cur

    @property
    def data(self) -> NDArray[np.float64]:
        """All events so far, ``(k, n_columns)`` (a new array)."""
        return np.concatenate([*self._blocks, self._cur[: self._n_cur]], axis=0)

    def as_dict(self) -> dict[str, NDArray[np.float64]]:
        """Every event column by name, each ``(k,)``."""
        d = self.data
        return {name: d[:, i].copy() for i, name in enumerate(self.columns)}
