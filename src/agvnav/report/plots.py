"""PNG plots of a closed-loop run (seed 000 Figs. 8, 10 and 11).

matplotlib is imported lazily inside each function, with the non-interactive
Agg backend, so the math packages never need it.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import lateral_position_error

__all__ = ["plot_errors", "plot_map", "plot_positioning_histogram", "pyplot", "write_plots"]


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
) -> Path:
    """Map with walls, reflectors, the planned path and the driven path (seed 000 Fig. 10).

    ``path_xy``/``driven_xy``/``estimated_xy`` are ``(n, 2)`` polylines (m),
    ``reflector_xy`` ``(N, 2)``, ``wall_segments`` ``(M, 2, 2)``. Two panels: the
    whole map and a close-up of the path.
    """
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.5))
    for ax in axes:
        for seg in np.asarray(wall_segments).reshape(-1, 2, 2):
            ax.plot(seg[:, 0], seg[:, 1], color="0.4", lw=1.2)
        r = np.asarray(reflector_xy).reshape(-1, 2)
        ax.plot(r[:, 0], r[:, 1], "o", ms=6, mfc="gold", mec="k", label="reflectors")
        ax.plot(path_xy[:, 0], path_xy[:, 1], "--", color="tab:blue", lw=1.5, label="planned path")
        ax.plot(driven_xy[:, 0], driven_xy[:, 1], color="tab:red", lw=1.2, label="driven (truth)")
        if estimated_xy is not None:
            ax.plot(estimated_xy[:, 0], estimated_xy[:, 1], color="tab:green", lw=0.8, alpha=0.8, label="estimated")
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.grid(True, alpha=0.3)
    pts = np.concatenate([path_xy, driven_xy])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.15 * max(hi - lo) + 0.2
    axes[1].set_xlim(lo[0] - pad, hi[0] + pad)
    axes[1].set_ylim(lo[1] - pad, hi[1] + pad)
    axes[0].set_title(title or "map")
    axes[1].set_title("path detail")
    axes[1].legend(loc="best", fontsize=8)
    return _save(fig, plt, out)


def plot_errors(
    t: NDArray[np.float64],
    lateral_error: NDArray[np.float64],
    wheel_heading_error: NDArray[np.float64],
    out: str | Path,
    transient_end_s: float | None = None,
    title: str = "",
) -> Path:
    """Lateral error eps_c (mm) and wheel heading error xi_r (deg) against time (seed 000 Fig. 11)."""
    plt = pyplot()
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    a1.plot(t, 1000.0 * lateral_error, color="tab:blue")
    a1.set_ylabel("lateral error ε_c [mm]")
    a2.plot(t, np.rad2deg(wheel_heading_error), color="tab:orange")
    a2.set_ylabel("wheel heading error ξ_r [deg]")
    a2.set_xlabel("time [s]")
    for ax in (a1, a2):
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.grid(True, alpha=0.3)
        if transient_end_s is not None:
            ax.axvline(transient_end_s, color="k", ls=":", lw=1.0, label="end of transient")
    if transient_end_s is not None:
        a1.legend(loc="best", fontsize=8)
    a1.set_title(title or "guidance errors")
    return _save(fig, plt, out)


def plot_positioning_histogram(e_lat: NDArray[np.float64], out: str | Path, title: str = "") -> Path:
    """Histogram of the positioning lateral error e_lat (mm), as seed 000 Fig. 8."""
    plt = pyplot()
    e = 1000.0 * np.asarray(e_lat, dtype=np.float64)
    e = e[np.isfinite(e)]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    if e.size:
        ax.hist(e, bins=min(40, max(5, e.size // 20)), color="tab:blue", edgecolor="k", alpha=0.8)
        ax.set_title(
            (title or "positioning lateral error")
            + f"\nmean |e| {np.mean(np.abs(e)):.1f} mm, std {np.std(e):.1f} mm, max |e| {np.max(np.abs(e)):.1f} mm"
        )
    else:
        ax.set_title((title or "positioning lateral error") + "\n(no position fix)")
    ax.set_xlabel("lateral error e_lat [mm]")
    ax.set_ylabel("samples")
    ax.grid(True, alpha=0.3)
    return _save(fig, plt, out)


def _save(fig: Any, plt: Any, out: str | Path) -> Path:
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def write_plots(
    series: Mapping[str, NDArray[np.float64]],
    path_xy: NDArray[np.float64],
    reflector_xy: NDArray[np.float64],
    wall_segments: NDArray[np.float64],
    out_dir: str | Path,
    transient_end_s: float | None = None,
    title: str = "",
) -> list[Path]:
    """Write map.png, errors.png and positioning_histogram.png from a run's series.

    ``series`` needs ``t``, ``x_tracked``, ``y_tracked`` (the true tracked point), ``x``,
    ``y``, ``psi``, ``est_x``, ``est_y``, ``est_psi``, ``est_valid``, ``lateral_error``,
    ``heading_error`` (the columns the simulator records); with ``est_x_C``/``est_y_C``
    the estimated path of the tracked point is drawn.
    """
    out_dir = Path(out_dir)
    driven = np.column_stack([series["x_tracked"], series["y_tracked"]])
    valid = series["est_valid"] > 0.5
    true_pose = np.column_stack([series["x"], series["y"], series["psi"]])
    est_pose = np.column_stack([series["est_x"], series["est_y"], series["est_psi"]])
    if "est_x_C" in series:
        est_c = np.column_stack([series["est_x_C"], series["est_y_C"]])
        est_xy = est_c[valid] if np.any(valid) else None
    else:
        est_xy = est_pose[valid, :2] if np.any(valid) else None
    e_lat = lateral_position_error(true_pose[valid], est_pose[valid])
    return [
        plot_map(path_xy, driven, reflector_xy, wall_segments, out_dir / "map.png", est_xy, title),
        plot_errors(
            series["t"], series["lateral_error"], series["heading_error"], out_dir / "errors.png",
            transient_end_s, title,
        ),
        plot_positioning_histogram(e_lat, out_dir / "positioning_histogram.png", title),
    ]
