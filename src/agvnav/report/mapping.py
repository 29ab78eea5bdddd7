"""Plot of a mapped reflector map: reflectors with their uncertainty ellipses and the driven trajectory."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from agvnav.mapping import MappingResult
from agvnav.report.plots import pyplot
from agvnav.world import WorldMap

__all__ = ["ellipse_points", "plot_mapping"]


def ellipse_points(cov: np.ndarray, centre: np.ndarray, n_sigma: float = 3.0, k: int = 64) -> np.ndarray:
    """``(k, 2)`` points of the ``n_sigma`` ellipse of the 2x2 covariance ``cov`` (m²) around ``centre`` (m)."""
    vals, vecs = np.linalg.eigh(0.5 * (cov + cov.T))
    a = np.linspace(0.0, 2.0 * np.pi, k)
    circle = np.stack([np.cos(a), np.sin(a)], axis=1) * n_sigma * np.sqrt(np.maximum(vals, 0.0))
    return np.asarray(centre + circle @ vecs.T)


def plot_mapping(result: MappingResult, out: str | Path, truth: WorldMap | None = None,
                 magnify: float | None = None) -> Path:
    """Write a PNG: trajectory, mapped reflectors with 3σ ellipses magnified ``magnify`` times
    (default: the power of ten that makes the largest about 0.5 m), their ids, and the true
    reflectors and walls of ``truth`` when given."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 6))
    try:
        if truth is not None:
            for seg in truth.wall_segments:
                ax.plot(seg[:, 0], seg[:, 1], color="0.5", lw=1.0)
            ax.plot(truth.reflector_xy[:, 0], truth.reflector_xy[:, 1], "x", color="k", ms=6, label="true reflectors")
        ax.plot(result.poses[:, 0], result.poses[:, 1], color="tab:blue", lw=1.0, label="driven (estimated)")
        big = max((float(np.sqrt(np.linalg.eigvalsh(c).max())) for c in result.covariance), default=1e-3)
        if magnify is None:
            magnify = float(10.0 ** np.round(np.log10(0.5 / (3.0 * max(big, 1e-9)))))
        for rid, xy, cov in zip(result.ids, result.xy, result.covariance, strict=True):
            e = ellipse_points(cov * magnify ** 2, xy)
            ax.plot(e[:, 0], e[:, 1], color="tab:red", lw=1.0)
            ax.plot(xy[0], xy[1], "o", color="tab:red", ms=3)
            ax.annotate(rid, xy, textcoords="offset points", xytext=(4, 4), fontsize=7)
        ax.plot([], [], color="tab:red", label=f"mapped, 3σ ellipse ×{magnify:g}")
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(f"reflector map: {len(result.ids)} reflectors, anchored by {result.anchor}")
        ax.legend(loc="best", fontsize=8)
        path = Path(out)
        fig.savefig(path, dpi=120, bbox_inches="tight")
    finally:
        plt.close(fig)
    return path
