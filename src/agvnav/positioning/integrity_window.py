"""The integrity monitor's window: the accepted reflections as typed records, and one pass over them.

Each accepted reflection is one row of :data:`WINDOW_FIELDS` (all float64; :data:`WINDOW_DTYPE`
is the NumPy structured dtype of a row, :meth:`_Window.records` the window as records):

* ``t`` stamp (s), ``nis`` its NIS, ``reflector`` the map row, ``bearing`` the edge bearing
  (rad, head frame), ``odom_x, odom_y, odom_psi`` the odometric base_link pose then (m, m, rad),
  ``on_time`` 1/0 (the head clock, :class:`~agvnav.positioning.integrity_sight.HeadClock`);
* ``has_correction`` 1/0 and the Kalman update's position correction ``dx, dy`` (m) and
  covariance decrease ``P- - P+`` as ``dP00, dP01, dP11`` (m²);
* ``has_innovation`` 1/0 and the EKF's innovation ``y`` (rad), its variance ``S`` (rad²) and
  Jacobian row ``H0, H1, H2``.

The compiled checks (:mod:`agvnav.positioning._integrity_fast`, :func:`_window_tally`) read the
rows through the column offsets below, derived from the field names (numba takes a flat
float buffer; a structured array is a view of the same memory). :func:`window_row` builds a
row by name.
"""

from __future__ import annotations

from array import array
from typing import Any, NamedTuple

import numpy as np

from agvnav._jit import jit

__all__ = ["WINDOW_DTYPE", "WINDOW_FIELDS", "window_row"]

#: The fields of a window row, in storage order (units in the module docstring).
WINDOW_FIELDS = (
    "t", "nis", "reflector", "bearing", "odom_x", "odom_y", "odom_psi", "on_time",
    "has_correction", "dx", "dy", "dP00", "dP01", "dP11",
    "has_innovation", "y", "S", "H0", "H1", "H2",
)
#: One window row as a NumPy structured dtype (every field float64).
WINDOW_DTYPE = np.dtype([(name, np.float64) for name in WINDOW_FIELDS])

#: Column offsets of the fields the compiled kernels read (``_C0``: ``dx``, then ``dy, dP00, dP01, dP11``;
#: ``_Y``: ``y``, then ``S, H0, H1, H2``).
_T, _NIS, _IDX, _BEAR = (WINDOW_FIELDS.index(f) for f in ("t", "nis", "reflector", "bearing"))
_OX, _OY, _OPSI, _ON_TIME = (WINDOW_FIELDS.index(f) for f in ("odom_x", "odom_y", "odom_psi", "on_time"))
_HAS_C, _C0, _HAS_I, _Y = (WINDOW_FIELDS.index(f) for f in ("has_correction", "dx", "has_innovation", "y"))
_S, _H0 = WINDOW_FIELDS.index("S"), WINDOW_FIELDS.index("H0")
_WIDTH = len(WINDOW_FIELDS)

_NO_FIVE = (0.0, 0.0, 0.0, 0.0, 0.0)


def window_row(
    t: float, nis: float, reflector: int, bearing: float, odom: tuple[float, ...], on_time: bool,
    correction: tuple[float, float, float, float, float] | None,
    innovation: tuple[float, float, float, float, float] | None,
) -> tuple[float, ...]:
    """One row in :data:`WINDOW_FIELDS` order: ``correction = (dx, dy, dP00, dP01, dP11)`` and
    ``innovation = (y, S, H0, H1, H2)`` or None (their ``has_*`` flag then 0)."""
    return (
        t, nis, reflector, bearing, odom[0], odom[1], odom[2], 1.0 if on_time else 0.0,
        0.0 if correction is None else 1.0, *(correction or _NO_FIVE),
        0.0 if innovation is None else 1.0, *(innovation or _NO_FIVE),
    )


