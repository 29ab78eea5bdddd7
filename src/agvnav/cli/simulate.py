"""``agvnav simulate [SCENARIO] [--out DIR] [--seed N] [--force] [--json] [--wide] [--jit on|off|auto]``.

The product's main job.

Runs a closed-loop scenario (the seed-000 guidance test in the lab when none is
given) with a progress bar on stderr (:class:`agvnav.cli.progress.RunProgress`),
prints a summary table in mm and degrees (the seed's figure beside a metric only
for a scenario that reproduces a seed experiment; with reactive control also the
stops, time stopped and each obstacle's minimum clearance and encounter result) and
writes ``DIR/metrics.json``, ``DIR/timing.json``, ``DIR/timeseries.csv``, ``DIR/reflections.csv`` and the PNG
plots, all at once at the end (:func:`agvnav.report.files.atomic_dir`); a DIR that
holds another run is refused (exit 2) unless ``--force``. A run that ran but
failed exits 3 after one line ``run FAILED: <reason>``. ``--json`` prints the
metrics (metrics.json, timing and the run's metadata) as one JSON document on
stdout and everything else on stderr, for scripts. ``--jit`` picks the kernels' mode (numba or
plain Python; auto: the cheaper for the run), recorded as ``kernels`` in metrics.json and the
JSON metadata. Argument parsing and
printing only; the work is :func:`agvnav.sim.simulate`.
"""

from __future__ import annotations

import gc
import math
from contextlib import nullcontext
from pathlib import Path
from typing import Any

import typer
from rich.console import Console

from agvnav.bench.common import Col, print_table
from agvnav.cli.errors import fail, user_errors
from agvnav.cli.progress import RunProgress, expected_sim_time

SCENARIO_ARG = typer.Argument(
    None, help="Scenario YAML file or shipped scenario name (default: guidance_test, seed 000 §4.3)."
)
OUT_OPT = typer.Option(Path("sim_out"), "--out", "-o", help="Output folder for metrics.json, CSV series and PNG plots.")
SEED_OPT = typer.Option(None, "--seed", min=0, help="Random seed (overrides the scenario's); same seed, same run.")
PLOTS_OPT = typer.Option(True, "--plots/--no-plots", help="Write the PNG plots.")
FORCE_OPT = typer.Option(False, "--force", help="Replace an --out folder that holds another run's results.")
LOG_OPT = typer.Option(None, "--log", help="Also write the run as an MCAP file of ROS 2 messages (docs/logs.md).")
REPORT_OPT = typer.Option(False, "--report", help="Also write DIR/report.html, a self-contained HTML report.")
JSON_OPT = typer.Option(
    False, "--json", help="Print the metrics as JSON on stdout (with version, seed and machine); messages go to stderr."
)
WIDE_OPT = typer.Option(False, "--wide", help="Print every table column, however wide the terminal.")
JIT_OPT = typer.Option(
    "auto", "--jit", help="Kernels compiled by numba (on), plain Python (off), or the cheaper for this run (auto); "
    "recorded in metrics.json as kernels. Seeded runs repeat bit for bit within one mode.",
)


@user_errors
def simulate(
    scenario: str | None = SCENARIO_ARG,
    out: Path = OUT_OPT,
    seed: int | None = SEED_OPT,
    plots: bool = PLOTS_OPT,
    force: bool = FORCE_OPT,
    log: Path | None = LOG_OPT,
    report: bool = REPORT_OPT,
    json: bool = JSON_OPT,
    wide: bool = WIDE_OPT,
    jit: str = JIT_OPT,
) -> None:
    """Run a closed-loop scenario; write metrics.json, timing.json, time series (CSV) and plots."""
    # Start-up allocates some 90,000 long-lived objects (the schema, the simulator, NumPy; matplotlib in
    # the plot worker): cyclic collections meanwhile free nothing and cost 50-90 ms of CPU (issue 11).
    # Collection is off until the run is built (_collect_again), on again whatever happens.
    gc.disable()
    try:
        from agvnav.report.plot_worker import PlotWorker

        # forked before anything else (no thread yet): it readies matplotlib on the other core during the run
        with PlotWorker() if plots else nullcontext() as plotter:
            _simulate(scenario, out, seed, plots, force, log, report, json, wide, plotter, jit)
    finally:
        gc.unfreeze()  # a caller in the same process (a test's CLI runner) gets its collector back as it was
        gc.enable()


