"""``agvnav simulate [SCENARIO] [--out DIR] [--seed N] [--force]``: the product's main job.

Runs a closed-loop scenario (the seed-000 guidance test in the lab when none is
given) with a progress bar, prints a summary table and writes ``DIR/metrics.json``,
``DIR/timing.json``, ``DIR/timeseries.csv``, ``DIR/reflections.csv`` and the PNG
plots, all at once at the end (:func:`agvnav.report.files.atomic_dir`); a DIR that
holds another run is refused (exit 2) unless ``--force``. A run that ran but
failed exits 3 after one line ``run FAILED: <reason>``. Argument parsing and
printing only; the work is :func:`agvnav.sim.simulate`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn
from rich.table import Table

from agvnav.cli.errors import fail, user_errors

SCENARIO_ARG = typer.Argument(
    None, help="Scenario YAML file or shipped scenario name (default: guidance_test, seed 000 §4.3)."
)
OUT_OPT = typer.Option(Path("sim_out"), "--out", "-o", help="Output folder for metrics.json, CSV series and PNG plots.")
SEED_OPT = typer.Option(None, "--seed", min=0, help="Random seed (overrides the scenario's); same seed, same run.")
PLOTS_OPT = typer.Option(True, "--plots/--no-plots", help="Write the PNG plots.")
FORCE_OPT = typer.Option(False, "--force", help="Replace an --out folder that holds another run's results.")
LOG_OPT = typer.Option(None, "--log", help="Also write the run as an MCAP file of ROS 2 messages (docs/logs.md).")
REPORT_OPT = typer.Option(False, "--report", help="Also write DIR/report.html, a self-contained HTML report.")


@user_errors
def simulate(
    scenario: str | None = SCENARIO_ARG,
    out: Path = OUT_OPT,
    seed: int | None = SEED_OPT,
    plots: bool = PLOTS_OPT,
    force: bool = FORCE_OPT,
    log: Path | None = LOG_OPT,
    report: bool = REPORT_OPT,
) -> None:
    """Run a closed-loop scenario; write metrics.json, timing.json, time series (CSV) and plots."""
    from agvnav.world.scenario import default_scenario, load_scenario

    sc = default_scenario() if scenario is None else load_scenario(scenario)
    if seed is not None:
        sc = sc.with_seed(seed)
    if sc.route is not None:  # the seed-004 automaton on its square route
        if log is not None or report:
            raise fail("--log and --report are for path scenarios; a route scenario writes laps")
        return _simulate_route(sc, out, plots, force)
    if log is not None and log.suffix != ".mcap":
        raise fail(f"--log {log}: the log file must end in .mcap")
    from agvnav.report.files import save_result
    from agvnav.sim import simulate as run_scenario
    from agvnav.sim.build import build

    build(sc)  # validate every cross-part rule before the progress bar starts
    _prepare_out(out, force)
    console = Console(highlight=False)
    result = _with_progress(console, sc.name, run_scenario, sc)
    written = save_result(result, out, plots=plots, force=force, report=report)
    if log is not None:
        try:
            from agvnav.logs import write_run_log
        except ImportError as exc:
            raise fail(f"--log needs the logs extra (pip install 'agvnav[logs]'): {exc}") from None
        counts = write_run_log(result, log)
        console.print(f"log {log}: {sum(counts.values())} messages on {len(counts)} topics")
    console.print(_summary(result))
    console.print(f"wrote {len(written)} files to {out}/: " + ", ".join(p.name for p in written))
    if not result.completed:
        console.print(f"run FAILED: {result.reason}")
        raise typer.Exit(RUN_FAILED_EXIT)
    return None


#: Exit code of a run that ran but failed (distinct from a user error's 2).
RUN_FAILED_EXIT = 3


def _with_progress(console: Console, name: str, run: Any, sc: Any) -> Any:
    """``run(sc, progress=...)`` under a transient progress bar of simulated time."""
    with Progress(
        TextColumn(f"[bold]{name}[/bold]"),
        BarColumn(),
        TextColumn("{task.fields[t]:7.2f} s simulated"),
        TimeRemainingColumn(),
        console=console,
        transient=True,
    ) as bar:
        task = bar.add_task("simulate", total=None, t=0.0)
        return run(sc, progress=lambda t: bar.update(task, t=t))


def _simulate_route(sc: Any, out: Path, plots: bool, force: bool) -> None:
    """The seed-004 tracked robot on its square route: laps with and without landmarks (Tables I-II)."""
    from agvnav.report.files import atomic_dir
    from agvnav.report.laps import save_laps, summary_table
    from agvnav.sim.laps import prepare_tracked, simulate_tracked

    prepare_tracked(sc)  # validate before the progress bar
    _prepare_out(out, force)
    console = Console(highlight=False)
    result = _with_progress(console, sc.name, simulate_tracked, sc)
    with atomic_dir(out, force) as tmp:
        written = [out / p.name for p in save_laps(result, tmp, plots)]
    console.print(summary_table(result))
    console.print(f"wrote {len(written)} files to {out}/: " + ", ".join(p.name for p in written))


def _prepare_out(out: Path, force: bool) -> None:
    """Before the run: refuse a folder holding another run (unless ``force``); check the parent is writable.

    Exit 2 with one line if not. Nothing is created yet: the results arrive all at once.
    """
    from agvnav.report.files import check_out_dir

    if out.exists() and not out.is_dir():
        raise fail(f"--out {out}: cannot create the output folder (it is a file)")
    check_out_dir(out, force)
    parent = out.absolute().parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
        probe = parent / f".{out.name}.agvnav_write_check"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise fail(f"--out {out}: cannot create the output folder ({reason})") from None


def _fmt(value: float | None, scale: float = 1.0, digits: int = 1) -> str:
    """``digits`` decimals; values below 1 in magnitude with 2 significant figures (0.036, not 0.0)."""
    if value is None or not math.isfinite(value):
        return "-"
    v = value * scale
    if v != 0.0 and abs(v) < 1.0:
        return f"{v:.2g}"
    return f"{v:.{digits}f}"


#: Below this initial lateral error (m) a run has no transient to correct: seed 000 §4.3's
#: 110 mm start does not apply to it.
NO_TRANSIENT_M = 1e-3


def _summary(result) -> Table:  # type: ignore[no-untyped-def]
    m = result.metrics
    t = Table(title=f"{result.scenario.name}: {result.scenario.vehicle.model} (seed {result.scenario.seed})")
    t.add_column("metric")
    t.add_column("value", justify="right")
    t.add_column("seed 000", justify="right")
    e0 = m.initial_lateral_error_m
    transient = e0 is not None and math.isfinite(e0) and abs(e0) > NO_TRANSIENT_M
    ref = (lambda text: text) if transient else (lambda text: "")
    after = " after transient" if transient else ""
    rows = [
        ("initial lateral error (mm)", _fmt(e0, 1e3), ref("110")),
        # no seed column here: after the band-defined transient this maximum is the band itself
        # (issue 13); the seed's 16.5 mm and 3.8 deg are compared on their own definition by
        # `agvnav bench seeds` (sim.metrics.guidance_figures)
        (f"max |lateral error|{after} (mm)", _fmt(m.max_abs_lateral_error_m, 1e3), ""),
        (f"RMS lateral error{after} (mm)", _fmt(m.rms_lateral_error_m, 1e3), ""),
        (
            f"max |wheel heading error|{after} (deg)",
            _fmt(m.max_abs_wheel_heading_error_rad, 180 / math.pi, 2),
            "",
        ),
    ]
    if transient:
        rows.append(("settling distance (m)", _fmt(m.settling_distance_m, 1.0, 3), ""))
    rows += [
        ("positioning RMS (mm)", _fmt(m.positioning_rms_m, 1e3), ""),
        ("positioning mean |e_lat| (mm)", _fmt(m.positioning_lateral_mean_abs_m, 1e3), "9.7"),
        ("positioning std e_lat (mm)", _fmt(m.positioning_lateral_std_m, 1e3), ""),  # the seed's 6.6 is std |e_lat|
        ("positioning max |e_lat| (mm)", _fmt(m.positioning_lateral_max_abs_m, 1e3), "23"),
        ("outcome", result.outcome + (f" ({result.reason})" if result.reason else ""), ""),
        ("simulated time (s)", _fmt(m.sim_time_s, 1.0, 2), ""),
        ("wall time (s)", _fmt(m.wall_time_s, 1.0, 3), ""),
        ("real-time factor", _fmt(m.real_time_factor, 1.0, 0), ""),
    ]
    for r in rows:
        t.add_row(*r)
    return t