class _Tally(NamedTuple):
    """The window's sums per map row (:func:`_window_tally`; ``N`` map rows).

    ``sightings (N,)`` per reflector, ``first (N,)`` position of the first (-1: none), ``nis (N,)``
    their NIS summed, ``innovations (N, 6)`` the EKF's ``y, S, H0, H1, H2`` summed over the
    sightings within ``window_s`` of the check and not excluded, and their count,
    ``newest (N,)`` position of the newest sighting within one revolution (-1: none),
    ``corrections (6,)`` the Kalman corrections ``dx, dy, c00, c01, c11`` summed and their
    count, ``late`` the sightings off the head's phase. Every sum in window order.
    """

    sightings: np.ndarray
    first: np.ndarray
    nis: np.ndarray
    innovations: np.ndarray
    newest: np.ndarray
    corrections: tuple[float, ...]
    late: int


@jit
def _window_tally(
    buf: Any, start: int, n: int, t: float, window_s: float, revolution_s: float, excluded: Any,
) -> tuple[Any, Any, Any, Any, Any, tuple[float, float, float, float, float, float], int]:
    """One pass over the ``n`` window rows of ``buf`` from offset ``start`` (:class:`_Window`), at ``t`` (s).

    Returns the fields of :class:`_Tally`; ``excluded (N,)`` flags the excluded map rows
    (non-zero), ``window_s`` and ``revolution_s`` (s) bound the innovations and the newest
    sightings. Every sum adds in window order from 0.0 (as the checks' loops did). The columns
    (``_T``, ...) are this module's, derived from :data:`WINDOW_FIELDS`.
    """
    m = excluded.shape[0]
    count, nis = np.zeros(m), np.zeros(m)
    first, newest = np.full(m, -1, np.int64), np.full(m, -1, np.int64)
    innov = np.zeros((m, 6))
    dx = dy = c00 = c01 = c11 = n_corr = 0.0
    late = 0
    for k in range(n):
        o = start + k * _WIDTH
        j = int(buf[o + _IDX])
        if count[j] == 0.0:
            first[j] = k
        count[j] += 1.0
        nis[j] += buf[o + _NIS]
        if buf[o + _ON_TIME] == 0.0:
            late += 1
        if buf[o + _HAS_C] != 0.0:
            dx, dy = dx + buf[o + _C0], dy + buf[o + _C0 + 1]
            c00, c01, c11 = c00 + buf[o + _C0 + 2], c01 + buf[o + _C0 + 3], c11 + buf[o + _C0 + 4]
            n_corr += 1.0
        age = t - buf[o + _T]
        if buf[o + _HAS_I] != 0.0 and not age > window_s and excluded[j] == 0:
            for c in range(5):
                innov[j, c] += buf[o + _Y + c]
            innov[j, 5] += 1.0
        if age <= revolution_s:
            newest[j] = k
    return count, first, nis, innov, newest, (dx, dy, c00, c01, c11, n_corr), late


def _owned(part: array) -> np.ndarray:
    """``part`` (a slice of a window's buffer, its own copy) as a float64 NumPy array over its memory.

    Never a view of the live buffer: while any view of it exists the buffer cannot grow
    (``BufferError``), and a frame held by a sampling profiler (Dask's worker profiler takes
    the running thread's stack every 10 ms) keeps a function's local views alive after it
    returned, so an ``np.frombuffer`` of the buffer failed a campaign run now and then.
    """
    return np.frombuffer(part, dtype=np.float64)