def _collect_again() -> None:
    """End of start-up: the objects alive now leave the collector's scans (``gc.freeze``); collection resumes."""
    gc.freeze()
    gc.enable()


def _simulate(
    scenario: str | None, out: Path, seed: int | None, plots: bool, force: bool, log: Path | None,
    report: bool, json: bool, wide: bool, plotter: Any, jit: str = "auto",
) -> None:
    from agvnav.world.scenario import ScenarioError, default_scenario, load_scenario

    if jit not in ("on", "off", "auto"):
        raise fail(f"--jit {jit}: expected on, off or auto")
    from agvnav.jit import set_compiled, set_compiled_for_run
    from agvnav.sim.reactive import interpreted_scans_s

    if jit != "auto":  # the user's choice wins over AGVNAV_JIT
        set_compiled(jit == "on", force=True)
    try:
        sc = default_scenario() if scenario is None else load_scenario(scenario)
    except ScenarioError as exc:
        if exc.key != ("fleet",) or scenario is None:
            raise
        return _simulate_fleet(scenario, out, seed, plots, force, log, report, json, wide, jit)
    if seed is not None:
        sc = sc.with_seed(seed)
    console = Console(highlight=False, stderr=json)  # with --json, stdout holds the JSON document only
    if sc.route is not None:  # the seed-004 automaton on its square route
        if log is not None or report:
            raise fail("--log and --report are for path scenarios; a route scenario writes laps")
        return _simulate_route(sc, out, plots, force, console, json, wide)
    if log is not None and log.suffix != ".mcap":
        raise fail(f"--log {log}: the log file must end in .mcap")
    from agvnav.report.files import save_result
    from agvnav.sim import simulate as run_scenario
    from agvnav.sim.build import build

    built = build(sc)  # validate every cross-part rule before the progress bar starts
    _collect_again()
    expected_s = expected_sim_time(sc, built)
    if jit == "auto":  # a short run with few reflectors is cheaper without numba's start-up
        set_compiled_for_run(expected_s, len(built.world.reflector_xy),
                             interpreted_scans_s(built.loop.sensors, expected_s))
    _prepare_out(out, force)
    with RunProgress(sc.name, expected_s, "s simulated") as bar:
        result = run_scenario(sc, progress=bar.update, built=built)
    parts = ["plots"] * plots + ["report"] * report
    with RunProgress(f"writing {out}", key=" ".join(["simulate save", *parts])):  # plots and report take seconds
        written = save_result(result, out, plots=plots, force=force, report=report, plotter=plotter)
    if log is not None:
        try:
            from agvnav.logs import write_run_log
        except ImportError as exc:
            raise fail(f"--log needs the logs extra (pip install 'agvnav[logs]'): {exc}") from None
        counts = write_run_log(result, log)
        console.print(f"log {log}: {sum(counts.values())} messages on {len(counts)} topics")
    if json:
        _print_json(result)
    else:
        print_table(_summary(result), wide=wide)
    _written_and_judged(console, out, written, result.completed, f"run FAILED: {result.reason}")
    return None


def _simulate_fleet(
    scenario: str, out: Path, seed: int | None, plots: bool, force: bool, log: Path | None, report: bool, json: bool,
    wide: bool, jit: str = "auto",
) -> None:
    """A fleet scenario (issue 28): every vehicle in one world, stepped in lockstep; one row per vehicle."""
    from agvnav.jit import set_compiled_for_run
    from agvnav.report.fleet import fleet_document, save_fleet, timing_fleet
    from agvnav.sim.fleet import build_fleet, run_fleet
    from agvnav.sim.reactive import interpreted_scans_s
    from agvnav.world.fleet import load_fleet

    if log is not None:
        raise fail("--log is for single-vehicle scenarios; a fleet writes its metrics, series and plots")
    fleet = load_fleet(scenario)
    if seed is not None:
        fleet = fleet.copy_attached({"seed": int(seed)})
    console = Console(highlight=False, stderr=json)
    built = build_fleet(fleet)  # every cross-vehicle rule checked before the progress bar starts
    _collect_again()
    if jit == "auto":  # else --jit forced the mode already
        set_compiled_for_run(built.duration * len(built.ids), len(built.built[0].world.reflector_xy),
                             sum(interpreted_scans_s(b.loop.sensors, built.duration) for b in built.built))
    _prepare_out(out, force)
    with RunProgress(fleet.name, built.duration, "s simulated") as bar:
        result = run_fleet(built, progress=bar.update)
    with RunProgress(f"writing {out}", key="simulate fleet save" + " plots" * plots + " report" * report):
        written = save_fleet(result, out, plots=plots, force=force, report=report)
    if json:
        from agvnav.bench.common import json_document

        body = {"metrics": fleet_document(result), "timing": timing_fleet(result)}
        print(json_document("scenario", fleet.name, body, fleet.seed, None))
    else:
        print_table(_fleet_table(result), wide=wide)
    _written_and_judged(console, out, written, result.completed, f"fleet run FAILED: {result.reason}")


