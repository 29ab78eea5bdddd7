"""Campaign statistics: per metric n, mean, std, median, 5/95 % quantiles and a 95 % CI of the mean.

Statistics use the **completed** runs only (a failed run's metrics describe a
different, unfinished drive); every group also counts its outcomes. The first
group is the whole campaign; then one group per grid point (each combination
of grid values). Random parameters take a new value every run, so they are not
grouped: the plots show metrics against them.

The confidence interval of the mean is Student's t interval,
``mean ± t(0.975, n - 1) · s / sqrt(n)`` with the sample standard deviation
``s`` (ddof = 1); it needs n >= 2.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pyarrow as pa
from numpy.typing import NDArray
from scipy.special import stdtrit

__all__ = ["OUTCOMES", "column_values", "describe", "summarize"]

OUTCOMES = ("completed", "failed", "error")


def _num(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def describe(values: NDArray[np.float64]) -> dict[str, Any]:
    """Statistics of the finite entries of ``values`` (NaN = undefined, ignored); None where undefined.

    Returns ``n``, ``mean``, ``std`` (ddof 1), ``median``, ``q05``, ``q95`` and ``ci95``
    (``[low, high]`` of the mean, Student t).
    """
    x = np.asarray(values, dtype=np.float64)
    x = x[np.isfinite(x)]
    n = int(x.size)
    out: dict[str, Any] = {"n": n, "mean": None, "std": None, "median": None, "q05": None, "q95": None, "ci95": None}
    if n == 0:
        return out
    mean = float(np.mean(x))
    q05, median, q95 = np.quantile(x, [0.05, 0.5, 0.95])
    out.update(mean=mean, median=float(median), q05=float(q05), q95=float(q95))
    if n >= 2:
        std = float(np.std(x, ddof=1))
        half = float(stdtrit(n - 1, 0.975)) * std / math.sqrt(n)
        out.update(std=std, ci95=[_num(mean - half), _num(mean + half)])
    return out


def column_values(table: pa.Table, name: str) -> list[Any]:
    """A column as a Python list (Nones for a column the table lacks)."""
    return table[name].to_pylist() if name in table.column_names else [None] * table.num_rows


def _floats(table: pa.Table, name: str) -> NDArray[np.float64]:
    return np.array([np.nan if v is None else float(v) for v in column_values(table, name)], dtype=np.float64)


def _group(table: pa.Table, mask: NDArray[np.bool_], params: dict[str, Any], metrics: Sequence[str]) -> dict[str, Any]:
    outcome = np.array(column_values(table, "outcome"), dtype=object)
    counts = {o: int(np.sum(mask & (outcome == o))) for o in OUTCOMES}
    ok = mask & (outcome == "completed")
    stats = {m: describe(_floats(table, f"metric.{m}")[ok]) for m in metrics}
    return {"params": params, "runs": int(mask.sum()), "outcomes": counts, "metrics": stats}


def summarize(table: pa.Table, group_by: Sequence[str] = (), metrics: Sequence[str] | None = None) -> dict[str, Any]:
    """Statistics of a campaign's results table: the whole campaign, then one group per grid point.

    Parameters
    ----------
    table
        The results (:func:`agvnav.campaign.store.read_results`).
    group_by
        Dotted parameter keys to group by (the grid keys).
    metrics
        Metric names (default: every ``metric.*`` column).
    """
    names = list(metrics) if metrics is not None else [c[7:] for c in table.column_names if c.startswith("metric.")]
    everything = np.ones(table.num_rows, dtype=bool)
    groups = [_group(table, everything, {}, names)]
    if group_by:
        columns = [column_values(table, f"param.{k}") for k in group_by]
        keys = [tuple(json.dumps(v) for v in row) for row in zip(*columns, strict=True)]
        for combo in dict.fromkeys(keys):
            mask = np.array([k == combo for k in keys], dtype=bool)
            params = {k: json.loads(v) for k, v in zip(group_by, combo, strict=True)}
            groups.append(_group(table, mask, params, names))
    return {"runs": table.num_rows, "metrics": names, "group_by": list(group_by), "groups": groups}
