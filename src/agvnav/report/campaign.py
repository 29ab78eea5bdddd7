"""A Monte Carlo campaign's report: the summary table and the PNG plots, in the same display units.

:func:`summary_table` is the table ``agvnav campaign`` prints: per group and metric the
statistics in the metric's display unit (:func:`agvnav.bench.common.display_unit`: mm or m,
deg, s), std and the 95 % confidence interval of the mean kept longest when the terminal
is narrow. The plots label every axis in those same units.

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

from agvnav._display import Col, display_unit, format_number

__all__ = ["MAX_LEVELS", "metric_units", "plot_campaign", "summary_sections", "summary_table"]

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
    """Numeric x (as written in the campaign file, like the table's group labels), or category positions
    and their labels for text values."""
    if all(v is None or (isinstance(v, int | float) and not isinstance(v, bool)) for v in values):
        return _floats(values), None
    labels = sorted({str(v) for v in values})
    return np.array([labels.index(str(v)) for v in values], dtype=np.float64), labels


def _axis(key: str, values: NDArray[np.float64]) -> tuple[str, float]:
    """Axis label of the SI column ``key`` in its display unit, and the scale to it (as the summary table)."""
    header, _, scale = display_unit(key, [float(v) for v in values[np.isfinite(values)]])
    return header, scale


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
    summary: dict[str, Any] | None = None,
) -> list[Path]:
    """Write one PNG per metric (histogram + metric against each parameter); return the paths.

    Parameters
    ----------
    columns
        ``"outcome"``, ``"metric.<name>"`` and ``"param.<key>"`` columns of equal length;
        only runs with outcome ``"completed"`` are drawn.
    metrics, params
        Metric names and swept dotted parameter keys to draw (SI, as in the campaign's table);
        each metric is drawn and labelled in its display unit, as :func:`summary_table` prints it
        (``max_abs_lateral_error_m`` -> "max abs lateral error (mm)"); a parameter axis shows the
        values as written in the campaign file, as the table's group labels do.
    summary
        The campaign summary (:func:`agvnav.campaign.summarize`): the plots then take the very
        units of its :func:`summary_table` (:func:`metric_units`); without it, each metric's unit
        is chosen from the drawn values by the same rule.
    """
    plt = _pyplot()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    keep = np.array([o == "completed" for o in columns.get("outcome", [])], dtype=bool)
    written = []
    units = metric_units(summary) if summary is not None else {}
    for metric in metrics:
        y_si = _floats(columns.get(f"metric.{metric}", [None] * keep.size))[keep]
        y_label, y_scale = units.get(metric) or _axis(metric, y_si)
        y = y_si * y_scale
        fig, axes = plt.subplots(1, 1 + len(params), figsize=(4.2 * (1 + len(params)), 3.6), squeeze=False)
        ax0 = axes[0, 0]
        finite = y[np.isfinite(y)]
        if finite.size:
            ax0.hist(finite, bins=min(40, max(5, int(np.sqrt(finite.size)))), color="C0", alpha=0.8)
        ax0.set_xlabel(y_label)
        ax0.set_ylabel(f"runs (of {finite.size} completed)")
        for ax, key in zip(axes[0, 1:], params, strict=True):
            x, labels = _x_values(list(np.asarray(columns.get(f"param.{key}", [None] * keep.size), dtype=object)[keep]))
            _panel(ax, x, labels, y, key)
            ax.set_ylabel(y_label)
        fig.suptitle(f"{title}: {y_label}" if title else y_label)
        fig.tight_layout()
        path = out / _file_name(metric)
        fig.savefig(path, dpi=100)
        plt.close(fig)
        written.append(path)
    return written


_STATS = ("mean", "std", "median", "q05", "q95")


def metric_units(summary: dict[str, Any]) -> dict[str, tuple[str, float]]:
    """Per metric of a campaign summary, its label with the display unit and the scale from SI.

    One unit per metric across every group (from all its statistics, by
    :func:`agvnav.bench.common.display_unit`): ``{"max_abs_lateral_error_m": ("max abs lateral
    error (mm)", 1000.0)}``. The table and the plots both use it.
    """
    values: dict[str, list[Any]] = {}
    for group in summary["groups"]:
        for metric, s in group["metrics"].items():
            if s is not None:
                values.setdefault(metric, []).extend([s[k] for k in _STATS] + list(s["ci95"] or []))
    out = {}
    for metric, vals in values.items():
        header, _, scale = display_unit(metric, [v for v in vals if v is not None])
        out[metric] = (header, scale)
    return out


def summary_sections(summary: dict[str, Any]) -> list[bool]:
    """After which row of :func:`summary_table` a group ends (one row per metric of each group)."""
    ends: list[bool] = []
    for group in summary["groups"]:
        n = max(len(group["metrics"]), 1)
        ends += [False] * (n - 1) + [True]
    return ends


def summary_table(name: str, summary: dict[str, Any]) -> tuple[str, list[Col], list[list[str]]]:
    """``(title, columns, rows)`` of a campaign summary: per group and metric, the statistics in the metric's
    display unit, for :func:`agvnav.bench.common.print_table`.

    Columns drop right to left by importance on a narrow terminal: n, then median, then the 5 % and
    95 % quantiles go before the 95 % confidence interval of the mean and the std, which stay with the
    mean. Each metric has one unit in every group (:func:`metric_units`), the one its plot uses.
    The group label puts one swept parameter per line and metric names wrap at spaces, so the
    figures get the room.
    """
    title = f"campaign {name}: {summary['runs']} runs; statistics over the completed runs"
    cols = [
        Col("group", "left", 0), Col("metric", "left", 0, wrap=True), Col("n", "right", 3), Col("mean", "right", 0),
        Col("std", "right", 1), Col("median", "right", 4), Col("5 %", "right", 5), Col("95 %", "right", 5),
        Col("95 % CI of mean", "right", 2),
    ]
    rows: list[list[str]] = []
    units = metric_units(summary)
    for group in summary["groups"]:
        label = "\n".join(f"{k}={v}" for k, v in group["params"].items()) or "all"
        counts = ", ".join(f"{v} {k}" for k, v in group["outcomes"].items() if v)
        items = list(group["metrics"].items()) or [("-", None)]
        for j, (metric, s) in enumerate(items):
            head = f"{label}\n({counts})" if j == 0 else ""
            if s is None:
                rows.append([head, metric, *[""] * 7])
                continue
            header, scale = units[metric]
            ci = "-" if s["ci95"] is None else (
                f"[{format_number(s['ci95'][0], scale)}, {format_number(s['ci95'][1], scale)}]"
            )
            stats = [format_number(s[k], scale) for k in _STATS]
            rows.append([head, header, str(s["n"]), *stats, ci])
    return title, cols, rows