def _written_and_judged(console: Console, out: Path, written: list[Path], completed: bool, failed: str) -> None:
    """Name the files written, then judge the run: a failed one says so in one line and exits 3."""
    console.print(f"wrote {len(written)} files to {out}/: " + ", ".join(p.name for p in written), soft_wrap=True)
    if not completed:
        console.print(failed)
        raise typer.Exit(RUN_FAILED_EXIT)


def _fleet_table(result: Any) -> tuple[str, list[Col], list[list[str]]]:
    """One row per vehicle and the fleet's totals: outcome, jobs, slowed/stopped time and why, separation."""
    f = result.figures
    cols = [Col("vehicle", "left", 0), Col("model", "left", 2), Col("outcome", "left", 0, wrap=True),
            Col("jobs done", "right", 0), Col("deliveries", "right", 1), Col("distance (m)", "right", 2),
            Col("slowed / stopped positioning (s)", "right", 1), Col("slowed / stopped fields (s)", "right", 1),
            Col("min separation (m)", "right", 0)]
    traffic = "traffic_wait_s" in f
    if traffic:
        cols.append(Col("waited for traffic (s): most at, for", "right", 1, wrap=True))
    rows = []
    for v in result.vehicles:
        outcome = v["outcome"] + (f" ({v['reason']})" if v["reason"] else "")
        near = f"{_fmt(v['min_separation_m'], 1.0, 2)} ({v['nearest_vehicle']})" if v["nearest_vehicle"] else "-"
        guard = f"{_fmt(v['time_slowed_positioning_s'], 1.0, 1)} / {_fmt(v['time_stopped_positioning_s'], 1.0, 1)}"
        fields = f"{_fmt(v['time_slowed_fields_s'], 1.0, 1)} / {_fmt(v['time_stopped_fields_s'], 1.0, 1)}"
        rows.append([v["id"], v["model"], outcome, f"{v['jobs_completed']} / {v['jobs']}", str(v["deliveries"]),
                     _fmt(v["distance_m"], 1.0, 1), guard, fields, near])
        if traffic:
            rows[-1].append(_traffic_wait(v))
    pair = f" ({' - '.join(f['min_separation_pair'])})" if f["min_separation_pair"] else ""
    rows.append([
        "fleet", f"{f['vehicles']} vehicles", result.outcome + (f" ({result.reason})" if result.reason else ""),
        f"{f['jobs_completed']} / {f['jobs']}", f"{f['deliveries']} ({_fmt(f['deliveries_per_hour'], 1.0, 1)}/h)",
        f"{f['collisions']} collisions", f"sim {_fmt(f['sim_time_s'], 1.0, 1)} s",
        f"RTF {_fmt(f['real_time_factor_cpu'], 1.0, 1)} (CPU)", _fmt(f["min_separation_m"], 1.0, 2) + pair,
    ])
    if traffic:
        rows[-1].append(f"{_fmt(f['traffic_wait_s'], 1.0, 1)} ({f['traffic_conflicts']} conflicts)")
    title = f"{result.fleet.name}: fleet of {len(result.ids)} (seed {result.fleet.seed})"
    return title, cols, rows


def _traffic_wait(v: dict[str, Any]) -> str:
    """A vehicle's time waiting for traffic (s), the node it waited at most and the zone it waited for most."""
    wait = _fmt(v["traffic_wait_s"], 1.0, 1)
    zones = v.get("traffic_wait_by_zone_s") or {}
    if not v.get("traffic_wait_most_at"):
        return wait
    return f"{wait}: {v['traffic_wait_most_at']}, {max(zones, key=lambda k: zones[k])}"