class _Window:
    """The accepted reflections of the window, oldest first: rows of :data:`_WIDTH` floats in one flat buffer.

    Appending a row is one ``array.extend``; :meth:`buffer` hands the check's compiled kernels
    (:mod:`agvnav.positioning._integrity_fast`, :func:`_window_tally`) the whole window in one
    pass each (issue 11: 1,400 reflections in the window of a 256-reflector map), compiled as
    one NumPy copy made once per change of the window.

    That copy is valid while ``(len(_flat), head)`` is the one it was taken at: rows are only
    ever appended at the end (``len`` grows: :meth:`append`, :meth:`push`) or dropped at the front
    (``head`` grows: :meth:`popleft`, :meth:`drop_older`), and every change that shrinks the buffer
    (:meth:`clear`, :meth:`keep`, :meth:`popleft`'s compaction) goes through :meth:`_reset`, which
    voids the copy. No row is written in place.
    """

    def __init__(self) -> None:
        self._flat = array("d")
        self._head = 0  # rows before it have left the window
        self._copy: tuple[tuple[int, int], np.ndarray] | None = None  # :meth:`buffer`'s key and copy

    def __len__(self) -> int:
        return len(self._flat) // _WIDTH - self._head

    def append(self, row: tuple[float, ...]) -> None:
        """Add one row (:data:`_WIDTH` floats) at the new end."""
        self._flat.extend(row)

    def push(self, row: tuple[float, ...], t: float, window_s: float) -> None:
        """:meth:`append` ``row``, then :meth:`drop_older` at ``t`` (s), called only when the oldest row expired."""
        flat = self._flat
        flat.extend(row)
        if t - flat[self._head * _WIDTH] > window_s:  # else drop_older drops nothing
            self.drop_older(t, window_s)

    def first_t(self) -> float:
        """Stamp (s) of the oldest row (the window must not be empty)."""
        return self._flat[self._head * _WIDTH]

    def drop_older(self, t: float, window_s: float) -> None:
        """Drop the oldest rows while their stamp is more than ``window_s`` (s) before ``t`` (s)."""
        flat, head, width = self._flat, self._head, _WIDTH
        end = len(flat)
        while head * width < end and t - flat[head * width] > window_s:
            head += 1
        if head != self._head:
            self._head = head - 1
            self.popleft()  # the last one through popleft: it compacts the buffer when due

    def popleft(self) -> None:
        """Drop the oldest row (the buffer is compacted once half of it is dropped rows)."""
        self._head += 1
        if self._head >= 256 and 2 * self._head >= len(self._flat) // _WIDTH:
            self._reset(self._head * _WIDTH)

    def clear(self) -> None:
        """Drop every row."""
        self._reset(len(self._flat))

    def _reset(self, cut: int) -> None:
        """Delete the first ``cut`` floats of the buffer, the head back at 0 (the copy of :meth:`buffer` is void)."""
        del self._flat[:cut]
        self._head = 0
        self._copy = None

    def records(self) -> np.ndarray:
        """``(n,)`` the window's rows as :data:`WINDOW_DTYPE` records (a copy), oldest first."""
        return np.ascontiguousarray(self.rows()).view(WINDOW_DTYPE).reshape(-1)

    def rows(self) -> np.ndarray:
        """``(n, len(WINDOW_FIELDS))`` copy of the window's rows as floats, oldest first."""
        if not len(self):
            return np.empty((0, _WIDTH))
        return _owned(self._flat[self._head * _WIDTH:]).reshape(-1, _WIDTH)

    def keep(self, mask: np.ndarray) -> None:
        """Keep only the rows where ``mask (n,)`` is True, in order."""
        kept = self.rows()[mask]
        self.clear()  # voids the copy of :meth:`buffer`
        self._flat.frombytes(np.ascontiguousarray(kept).tobytes())

    def indices(self) -> list[int]:
        """Map rows of the window's reflections, oldest first."""
        return list(map(int, self._flat[self._head * _WIDTH + _IDX::_WIDTH]))

    def row(self, k: int) -> list[float]:
        """Row ``k`` (0: the oldest) as floats."""
        o = (self._head + k) * _WIDTH
        return self._flat[o:o + _WIDTH].tolist()

    def buffer(self) -> tuple[Any, int]:
        """The flat buffer for :func:`_window_tally` and the offset of the oldest row in it.

        A NumPy copy of the window (numba takes arrays), made once while the window stays as it
        is (the class docstring).
        """
        key = (len(self._flat), self._head)
        held = self._copy
        if held is None or held[0] != key:
            held = self._copy = key, _owned(self._flat[self._head * _WIDTH:])
        return held[1], 0
