"""PNG plots of a closed-loop run (seed 000 Figs. 8, 10 and 11).

matplotlib is imported lazily inside each function, with the non-interactive
Agg backend, so the math packages never need it.

Speed (issue 11: the plots were about half of ``agvnav simulate``): the three run plots
draw on a bare :class:`matplotlib.figure.Figure` with the Agg canvas, never through
``pyplot`` (no figure manager, no global figure list to close); walls are one
:class:`~matplotlib.collections.LineCollection` per panel, not one line each; the
margins are fixed instead of measured by ``tight_layout`` (a second text layout pass).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import lateral_position_error

__all__ = [
    "RUN_PLOTS", "error_labels", "event_spans", "event_strips", "plot_errors", "plot_map",
    "plot_positioning_histogram", "prepare", "pyplot", "warm_up", "write_plots",
]

#: Titles sit at the top of their axes (``y`` given): matplotlib otherwise measures every tick
#: label of the axis to lift the title clear of top-side decorations these plots never have,
#: about a fifth of the drawing time.
_TITLE_Y = 1.0


def pyplot() -> Any:
    """``matplotlib.pyplot`` with the non-interactive Agg backend, imported on first use.

    Every plotting function of :mod:`agvnav.report` starts here, so importing agvnav
    (or its CLI) never imports matplotlib nor changes the caller's backend.
    """
    import matplotlib  # noqa: PLC0415  (lazy on purpose: see the docstring)

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt  # noqa: PLC0415

    return plt


def plot_map(
    path_xy: NDArray[np.float64],
    driven_xy: NDArray[np.float64],
    reflector_xy: NDArray[np.float64],
    wall_segments: NDArray[np.float64],
    out: str | Path,
    estimated_xy: NDArray[np.float64] | None = None,
    title: str = "",
    *,
    make_dir: bool = True,
    obstacles: Mapping[str, NDArray[np.float64]] | None = None,
    stops_xy: NDArray[np.float64] | None = None,
    driven_label: str = "driven (truth)",
    obstacles_at_stops: Mapping[str, NDArray[np.float64]] | None = None,
) -> Path:
    """Map with walls, reflectors, the planned path and the driven path (seed 000 Fig. 10).

    ``path_xy``/``driven_xy``/``estimated_xy`` are ``(n, 2)`` polylines (m),
    ``reflector_xy`` ``(N, 2)``, ``wall_segments`` ``(M, 2, 2)``. Two panels: the
    whole map and a close-up of the path. ``obstacles`` maps an obstacle id to its
    centre's track ``(n, 2)`` (m, NaN while absent), drawn with its last position;
    ``stops_xy`` ``(k, 2)`` marks where the vehicle stopped (safety field or positioning guard),
    ``obstacles_at_stops`` each obstacle's centre ``(k, 2)`` at those instants.
    """
    from matplotlib.collections import LineCollection  # noqa: PLC0415  (lazy: see the module docstring)

    fig, axes = _take("map")
    walls = np.asarray(wall_segments, dtype=np.float64).reshape(-1, 2, 2)
    for ax in axes:
        if walls.shape[0]:
            ax.add_collection(LineCollection(list(walls), colors="0.4", linewidths=1.2))
        r = np.asarray(reflector_xy).reshape(-1, 2)
        ax.plot(r[:, 0], r[:, 1], "o", ms=6, mfc="gold", mec="k", label="reflectors")
        ax.plot(path_xy[:, 0], path_xy[:, 1], "--", color="tab:blue", lw=1.5, label="planned path")
        ax.plot(driven_xy[:, 0], driven_xy[:, 1], color="tab:red", lw=1.2, label=driven_label)
        if estimated_xy is not None:
            ax.plot(estimated_xy[:, 0], estimated_xy[:, 1], color="tab:green", lw=0.8, alpha=0.8, label="estimated")
        for oid, track in (obstacles or {}).items():
            ok = track[np.all(np.isfinite(track), axis=1)]
            if ok.size:
                ax.plot(ok[:, 0], ok[:, 1], ":", color="tab:purple", lw=1.2)
                ax.plot(ok[-1:, 0], ok[-1:, 1], "s", ms=7, color="tab:purple", label=f"{oid} (end)")
            at = (obstacles_at_stops or {}).get(oid)
            if at is not None and np.isfinite(at).any():
                ax.plot(at[:, 0], at[:, 1], "s", ms=8, mfc="none", mec="crimson", mew=1.5, label=f"{oid} at stop")
        if stops_xy is not None and len(stops_xy):
            ax.plot(stops_xy[:, 0], stops_xy[:, 1], "X", ms=9, color="crimson", mec="k", label="stop")
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.grid(True, alpha=0.3)
    pts = np.concatenate([path_xy, driven_xy])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.15 * max(hi - lo) + 0.2
    axes[1].set_xlim(lo[0] - pad, hi[0] + pad)
    axes[1].set_ylim(lo[1] - pad, hi[1] + pad)
    axes[0].set_title(title or "map", y=_TITLE_Y)
    axes[1].set_title("path detail", y=_TITLE_Y)
    axes[1].legend(loc="best", fontsize=8)
    return _save(fig, out, make_dir)


def plot_errors(
    t: NDArray[np.float64],
    lateral_error: NDArray[np.float64],
    wheel_heading_error: NDArray[np.float64],
    out: str | Path,
    transient_end_s: float | None = None,
    title: str = "",
    *,
    make_dir: bool = True,
    labels: tuple[str, str] = ("lateral error ε_c [mm]", "wheel heading error ξ_r [deg]"),
    events: Mapping[str, NDArray[np.float64]] | None = None,
) -> Path:
    """Lateral error (mm) and heading error (deg) against time (seed 000 Fig. 11), and the run's events.

    ``labels`` name the two errors as they apply to the vehicle (:func:`error_labels`; the default
    is the tricycle's ε_c and ξ_r). A third panel shows the commanded speed ``events["v_cmd"]``
    (m/s) over shaded windows of what happened (:func:`event_spans`: faults, estimator outages,
    positioning guard, safety-field stops, station stops) and, on a second axis, each obstacle's
    clearance ``events["clearance__<id>"]`` (m).
    """
    fig, (a1, a2, a3) = _take("errors")
    a1.plot(t, 1000.0 * lateral_error, color="tab:blue")
    a1.set_ylabel(labels[0])
    a2.plot(t, np.rad2deg(wheel_heading_error), color="tab:orange")
    a2.set_ylabel(labels[1])
    a3.set_xlabel("time [s]")
    for ax in (a1, a2, a3):
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.grid(True, alpha=0.3)
        if transient_end_s is not None:
            ax.axvline(transient_end_s, color="k", ls=":", lw=1.0, label="end of transient" if ax is a1 else None)
    if transient_end_s is not None:
        a1.legend(loc="best", fontsize=8)
    ev = events or {}
    if "v_cmd" in ev:
        a3.plot(t, ev["v_cmd"], color="k", lw=1.0, label="commanded speed")
    a3.set_ylabel("speed [m/s]")
    for label, color, windows, (low, high) in event_strips(event_spans(t, ev)):
        for i, (a, b) in enumerate(windows):
            a3.axvspan(a, b, ymin=low, ymax=high, color=color, alpha=0.3, lw=0, label=label if i == 0 else None)
    clear = {k.split("__", 1)[1]: v for k, v in ev.items() if k.startswith("clearance__")}
    if clear:
        a4 = a3.twinx()
        for oid, c in clear.items():
            a4.plot(t, c, lw=1.0, label=f"clearance to {oid}")
        a4.set_ylabel("clearance [m]")
        a4.legend(loc="upper right", fontsize=7)
    if a3.get_legend_handles_labels()[0]:
        a3.legend(loc="upper left", fontsize=7, ncol=3)
    a1.set_title(title or "guidance errors", y=_TITLE_Y)
    return _save(fig, out, make_dir)


def error_labels(series: Mapping[str, NDArray[np.float64]]) -> tuple[str, str]:
    """The axis labels of the lateral and heading errors that fit the vehicle that recorded ``series``.

    A steered vehicle records seed 000's ``xi_r``: its heading error is the wheel heading error
    ξ_r and its lateral error that of C (ε_c), O (ε_o) or, after point switching, of the point
    guided at each instant (``point_offset`` > 0: C). A holonomic vehicle (its plant records the
    lateral body speed ``v_y``) has no steered wheel: its body heading is measured against the path
    tangent plus the segment's yaw offset. Any other vehicle: the body heading against the path tangent.
    """
    if "xi_r" in series:
        off = np.asarray(series.get("point_offset", np.zeros(1)))
        if np.all(off > 0.0):
            lateral = "lateral error ε_c of C [mm]"
        elif np.all(off == 0.0):
            lateral = "lateral error ε_o of O [mm]"
        else:
            lateral = "lateral error of the guided point (C or O) [mm]"
        return lateral, "wheel heading error ξ_r [deg]"
    if "v_y" in series:
        return "lateral error [mm]", "heading error vs tangent + yaw offset [deg]"
    return "lateral error [mm]", "heading error vs path tangent [deg]"


def _windows(t: NDArray[np.float64], mask: NDArray[np.bool_]) -> list[tuple[float, float]]:
    """``[(start, end), ...]`` (s) of the runs of True in ``mask`` (end: the next sample, or the last)."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(float(t[int(a)]), float(t[min(int(b), t.size - 1)])) for a, b in zip(starts, ends, strict=True)]


def event_spans(
    t: NDArray[np.float64], series: Mapping[str, NDArray[np.float64]]
) -> list[tuple[str, str, list[tuple[float, float]]]]:
    """``(label, colour, windows)`` of the events recorded in ``series`` that happened (windows in s).

    Injected faults (``fault__<i>_<kind>``), estimator not tracking (``est_status`` != 1), the
    positioning guard slowing or stopping (``guard_level``), safety fields slowing or stopping
    (``reaction_level``), and station stops (``dwelling``).
    """
    out: list[tuple[str, str, list[tuple[float, float]]]] = []

    def add(label: str, colour: str, mask: NDArray[np.bool_]) -> None:
        w = _windows(t, mask)
        if w:
            out.append((label, colour, w))

    for key in sorted(k for k in series if k.startswith("fault__")):
        add(f"fault {key.split('__', 1)[1].replace('_', ' ', 1)}", "0.55", np.asarray(series[key]) > 0.5)
    if "est_status" in series:
        st = np.asarray(series["est_status"])
        add("dead reckoning", "tab:cyan", st == 2.0)
        add("positioning degraded/lost", "tab:pink", (st != 1.0) & (st != 2.0))
    if "guard_level" in series:
        level = np.asarray(series["guard_level"])
        add("guard: slow", "gold", level == 1.0)
        add("guard: stop", "red", level >= 2.0)
    if "reaction_level" in series:
        level = np.asarray(series["reaction_level"])
        add("field: slow", "orange", level == 1.0)
        add("field: stop", "crimson", level >= 2.0)
    if "dwelling" in series:
        add("station stop", "tab:blue", np.asarray(series["dwelling"]) > 0.5)
    return out


def event_strips(
    spans: list[tuple[str, str, list[tuple[float, float]]]],
) -> list[tuple[str, str, list[tuple[float, float]], tuple[float, float]]]:
    """Each kind of :func:`event_spans` with its own horizontal strip ``(low, high)`` of the axes (0-1, top first).

    Windows of different kinds overlap in time (a goniometer blackout, the dead reckoning it causes,
    the guard slowing the vehicle): drawn over the full height their colours mix into one no legend
    names, and the fault disappears under the others. In strips, each keeps its legend colour.
    """
    n = len(spans)
    return [(label, colour, windows, (1.0 - (j + 1) / n, 1.0 - j / n))
            for j, (label, colour, windows) in enumerate(spans)]


def plot_positioning_histogram(
    e_lat: NDArray[np.float64], out: str | Path, title: str = "", *, make_dir: bool = True
) -> Path:
    """Histogram of the positioning lateral error e_lat (mm), as seed 000 Fig. 8."""
    e = 1000.0 * np.asarray(e_lat, dtype=np.float64)
    e = e[np.isfinite(e)]
    fig, ax = _take("histogram")
    if e.size:
        ax.hist(e, bins=min(40, max(5, e.size // 20)), color="tab:blue", edgecolor="k", alpha=0.8)
        ax.set_title(
            (title or "positioning lateral error")
            + f"\nmean |e| {np.mean(np.abs(e)):.1f} mm, std {np.std(e):.1f} mm, max |e| {np.max(np.abs(e)):.1f} mm",
            y=_TITLE_Y,
        )
    else:
        ax.set_title((title or "positioning lateral error") + "\n(no position fix)", y=_TITLE_Y)
    ax.set_xlabel("lateral error e_lat [mm]")
    ax.set_ylabel("samples")
    ax.grid(True, alpha=0.3)
    return _save(fig, out, make_dir)


def _map_axes() -> tuple[Any, Any]:
    """The map plot's empty figure and its two panels."""
    fig = _figure((12, 5.5))
    axes = fig.subplots(1, 2)
    fig.subplots_adjust(left=0.06, right=0.99, bottom=0.1, top=0.93, wspace=0.18)
    return fig, axes


def _errors_axes() -> tuple[Any, Any]:
    """The error plot's empty figure and its two panels (shared time axis)."""
    fig = _figure((9, 8))
    axes = fig.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": (3, 3, 2)})
    fig.subplots_adjust(left=0.1, right=0.92, bottom=0.07, top=0.95, hspace=0.08)
    return fig, axes


def _histogram_axes() -> tuple[Any, Any]:
    """The histogram's empty figure and its panel."""
    fig = _figure((7, 4.5))
    ax = fig.subplots()
    fig.subplots_adjust(left=0.11, right=0.97, bottom=0.12, top=0.86)
    return fig, ax


_MAKERS = {"map": _map_axes, "errors": _errors_axes, "histogram": _histogram_axes}

#: Empty figures made ahead by :func:`prepare`, by plot name; each is used once (popped).
_READY: dict[str, tuple[Any, Any]] = {}


def prepare(only: Collection[str] = ("map", "errors", "histogram")) -> None:
    """Make the empty figures and panels of the run plots ``only`` ahead of the data.

    Creating a figure and its axes and drawing them once empty (tick, spine and text objects,
    which the real drawing updates instead of creating) is data-free and about a fifth of
    drawing a plot; :class:`agvnav.report.plot_worker.PlotWorker`'s children do it while the
    run goes on (issue 11), and the next :func:`plot_map`, :func:`plot_errors` or
    :func:`plot_positioning_histogram` in this process draws into them. The files are the
    same as without it (tested byte for byte).
    """
    unknown = sorted(set(only) - set(_MAKERS))
    if unknown:
        raise ValueError(f"unknown plots {unknown}; the run plots are {list(_MAKERS)}")
    for name in only:
        if name not in _READY:
            made = _MAKERS[name]()
            made[0].canvas.draw()  # the empty panels once: ticks, spines and fonts made now, reused by the real draw
            _READY[name] = made


def _take(name: str) -> tuple[Any, Any]:
    """The figure and axes of plot ``name``: the one :func:`prepare` made (used once), else new ones."""
    made = _READY.pop(name, None)
    return made if made is not None else _MAKERS[name]()


def _figure(size: tuple[float, float]) -> Any:
    """A bare Agg figure of ``size`` inches (no pyplot: nothing to close, no global state)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: PLC0415  (lazy: see the module docstring)
    from matplotlib.figure import Figure  # noqa: PLC0415

    fig = Figure(figsize=size)
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Any, out: str | Path, make_dir: bool = True) -> Path:
    """Write ``fig`` as a PNG to ``out``; its folder is created only with ``make_dir`` (else it must exist)."""
    out = Path(out)
    if make_dir:
        out.parent.mkdir(parents=True, exist_ok=True)
    # zlib level 1: a quarter of the encoding time of the default 6 for ~15 % larger files
    fig.savefig(out, dpi=110, pil_kwargs={"compress_level": 1})
    return out


def warm_up() -> None:
    """Import matplotlib and draw a throw-away figure (fonts, text layout, Agg canvas), writing nothing.

    :class:`agvnav.report.plot_worker.PlotWorker` calls it in its child while the run goes on,
    so the run's plots find matplotlib ready.
    """
    fig = _figure((2.0, 1.5))
    ax = fig.subplots()
    ax.plot([0.0, 1.0], [0.0, 1.0], "o-")
    ax.set_title("warm-up ε ξ")
    ax.set_xlabel("x [m]")
    fig.canvas.draw()


#: The run plots :func:`write_plots` draws, in its order.
RUN_PLOTS = ("map", "errors", "histogram")


def write_plots(
    series: Mapping[str, NDArray[np.float64]],
    path_xy: NDArray[np.float64],
    reflector_xy: NDArray[np.float64],
    wall_segments: NDArray[np.float64],
    out_dir: str | Path,
    transient_end_s: float | None = None,
    title: str = "",
    only: Collection[str] = RUN_PLOTS,
    make_dir: bool = True,
) -> list[Path]:
    """Write map.png, errors.png and positioning_histogram.png from a run's series.

    ``series`` needs ``t``, ``x_tracked``, ``y_tracked`` (the true tracked point), ``x``,
    ``y``, ``psi``, ``est_x``, ``est_y``, ``est_psi``, ``est_valid``, ``lateral_error``,
    ``heading_error`` (the columns the simulator records); with ``est_x_C``/``est_y_C``
    the estimated path of the tracked point is drawn. The event columns, where recorded
    (:mod:`agvnav.sim.events`: faults, obstacles' tracks and clearances, positioning guard,
    safety fields, station stops), are drawn too: obstacles and stops on the map, the
    events under the errors; the error labels fit the vehicle (:func:`error_labels`). ``only`` names the plots to draw
    (of :data:`RUN_PLOTS`: ``map``, ``errors``, ``histogram``); the paths come in that order.
    ``make_dir`` creates ``out_dir`` (with its parents) first; without it ``out_dir`` must exist
    (the plot worker's children: a folder removed under them is never created again).
    """
    unknown = sorted(set(only) - set(RUN_PLOTS))
    if unknown:
        raise ValueError(f"unknown plots {unknown}; the run plots are {list(RUN_PLOTS)}")
    out_dir = Path(out_dir)
    if make_dir:
        out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    if "map" in only:
        driven = np.column_stack([series["x_tracked"], series["y_tracked"]])
        valid = series["est_valid"] > 0.5
        if "est_x_C" in series:
            est_xy = np.column_stack([series["est_x_C"], series["est_y_C"]])[valid] if np.any(valid) else None
        else:
            est_xy = np.column_stack([series["est_x"], series["est_y"]])[valid] if np.any(valid) else None
        obstacles = {k.split("__", 1)[1]: np.column_stack([series[k], series["obstacle_y__" + k.split("__", 1)[1]]])
                     for k in series if k.startswith("obstacle_x__")}
        stopped = np.zeros(np.shape(series["t"]), dtype=bool)
        for key in ("guard_level", "reaction_level"):
            if key in series:
                stopped |= np.asarray(series[key]) >= 2.0
        onset = np.flatnonzero(np.diff(stopped.astype(np.int8), prepend=0) == 1)
        guided = "point_offset" in series and np.ptp(series["point_offset"]) > 0.0
        written.append(plot_map(path_xy, driven, reflector_xy, wall_segments, out_dir / "map.png", est_xy, title,
                                make_dir=False, obstacles=obstacles, stops_xy=driven[onset],
                                obstacles_at_stops={k: v[onset] for k, v in obstacles.items()},
                                driven_label="driven, guided point C/O (truth)" if guided else "driven (truth)"))
    if "errors" in only:
        keys = ("v_cmd", "est_status", "guard_level", "reaction_level", "dwelling")
        events = {k: v for k, v in series.items() if k in keys or k.startswith(("fault__", "clearance__"))}
        written.append(plot_errors(
            series["t"], series["lateral_error"], series["heading_error"], out_dir / "errors.png",
            transient_end_s, title, make_dir=False, labels=error_labels(series), events=events,
        ))
    if "histogram" in only:
        valid = series["est_valid"] > 0.5
        true_pose = np.column_stack([series["x"], series["y"], series["psi"]])
        est_pose = np.column_stack([series["est_x"], series["est_y"], series["est_psi"]])
        e_lat = lateral_position_error(true_pose[valid], est_pose[valid])
        written.append(plot_positioning_histogram(e_lat, out_dir / "positioning_histogram.png", title,
                                                  make_dir=False))
    return written