def _print_json(result: Any) -> None:
    """The metrics of ``result`` (metrics.json, timing.json) and who produced them, as JSON on stdout."""
    from agvnav.bench.common import json_document
    from agvnav.report.files import metrics_document, timing_document

    body = {"metrics": metrics_document(result), "timing": timing_document(result)}
    print(json_document("scenario", result.scenario.name, body, result.scenario.seed, None))


#: Exit code of a run that ran but failed (distinct from a user error's 2).
RUN_FAILED_EXIT = 3


def _simulate_route(sc: Any, out: Path, plots: bool, force: bool, console: Console, json: bool, wide: bool) -> None:
    """The seed-004 tracked robot on its square route: laps with and without landmarks (Tables I-II)."""
    from agvnav.report.files import atomic_dir
    from agvnav.report.laps import save_laps, summary_table
    from agvnav.sim.laps import nominal_lap_time, prepare_tracked, simulate_tracked

    parts = prepare_tracked(sc)  # validate before the progress bar
    _collect_again()
    _prepare_out(out, force)
    passes = 2 if sc.controller.compare_landmarks else 1
    lap = sc.duration_s or sc.controller.laps * nominal_lap_time(parts.route, parts.params)
    with RunProgress(sc.name, passes * lap, "s simulated") as bar:
        result = simulate_tracked(sc, progress=bar.update)
    with atomic_dir(out, force) as tmp:
        written = [out / p.name for p in save_laps(result, tmp, plots)]
    if json:
        from agvnav.bench.common import json_document

        body = {"modes": result.mode_summary(), "laps": result.lap_rows()}
        print(json_document("scenario", sc.name, body, sc.seed, None))
    else:
        print_table(summary_table(result), wide=wide)
    console.print(f"wrote {len(written)} files to {out}/: " + ", ".join(p.name for p in written), soft_wrap=True)


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


def _seed_column(name: str) -> dict[str, str]:
    """The seed's figure per metric key when scenario ``name`` reproduces a seed experiment, else {}."""
    from agvnav.report.html import SEED_FIGURES

    for prefix, figures in SEED_FIGURES.items():
        if name.startswith(prefix):
            return {key: value for key, (value, _source) in figures.items()}
    return {}


def _reactive_rows(result: Any) -> list[tuple[str, str, str]]:
    """Summary rows of the reactive control (issue 18), none for a run without it.

    Stops, time stopped, detours, the largest excursion beyond the corridor (when there is one),
    then per obstacle its minimum clearance and how the encounter ended; headers and units by
    :func:`agvnav.bench.common.display_unit` (a clearance below 1 m in mm).
    """
    from agvnav.bench.common import display_unit, format_number
    from agvnav.report.files import reactive_document

    doc = reactive_document(result)
    if doc is None:
        return []

    def row(key: str, value: Any, label: str | None = None) -> tuple[str, str, str]:
        header, _unit, scale = display_unit(key, [value])
        if label is not None:  # the key's own words replaced, its unit kept
            header = label + header[len(header.split(" (")[0]):]
        return header, format_number(value, scale), ""

    rows = [row("emergency_stops", doc["stops"]), row("time_stopped_s", doc["time_stopped_s"])]
    if doc["detours"]:
        rows.append(row("detours", doc["detours"]))
    if doc["max_corridor_excess_m"] is not None:
        rows.append(row("max_corridor_excess_m", doc["max_corridor_excess_m"]))
    for oid, ob in doc["obstacles"].items():
        rows.append(row("min_clearance_m", ob["min_clearance_m"], f"min clearance to {oid}"))
        rows.append((f"encounter with {oid}", str(ob["result"]), ""))
    return rows


