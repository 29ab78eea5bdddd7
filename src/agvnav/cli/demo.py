"""``agvnav demo``: triangulate a vehicle on a built-in reflector layout and print a table.

The goniometer is the seed's (65535 pulses/rev, seed 000 §4.1): bearings are quantised
to the pulse; the odometric heading estimate is off by a few degrees. One pose sits on
the critical circle of the first three reflectors, where relative angles fail and
absolute angles fall back on the heading estimate (seed 000, §2.3). Degrees appear only
here, at the user's edge, and are labelled.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import typer

from agvnav.bench.common import Col, print_table
from agvnav.cli.errors import user_errors
from agvnav.geometry import angle_diff, bearing_to, circumcentre
from agvnav.positioning import METHODS, encoder_bearing_std, triangulate

#: A 20 m x 14 m hall with five wall reflectors (m); the first three are "in view" for the
#: three-reflector methods, least squares uses all five.
LAYOUT = np.array([[0.0, 7.0], [10.0, 14.0], [20.0, 7.0], [10.0, 0.0], [2.0, 13.0]])


def demo_poses() -> np.ndarray:
    """Vehicle poses ``(k, 3)`` (m, m, rad): three ordinary ones and one on the critical circle."""
    centre, _ = circumcentre(LAYOUT[0], LAYOUT[1], LAYOUT[2])
    radius = float(np.linalg.norm(LAYOUT[0] - centre))
    on_circle = centre + radius * np.array([math.cos(2.5), math.sin(2.5)])  # inside the hall
    return np.array(
        [
            [5.0, 5.0, math.radians(30.0)],
            [12.0, 8.0, math.radians(95.0)],
            [15.0, 3.0, math.radians(-120.0)],
            [on_circle[0], on_circle[1], math.radians(10.0)],
        ]
    )


def demo_rows(pulses_per_rev: int = 65535, heading_error_deg: float = 1.0) -> list[dict[str, Any]]:
    """One row per (pose, method): truth, estimate and error, in SI units.

    Bearings are the exact ones rounded to the encoder pulse ``2 pi / pulses_per_rev``; the
    heading estimate's std is taken as the size of its error (used on the critical circle).
    """
    sigma = encoder_bearing_std(pulses_per_rev)
    step = 2.0 * math.pi / pulses_per_rev
    rows: list[dict[str, Any]] = []
    for k, pose in enumerate(demo_poses(), start=1):
        bearings = np.round(bearing_to(pose, LAYOUT) / step) * step
        estimate = pose[2] + math.radians(heading_error_deg)
        heading_std = max(abs(math.radians(heading_error_deg)), 1e-4)
        for method in METHODS:
            n = len(LAYOUT) if method == "least_squares" else 3
            fix = triangulate(
                LAYOUT[:n], bearings[:n], method, heading_estimate=estimate, bearing_std=sigma, heading_std=heading_std
            )
            rows.append(
                {
                    "pose": k,
                    "truth": pose,
                    "method": method,
                    "reflectors": n,
                    "fix": fix,
                    "position_error_m": float(math.hypot(fix.x - pose[0], fix.y - pose[1])),
                    "heading_error_rad": float(angle_diff(fix.heading, pose[2])),
                    "std_position_m": _position_std(fix.covariance),
                }
            )
    return rows


def _status(row: dict[str, Any]) -> str:
    """Status label; an invalid fix names its reason, derived from the geometry and the method."""
    fix = row["fix"]
    if fix.valid:
        return "heading from estimate" if fix.heading_from_estimate else "ok"
    return f"[red]invalid ({_invalid_reason(row)})[/red]"


def _invalid_reason(row: dict[str, Any]) -> str:
    truth = row["truth"]
    centre, ok = circumcentre(LAYOUT[0], LAYOUT[1], LAYOUT[2])
    radius = float(np.linalg.norm(LAYOUT[0] - centre))
    on_circle = bool(ok) and abs(float(np.linalg.norm(truth[:2] - centre)) - radius) < 1e-3 * radius
    if on_circle and row["reflectors"] == 3:
        return "critical circle"
    if row["method"] == "least_squares":
        return "no convergence"
    return "degenerate geometry"


#: The demo table's columns: header, justification, priority (0 kept longest on a narrow terminal).
DEMO_COLUMNS = [
    Col("pose", "right", 0), Col("true x, y (m)", "right", 3), Col("true heading (deg)", "right", 4),
    Col("method", "left", 0), Col("N", "right", 5), Col("x, y (m)", "right", 2), Col("heading (deg)", "right", 2),
    Col("position error (mm)", "right", 0), Col("heading error (deg)", "right", 1),
    Col("1-sigma position (mm)", "right", 1), Col("status", "left", 0),
]


def _table(
    rows: list[dict[str, Any]], pulses_per_rev: int, heading_error_deg: float
) -> tuple[str, list[Col], list[list[str]], str, list[bool]]:
    """``(title, columns, cells, caption, section ends)`` of the demo table."""
    sigma_mrad = encoder_bearing_std(pulses_per_rev) * 1e3
    title = "agvnav demo: goniometer triangulation on a 20 m x 14 m hall"
    caption = (
        f"encoder {pulses_per_rev} pulses/rev (bearing std {sigma_mrad:.4f} mrad); "
        f"heading estimate off by {heading_error_deg:+.1f} deg; pose 4 is on the critical circle"
    )
    cells: list[list[str]] = []
    ends: list[bool] = []
    for row in rows:
        fix, truth = row["fix"], row["truth"]
        ok = bool(fix.valid)
        cells.append([
            str(row["pose"]),
            f"{truth[0]:.3f}, {truth[1]:.3f}",
            f"{math.degrees(truth[2]):.2f}",
            row["method"],
            str(row["reflectors"]),
            f"{float(fix.x):.4f}, {float(fix.y):.4f}" if ok else "-",
            f"{math.degrees(float(fix.heading)):.3f}" if ok else "-",
            f"{row['position_error_m'] * 1e3:.3f}" if ok else "-",
            f"{math.degrees(row['heading_error_rad']):.4f}" if ok else "-",
            f"{row['std_position_m'] * 1e3:.3f}" if ok and math.isfinite(row["std_position_m"]) else "-",
            _status(row),
        ])
        ends.append(row["method"] == METHODS[-1])
    return title, DEMO_COLUMNS, cells, caption, ends


@user_errors
def demo(
    pulses_per_rev: int = typer.Option(65535, "--pulses-per-rev", help="Goniometer encoder pulses per revolution."),
    heading_error_deg: float = typer.Option(
        1.0, "--heading-error-deg", help="Error of the odometric heading estimate, in degrees."
    ),
    wide: bool = typer.Option(False, "--wide", help="Print every column, however wide the terminal."),
) -> None:
    """Triangulate a vehicle on a built-in reflector layout and print a table."""
    _check_options(pulses_per_rev, heading_error_deg)
    rows = demo_rows(pulses_per_rev, heading_error_deg)
    title, cols, cells, caption, ends = _table(rows, pulses_per_rev, heading_error_deg)
    print_table((title, cols, cells), wide=wide, caption=caption, sections=ends)


def _check_options(pulses_per_rev: int, heading_error_deg: float) -> None:
    """Validate the options at the edge, naming them as the user typed them."""
    if pulses_per_rev < 3:
        raise ValueError(f"--pulses-per-rev must be an integer >= 3, got {pulses_per_rev}")
    if not math.isfinite(heading_error_deg) or abs(heading_error_deg) > 90.0:
        raise ValueError(f"--heading-error-deg must be a finite number in [-90, 90] degrees, got {heading_error_deg}")


def _position_std(covariance: np.ndarray | None) -> float:
    """sqrt of the position variance (m); NaN when the method gives no covariance."""
    if covariance is None:
        return math.nan
    return float(np.sqrt(covariance[0, 0] + covariance[1, 1]))
