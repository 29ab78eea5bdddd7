"""``agvnav bench ...``: speed and accuracy tables; ``--json`` for machines.

Every benchmark module ``agvnav.bench.<name>`` exposes
``run(quick: bool, seed: int) -> list[dict]`` (one flat record per table row)
and ``TITLE``; this module only parses arguments and prints. A ``run`` that also
accepts ``progress`` gets a ``(done, total)`` callback; the others run under a bar
of elapsed time against the wall time they took last time
(:class:`agvnav.cli.progress.RunProgress`). An optional module attribute
``PRIORITY`` (record keys, most important first) says which columns a narrow
terminal keeps; ``--wide`` prints them all.

A benchmark whose optional extra is missing (``bench speed``'s campaign throughput needs
Dask, the ``campaign`` extra) stops before it runs with one line naming the extra, exit 2
(:data:`EXTRAS`): never a traceback, and never a table silently short of the rows the
benchmark defines (its records are what runs are compared on). ``bench mapping`` needs
no extra (the campaign package imports without Dask).
"""

from __future__ import annotations

import importlib
import inspect

import typer

from agvnav.bench.common import emit
from agvnav.cli.errors import fail, user_errors
from agvnav.cli.progress import RunProgress

bench_app = typer.Typer(help="Benchmarks: speed and accuracy tables (--json for machines).", no_args_is_help=True)

JSON_OPT = typer.Option(False, "--json", help="Print {\"benchmark\": NAME, \"records\": [...]} instead of a table.")
QUICK_OPT = typer.Option(False, "--quick", help="Smaller problem sizes, for a fast look (figures are noisier).")
SEED_OPT = typer.Option(0, "--seed", min=0, help="Random seed; the same seed reproduces the same figures.")
WIDE_OPT = typer.Option(False, "--wide", help="Print every column, however wide the terminal.")


#: Top-level module -> the optional extra that installs it (pyproject.toml), for the one-line message.
EXTRAS = {"dask": "campaign", "distributed": "campaign", "pyarrow": "campaign", "mcap": "logs",
          "mcap_ros2": "logs", "rosbags": "logs", "gtsam": "slam"}


def _missing_extra(name: str, exc: ModuleNotFoundError) -> typer.Exit | None:
    """One line naming the extra a benchmark needs when ``exc`` is one of its modules missing, else None."""
    root = (exc.name or "").split(".")[0]
    extra = EXTRAS.get(root)
    if extra is None:
        return None
    return fail(f"agvnav bench {name} needs the {extra} extra ({root} is not installed): pip install 'agvnav[{extra}]'")


def _run(name: str, as_json: bool, quick: bool, seed: int, wide: bool = False) -> None:
    try:
        module = importlib.import_module(f"agvnav.bench.{name}")
    except ModuleNotFoundError as exc:  # checked before anything runs: every module-level import of the benchmark
        raise _missing_extra(name, exc) or exc from None
    reports = "progress" in inspect.signature(module.run).parameters
    key = None if reports else f"bench {name}{' --quick' if quick else ''}"
    try:
        with RunProgress(f"bench {name}", None, "", key=key) as bar:
            if reports:
                records = module.run(quick=quick, seed=seed, progress=bar.update)
            else:
                records = module.run(quick=quick, seed=seed)
    except ModuleNotFoundError as exc:  # an import the benchmark makes while it runs
        raise _missing_extra(name, exc) or exc from None
    emit(
        name, records, as_json=as_json, title=module.TITLE, seed=seed, quick=quick, wide=wide,
        priority=getattr(module, "PRIORITY", ()),
    )


