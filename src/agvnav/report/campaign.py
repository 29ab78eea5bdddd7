"""PNG plots of a Monte Carlo campaign: each metric's distribution and the metric against each swept parameter.

One figure per metric, ``campaign_<metric>.png``: a histogram of the metric
over the completed runs, then one panel per swept parameter with every run as
a point and, when the parameter takes at most :data:`MAX_LEVELS` values (a grid),
the mean per value. Text-valued parameters (``choice`` of names) are shown as
categories. The input is plain columns (name -> values), as read from the
campaign's Parquet table, so this module needs no campaign code.

matplotlib is imported only when plotting, with the non-interactive Agg backend.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["MAX_LEVELS", "plot_campaign"]

#: A parameter with at most this many distinct values gets its mean per value drawn.
MAX_LEVELS = 20


def _pyplot() -> Any:
    import matplotlib  # noqa: PLC0415 - plotting is optional: matplotlib loads only when a plot is drawn

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt  # noqa: PLC0415 - see above

    return plt


def _floats(values: Sequence[Any]) -> NDArray[np.float64]:
    return np.array([np.nan if v is None else float(v) for v in values], dtype=np.float64)


def _x_values(values: Sequence[Any]) -> tuple[NDArray[np.float64], list[str] | None]:
    """Numeric x, or category positions and their labels for text values."""
    if all(v is None or (isinstance(v, int | float) and not isinstance(v, bool)) for v in values):
        return _floats(values), None
    labels = sorted({str(v) for v in values})
    return np.array([labels.index(str(v)) for v in values], dtype=np.float64), labels


def _panel(ax: Any, x: NDArray[np.float64], labels: list[str] | None, y: NDArray[np.float64], name: str) -> None:
    ok = np.isfinite(x) & np.isfinite(y)
    ax.plot(x[ok], y[ok], ".", alpha=0.4, markersize=4)
    levels = np.unique(x[ok])
    if 0 < levels.size <= MAX_LEVELS:
        means = [float(np.mean(y[ok][x[ok] == v])) for v in levels]
        ax.plot(levels, means, "o-", color="C3", label="mean")
        ax.legend(loc="best", fontsize="small")
    if labels is not None:
        ax.set_xticks(range(len(labels)), labels, rotation=30)
    ax.set_xlabel(name)
    ax.grid(True, alpha=0.3)


def _file_name(metric: str) -> str:
    return "campaign_" + re.sub(r"[^A-Za-z0-9_.-]", "_", metric) + ".png"


def plot_campaign(
    columns: Mapping[str, Sequence[Any]],
    metrics: Sequence[str],
    params: Sequence[str],
    out_dir: str | Path,
    title: str = "",
) -> list[Path]:
    """Write one PNG per metric (histogram + metric against each parameter); return the paths.

    Parameters
    ----------
    columns
        ``"outcome"``, ``"metric.<name>"`` and ``"param.<key>"`` columns of equal length;
        only runs with outcome ``"completed"`` are drawn.
    metrics, params
        Metric names and swept dotted parameter keys to draw.
    """
    plt = _pyplot()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    keep = np.array([o == "completed" for o in columns.get("outcome", [])], dtype=bool)
    written = []
    for metric in metrics:
        y = _floats(columns.get(f"metric.{metric}", [None] * keep.size))[keep]
        fig, axes = plt.subplots(1, 1 + len(params), figsize=(4.2 * (1 + len(params)), 3.6), squeeze=False)
        ax0 = axes[0, 0]
        finite = y[np.isfinite(y)]
        if finite.size:
            ax0.hist(finite, bins=min(40, max(5, int(np.sqrt(finite.size)))), color="C0", alpha=0.8)
        ax0.set_xlabel(metric)
        ax0.set_ylabel(f"runs (of {finite.size} completed)")
        for ax, key in zip(axes[0, 1:], params, strict=True):
            x, labels = _x_values(list(np.asarray(columns.get(f"param.{key}", [None] * keep.size), dtype=object)[keep]))
            _panel(ax, x, labels, y, key)
            ax.set_ylabel(metric)
        fig.suptitle(title or metric)
        fig.tight_layout()
        path = out / _file_name(metric)
        fig.savefig(path, dpi=100)
        plt.close(fig)
        written.append(path)
    return written
