"""Plots of simulation runs (matplotlib, Agg backend, imported lazily)."""

from agvnav.report.plots import plot_errors, plot_map, plot_positioning_histogram, write_plots

__all__ = ["plot_errors", "plot_map", "plot_positioning_histogram", "write_plots"]