@bench_app.command("triangulation")
@user_errors
def triangulation(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Triangulation methods: ns per fix (batch), µs per single fix, RMS error against the CRLB."""
    _run("triangulation", json, quick, seed, wide)


@bench_app.command("kinematics")
@user_errors
def kinematics(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Kinematic models: steps per second for 10,000 vehicles; odometry integrator errors."""
    _run("kinematics", json, quick, seed, wide)


@bench_app.command("positioning")
@user_errors
def positioning(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Dynamic positioning of a moving tricycle: naive, angle propagation, batch ML, EKF."""
    _run("positioning", json, quick, seed, wide)


@bench_app.command("guidance")
@user_errors
def guidance(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Guidance laws against pure pursuit and Stanley; simulator real-time factor."""
    _run("guidance", json, quick, seed, wide)


@bench_app.command("landmarks")
@user_errors
def landmarks(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Tracked robot on the square route: error per lap with and without wall landmarks."""
    _run("landmarks", json, quick, seed, wide)


@bench_app.command("vehicles")
@user_errors
def vehicles(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Every vehicle configuration on the same loop: completion, lateral and positioning errors (true pose)."""
    _run("vehicles", json, quick, seed, wide)


@bench_app.command("seeds")
@user_errors
def seeds(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Every experimental figure of seeds 000/001 and 004: seed value, seed-method band, agvnav, driver."""
    _run("seeds", json, quick, seed, wide)


@bench_app.command("integrity")
@user_errors
def integrity(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Injected faults (goniometer, reflectors, odometry): silent failures, safe stops, NEES (truth-judged)."""
    _run("integrity", json, quick, seed, wide)


@bench_app.command("consistency")
@user_errors
def consistency(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """EKF consistency: NEES (full, position, heading) over 200 runs of the fault-free EKF scenarios, 95 % bands."""
    _run("consistency", json, quick, seed, wide)


@bench_app.command("speed")
@user_errors
def speed(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Closed loop: real-time factor (CPU) per case, µs per step, memory, start-up, campaign runs/s."""
    _run("speed", json, quick, seed, wide)


@bench_app.command("missions")
@user_errors
def missions(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Missions on the hall route network: stop errors, mission time, lateral error per edge kind; planning speed."""
    _run("missions", json, quick, seed, wide)


@bench_app.command("docking")
@user_errors
def docking(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Docking relative to the station: true final error (p95), silent failures, dock time vs the global stop."""
    _run("docking", json, quick, seed, wide)


@bench_app.command("layout")
@user_errors
def layout(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Reflector layout planner: reflectors planned vs regular spacing, predicted vs simulated RMS, planning time."""
    _run("layout", json, quick, seed, wide)


@bench_app.command("safety")
@user_errors
def safety(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Reactive safety: people crossing at/inside the stopping distance, a pallet avoided in a two-way lane."""
    _run("safety", json, quick, seed, wide)


@bench_app.command("mapping")
@user_errors
def mapping(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """Reflector mapping (SLAM): reflectors found, spurious, map RMS and NEES per anchor; positioning on the map."""
    _run("mapping", json, quick, seed, wide)


@bench_app.command("traffic")
@user_errors
def traffic(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT,
            runs: int = typer.Option(0, "--runs", min=0, help="Monte Carlo runs per row (0: the default, 1,000 runs "
                                     "over the 10 rows, 100 per row; 2 per row with --quick); the default takes hours "
                                     "of CPU.")
            ) -> None:
    """Traffic control: collisions and deadlocks under delays, deliveries/h beside the baseline, planning time."""
    try:
        from agvnav.bench import traffic as bench

        key = f"bench traffic{' --quick' if quick else ''}{f' --runs {runs}' if runs else ''}"
        with RunProgress("bench traffic", None, "", key=key):
            records = bench.run(quick=quick, seed=seed, runs=runs or None)
    except ModuleNotFoundError as exc:
        raise _missing_extra("traffic", exc) or exc from None
    emit("traffic", records, as_json=json, title=bench.TITLE, seed=seed, quick=quick, wide=wide,
         priority=bench.PRIORITY)


@bench_app.command("fleet")
@user_errors
def fleet(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT) -> None:
    """A fleet in the warehouse (1 to 200 vehicles): CPU per vehicle-step, real-time factor, memory, separation."""
    _run("fleet", json, quick, seed, wide)


@bench_app.command("vda5050")
@user_errors
def vda5050(json: bool = JSON_OPT, quick: bool = QUICK_OPT, seed: int = SEED_OPT, wide: bool = WIDE_OPT,
            full: bool = typer.Option(False, "--full", help="Issue 31's sizes: 10 vehicles x 1 simulated hour per "
                                      "version, 10^5 states; hours of CPU.")) -> None:
    """VDA 5050: message conformance per version, order-to-motion latency on mosquitto, deviationRange misses."""
    from agvnav.bench import vda5050 as bench

    if quick and full:
        raise fail("--quick and --full exclude each other")
    try:
        with RunProgress("bench vda5050", None, "", key=f"bench vda5050{' --quick' if quick else ''}"
                         f"{' --full' if full else ''}") as _bar:
            records = bench.run(quick=quick, seed=seed, full=full)
    except ModuleNotFoundError as exc:
        raise _missing_extra("vda5050", exc) or exc from None
    emit("vda5050", records, as_json=json, title=bench.TITLE, seed=seed, quick=quick, wide=wide,
         priority=bench.PRIORITY)