def _heading_rows(result: Any, after: str) -> list[tuple[str, str, str]]:
    """The heading figure that fits the vehicle (issue 29): seed 000's wheel heading error xi_r for a steered
    vehicle, else the body heading against the path's reference heading (a holonomic vehicle's yaw
    offset included), read past each reorientation when the reference steps."""
    from agvnav.sim.metrics import REORIENTATION_M
    from agvnav.world.vehicle_specs import vehicle_kind

    m = result.metrics
    wheel = getattr(m, "max_abs_wheel_heading_error_rad", None)
    if wheel is not None or vehicle_kind(result.scenario.vehicle.model).family == "steered":
        return [(f"max |wheel heading error ξ_r|{after} (deg)", _fmt(wheel, 180 / math.pi, 2), "")]
    turns = int(getattr(m, "heading_reorientations", 0) or 0)
    value = _fmt(getattr(m, "max_abs_heading_error_rad", None), 180 / math.pi, 2)
    if not turns:
        return [(f"max |heading error|{after} (deg)", value, "")]
    return [
        ("reorientations (reference heading steps)", str(turns), ""),
        (f"max |heading error|{after}, from {REORIENTATION_M:g} m past each (deg)", value, ""),
    ]


def _window(a: float, b: float) -> str:
    return f"{a:.2f}-{b:.2f} s"


def _mission_rows(result: Any) -> list[tuple[str, str, str]]:
    """Station stops, stop errors, mission time and the lateral error per edge kind (issue 14 figures)."""
    x = getattr(result, "extra", {}) or {}
    if "stations" not in x:
        return []
    rows = [
        ("station stops", str(int(x["stations"])), ""),
        ("max stop error (mm)", _fmt(x.get("max_stop_error_m"), 1e3), ""),
        ("max stop heading error (deg)", _fmt(x.get("max_stop_heading_error_rad"), 180 / math.pi, 2), ""),
        ("mission time (s)", _fmt(x.get("mission_time_s"), 1.0, 1), ""),
    ]
    for key in sorted(k for k in x if k.startswith("max_lateral_m.")):
        value = x[key]
        if value is not None and math.isfinite(value):
            rows.append((f"max |lateral error| on {key.split('.', 1)[1].replace('_', ' ')} (mm)", _fmt(value, 1e3), ""))
    return rows


def _event_rows(result: Any) -> list[tuple[str, str, str]]:
    """The scenario's events (issue 29): injected faults, estimator outages, the positioning guard."""
    ev = getattr(result, "timeline", None) or {}
    rows: list[tuple[str, str, str]] = []
    for f in ev.get("faults", []):
        rows.append((f"fault {f['index']}: {f['kind']}", _window(f["start_s"], f["end_s"]), ""))
    per_status: dict[str, float] = {}
    for w in ev.get("estimator", []):
        per_status[w["status"]] = per_status.get(w["status"], 0.0) + w["end_s"] - w["start_s"]
    for status, seconds in per_status.items():
        rows.append((f"time {status.replace('_', ' ')} (s)", _fmt(seconds, 1.0, 2), ""))
    guard = ev.get("positioning_guard")
    if guard is not None:
        rows += [
            ("slowed for positioning (s)", _fmt(guard["time_slow_s"], 1.0, 2), ""),
            ("stops for positioning", str(guard["stops"]), ""),
            ("stopped for positioning (s)", _fmt(guard["time_stop_s"], 1.0, 2), ""),
            ("max 3σ lateral (estimated, during faults) / stop limit (mm)" if ev.get("faults") else
             "max 3σ lateral, estimated / stop limit (mm)",
             f"{_fmt(guard['max_lateral_3sigma_m'], 1e3)} / {_fmt(guard['lateral_3sigma_stop_m'], 1e3)}", ""),
        ]
    return rows


def _stop_window_rows(result: Any) -> list[tuple[str, str, str]]:
    """When the safety fields stopped the vehicle, and for what (the first :data:`MAX_WINDOW_ROWS`)."""
    ev = getattr(result, "timeline", None) or {}
    stops = [w for w in ev.get("reactive", []) if w["level"] == "stop"]
    return [(f"stopped for {w['trigger'] or 'a field'}", _window(w["start_s"], w["end_s"]), "")
            for w in stops[:MAX_WINDOW_ROWS]]


def _docking_rows(result: Any) -> list[tuple[str, str, str]]:
    """A docking's figures (issue 32): true error against the true station, time, measured station offset."""
    extra = getattr(result, "extra", None) or {}
    if "dock_error_m" not in extra:
        return []
    offset = math.hypot(extra["station_offset_measured_x_m"], extra["station_offset_measured_y_m"])
    return [
        ("docking error, true station (mm)", _fmt(extra["dock_error_m"], 1e3, 2), ""),
        ("docking heading error (deg)", _fmt(math.degrees(extra["dock_heading_error_rad"]), 1.0, 3), ""),
        ("docking reported finished", "yes" if extra["docking_reported_finished"] else "no", ""),
        ("time to dock (s)", _fmt(extra["dock_time_s"], 1.0, 1), ""),
        ("station offset measured / true (mm)",
         f"{_fmt(offset, 1e3, 1)} / {_fmt(extra['station_offset_true_m'], 1e3, 1)}", ""),
    ]


