"""Series CSV files of a run folder: one column per series with a header row, and a units sidecar."""

from __future__ import annotations

import csv
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from agvnav.report.reference import COLUMNS, LAP_COLUMNS, PER_OBSTACLE

__all__ = ["read_csv", "units_path", "write_csv"]


def write_csv(
    path: Path, columns: dict[str, NDArray[np.float64]], units: Mapping[str, tuple[str, str]] | None = None
) -> Path:
    """One column per series, a header row of names, ``%.10g`` values; the units in a sidecar.

    ``units`` maps a column name to ``(unit, meaning)``; by default the documented
    columns of :mod:`agvnav.report.reference` (time series, then laps); a per-obstacle column
    ``NAME__ID`` is documented as ``NAME__<id>``. The sidecar
    :func:`units_path` lists every column in order; an undocumented one says so.
    Returns the CSV's path.
    """
    names = list(columns)
    data = np.column_stack([np.asarray(columns[n], dtype=np.float64) for n in names])
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt="%.10g")
    table = {**LAP_COLUMNS, **COLUMNS} if units is None else units
    with open(units_path(path), "w", encoding="utf-8", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(["column", "unit", "meaning"])
        for name in names:
            unit, meaning = table.get(name) or table.get(name.split("__")[0] + PER_OBSTACLE, ("", "not documented"))
            out.writerow([name, unit, meaning])
    return path


def read_csv(path: Path) -> dict[str, NDArray[np.float64]]:
    """The columns of a CSV that :func:`write_csv` wrote: name -> values, in the header row's order."""
    with path.open(encoding="utf-8") as f:
        names = f.readline().strip().split(",")
        data = np.loadtxt(f, delimiter=",", ndmin=2, dtype=np.float64)
    return {n: data[:, i] for i, n in enumerate(names)}


def units_path(csv_path: str | Path) -> Path:
    """The units sidecar of a CSV file: ``NAME.csv`` -> ``NAME.units.csv``."""
    p = Path(csv_path)
    return p.with_name(f"{p.stem}.units.csv")