#: Label suffix of a docking run's path figures: against the approach drawn on the map's station, which may stand
#: off the map (issue 32), not the docking's error.
ON_MAP_STATION = ", vs path on the map's station"

#: Most reactive stop windows listed one per row in the summary table.
MAX_WINDOW_ROWS = 5


def _summary(result: Any) -> tuple[str, list[Col], list[list[str]]]:
    """The summary table ``(title, columns, rows)``: metric, value, and the seed's figure where one applies.

    The figures fit the vehicle (:func:`_heading_rows`); a mission adds its stops and per-edge lateral
    errors (the headline is their largest); a docking's own figures lead its table, its path figures
    labelled as against the map's station (:data:`ON_MAP_STATION`); a run with faults, positioning outages or reactive
    stops adds when they happened (:mod:`agvnav.sim.events`).
    """
    m = result.metrics
    title = f"{result.scenario.name}: {result.scenario.vehicle.model} (seed {result.scenario.seed})"
    e0 = m.initial_lateral_error_m
    transient = e0 is not None and math.isfinite(e0) and abs(e0) > NO_TRANSIENT_M
    after = " after transient" if transient else ""
    seed = _seed_column(result.scenario.name)
    mission = "stations" in (getattr(result, "extra", {}) or {})
    guided = " of the guided point" if mission else ""
    # no seed figure beside the maxima after the band-defined transient or the signed std: the
    # seed's 16.5 mm, 3.8 deg and 6.6 mm are compared on their own definitions by `agvnav bench seeds`
    comparable = {"initial_lateral_error_m", "positioning_lateral_mean_abs_m", "positioning_lateral_max_abs_m"}
    docking = _docking_rows(result)
    # a docking follows its approach relative to the station as it stands: the path figures are against the
    # approach drawn on the map's station (off by the station's offset), so the docking's own figures lead
    on_map = ON_MAP_STATION if docking else ""
    rows: list[tuple[str, str, str]] = [
        *docking,
        (f"initial lateral error{on_map} (mm)", _fmt(e0, 1e3), "initial_lateral_error_m" if transient else ""),
        (f"max |lateral error|{guided}{after}{on_map} (mm)", _fmt(m.max_abs_lateral_error_m, 1e3), ""),
        (f"RMS lateral error{guided}{after}{on_map} (mm)", _fmt(m.rms_lateral_error_m, 1e3), ""),
        *_heading_rows(result, after + on_map),
    ]
    if transient:
        rows.append(("settling distance (m)", _fmt(m.settling_distance_m, 1.0, 3), ""))
    rows += [
        *_mission_rows(result),
        ("positioning RMS (mm)", _fmt(m.positioning_rms_m, 1e3), ""),
        ("positioning mean |e_lat| (mm)", _fmt(m.positioning_lateral_mean_abs_m, 1e3),
         "positioning_lateral_mean_abs_m"),
        ("positioning std e_lat (mm)", _fmt(m.positioning_lateral_std_m, 1e3), ""),
        ("positioning max |e_lat| (mm)", _fmt(m.positioning_lateral_max_abs_m, 1e3), "positioning_lateral_max_abs_m"),
        *_event_rows(result),
        ("outcome", result.outcome + (f" ({result.reason})" if result.reason else ""), ""),
        *_reactive_rows(result),
        *_stop_window_rows(result),
        ("simulated time (s)", _fmt(m.sim_time_s, 1.0, 2), ""),
        ("wall time (s)", _fmt(m.wall_time_s, 1.0, 3), ""),
        ("real-time factor", _fmt(m.real_time_factor, 1.0, 0), ""),
    ]
    cols = [Col("metric", "left", 0), Col("value", "right", 0)]
    if not seed:
        return title, cols, [[name, value] for name, value, _ in rows]
    cols.append(Col("seed 000 (same unit)", "right", 1))
    cells = [[name, value, seed.get(key, "") if key in comparable else ""] for name, value, key in rows]
    return title, cols, cells
