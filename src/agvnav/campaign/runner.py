"""Run a campaign on a Dask ``distributed`` cluster; results stream to Parquet as batches finish.

The runs are cut into batches (many runs per task, so 10,000 short runs do not
wait on the scheduler; fewer towards the end, so no worker waits long for the
last one: :func:`batch_plans`), submitted with ``Client.submit`` of the pure task
function :func:`agvnav.campaign.task.run_batch`, and collected with
``as_completed``: each finished batch is written at once as one part file of
the dataset. A campaign started again on the same folder skips the runs
already there. A batch whose task itself failed (a worker died) is recorded as
``error`` runs with the reason; it does not stop the campaign.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import dask
from distributed import Client, LocalCluster, as_completed
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, TextColumn, TimeRemainingColumn
from rich.progress import Progress as ProgressBar

from agvnav.campaign.overrides import BaseScenario, apply_overrides, dump_yaml, load_base, replay_mapping
from agvnav.campaign.plan import RunPlan, plan_runs
from agvnav.campaign.spec import CampaignSpec, is_number
from agvnav.campaign.store import check_manifest, finished_runs, read_results, records_table, write_json, write_part
from agvnav.campaign.summary import summarize
from agvnav.campaign.task import run_batch

__all__ = [
    "CLUSTER_CONFIG", "CampaignResult", "batch_plans", "fingerprint", "local_cluster", "run_campaign", "write_replay",
]

#: Most runs in one task: ~0.5 s of work per task at the target 1000x real time.
MAX_BATCH = 20
Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class CampaignResult:
    """What one call of :func:`run_campaign` did."""

    out_dir: Path
    total: int
    ran: int
    skipped: int
    workers: int
    wall_s: float
    summary: dict[str, Any]

    @property
    def runs_per_s(self) -> float | None:
        """Runs finished per wall-clock second in this call (None when nothing ran)."""
        return self.ran / self.wall_s if self.ran and self.wall_s > 0 else None


def fingerprint(spec: CampaignSpec, base: BaseScenario) -> str:
    """SHA-256 of what decides the runs' results (spec without name, description and, gridless, the count)."""
    drop = {"name", "description"} | (set() if spec.grid else {"runs", "seeds"})
    doc = {"spec": spec.model_dump(mode="json", exclude=drop), "base": base.text}
    return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()


def numeric_params(spec: CampaignSpec) -> dict[str, bool]:
    """Swept key -> True when all its values are numbers or null (a float64 column)."""
    out = {k: all(v is None or is_number(v) for v in values) for k, values in spec.grid.items()}
    out.update({k: d.is_numeric() for k, d in spec.random.items()})
    return out


def batch_plans(plans: Sequence[RunPlan], workers: int, batch_size: int | None = None) -> list[list[RunPlan]]:
    """Cut ``plans`` into batches, in order: ``batch_size`` runs each, or by default shrinking ones.

    By default (guided self-scheduling) each batch takes a quarter of a worker's share of the
    runs still to cut, ``ceil(remaining / (4 * workers))``, at most :data:`MAX_BATCH` and at least
    one: full batches while many runs remain, then ever smaller ones down to single runs, so the
    workers run out of work within about one run of each other instead of one waiting for a
    whole batch of the other (runs of one campaign differ in cost: 0.2-0.5 s for the default
    scenario's seeds). A batch is a task and a part file; a 10,000-run campaign on 2 workers
    has 520 of them against 500 of 20 runs.
    """
    if batch_size is not None:
        if batch_size < 1:
            raise ValueError(f"batch_size must be >= 1, got {batch_size}")
        return [list(plans[i : i + batch_size]) for i in range(0, len(plans), batch_size)]
    out, start, share = [], 0, 4 * max(1, workers)
    while start < len(plans):
        size = max(1, min(MAX_BATCH, math.ceil((len(plans) - start) / share)))
        out.append(list(plans[start : start + size]))
        start += size
    return out


#: Dask settings of the cluster :func:`local_cluster` starts (issue 11): its diagnostics serve a
#: dashboard that cluster does not run. The statistical profiler samples the running task's stack
#: every 10 ms, the event-loop check ticks every 20 ms and the system monitor polls every 0.5 s;
#: together they took 8-13 % of a worker's CPU beside the runs (measured on the default scenario:
#: worker process CPU against the runs' thread CPU), 2-5 % with these settings.
CLUSTER_CONFIG: dict[str, Any] = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
}


def local_cluster(workers: int = 2) -> LocalCluster:
    """The default cluster: ``workers`` single-threaded worker processes, no dashboard, quiet logs.

    One thread per process: the simulator is pure Python, so threads would only
    contend for the interpreter lock. The cluster runs with :data:`CLUSTER_CONFIG`
    (no profiler, slower diagnostics ticks); the caller's Dask configuration is left as it was.
    """
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    with dask.config.set(CLUSTER_CONFIG):  # the nannies hand this configuration to their workers
        return LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            scheduler_kwargs={"dashboard_address": ":0"},  # no dashboard; health routes on a free port
            silence_logs=logging.ERROR,
        )


@contextmanager
def _client(scheduler: str | None, workers: int | None) -> Iterator[Any]:
    if scheduler is not None:
        with Client(scheduler) as client:
            yield client
        return
    with local_cluster(2 if workers is None else workers) as cluster, Client(cluster) as client:
        yield client


def _failed_batch(batch: Sequence[RunPlan], exc: BaseException) -> list[dict[str, Any]]:
    reason = f"task failed: {type(exc).__name__}: {' '.join(str(exc).split())}"
    return [
        {"run": p.index, "seed": p.seed, "outcome": "error", "reason": reason, "cpu_time_s": 0.0,
         "overrides": json.dumps(p.params, sort_keys=True), **{f"param.{k}": v for k, v in p.params.items()}}
        for p in batch
    ]


def _progress_bar(total: int, done: int) -> tuple[Progress, Callable[[], None]]:
    bar = ProgressBar(
        TextColumn("campaign"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
        console=Console(stderr=True), transient=True,
    )
    task = bar.add_task("runs", total=total, completed=done)
    bar.start()
    return (lambda finished, _total: bar.update(task, completed=finished)), bar.stop


def _reporter(progress: bool | Progress | None, total: int, done: int) -> tuple[Progress, Callable[[], None]]:
    if callable(progress):
        return progress, lambda: None
    if progress is None:
        progress = sys.stderr.isatty()
    if progress:
        return _progress_bar(total, done)
    return (lambda finished, _total: None), lambda: None


def _execute(
    client: Any, spec: CampaignSpec, base: BaseScenario, batches: list[list[RunPlan]], out: Path, report: Progress,
    done: int, total: int,
) -> None:
    text = dump_yaml(apply_overrides(base.mapping, spec.overrides))
    kinds = numeric_params(spec)
    where = str(base.base_dir) if base.base_dir is not None else None
    futures = {}
    for batch in batches:
        items = [(p.index, p.params, p.seed) for p in batch]
        fut = client.submit(
            run_batch, text, items, spec.metrics, source=base.source, base_dir=where,
            key=f"agvnav-campaign-{batch[0].index}-{batch[-1].index}-{time.time_ns()}", pure=False,
        )
        futures[fut] = batch
    try:
        for fut in as_completed(futures):
            try:
                records = fut.result()
            except Exception as exc:  # a lost batch is recorded, the campaign goes on
                records = _failed_batch(futures[fut], exc)
            write_part(out, records_table(records, kinds))
            done += len(records)
            report(done, total)
    finally:
        client.cancel(list(futures))


def run_campaign(
    spec: CampaignSpec,
    out_dir: str | Path,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool | Progress | None = None,
    batch_size: int | None = None,
    force: bool = False,
) -> CampaignResult:
    """Run every run of ``spec`` not yet in ``out_dir``; write the Parquet dataset and ``summary.json``.

    Parameters
    ----------
    spec
        The campaign (:func:`agvnav.campaign.load_campaign`).
    out_dir
        Output folder (``campaign.json``, ``runs/part-*.parquet``, ``summary.json``).
    scheduler
        Address of an existing Dask scheduler; default a ``LocalCluster`` of ``workers``
        (default 2) single-threaded worker processes.
    progress
        None: a bar on stderr when it is a terminal; True/False: always/never; a
        callable ``(finished, total)``: called after every written batch.
    batch_size
        Runs per task (default: see :func:`batch_plans`).
    force
        Replace a folder holding another campaign's results (never a folder of other files:
        :func:`agvnav.campaign.store.check_out_dir`).
    """
    if scheduler is not None and workers is not None:
        raise ValueError("give --workers for a local cluster or --scheduler for an existing one, not both")
    out = Path(out_dir)
    base = load_base(spec.resolve_base())
    plans = plan_runs(spec)
    check_manifest(out, _manifest(spec, base, len(plans)), force)
    done = finished_runs(out)
    todo = [p for p in plans if p.index not in done]
    t0 = time.perf_counter()
    n_workers = 0
    if todo:
        report, stop = _reporter(progress, len(plans), len(plans) - len(todo))
        try:
            with _client(scheduler, workers) as client:
                n_workers = len(client.scheduler_info()["workers"])
                batches = batch_plans(todo, n_workers, batch_size)
                _execute(client, spec, base, batches, out, report, len(plans) - len(todo), len(plans))
        finally:
            stop()
    wall = time.perf_counter() - t0
    summary = summarize(read_results(out), list(spec.grid), spec.metrics)
    write_json(out / "summary.json", summary)
    return CampaignResult(out, len(plans), len(todo), len(plans) - len(todo), n_workers, wall, summary)


def _manifest(spec: CampaignSpec, base: BaseScenario, runs: int) -> dict[str, Any]:
    """The content of ``campaign.json``: what campaign the folder holds."""
    return {"name": spec.name, "fingerprint": fingerprint(spec, base), "runs": runs, "swept": spec.swept,
            "metrics": spec.metrics}


def write_replay(spec: CampaignSpec, run: int, out_dir: str | Path, force: bool = False) -> Path:
    """Write the whole scenario of run ``run`` to ``out_dir/replay/run_<run>.yaml``; return its path.

    ``agvnav simulate`` of that file repeats the run alone (same overrides, same seed). ``out_dir``
    follows :func:`run_campaign`'s rules (absent, empty or this campaign's folder; another campaign's
    only with ``force``) and becomes this campaign's folder (its ``campaign.json``); the file is
    written to a temporary name and renamed.
    """
    plans = plan_runs(spec)
    if not 0 <= run < len(plans):
        raise ValueError(f"--replay {run}: the campaign has runs 0..{len(plans) - 1} ({len(plans)} runs)")
    plan = plans[run]
    base = load_base(spec.resolve_base())
    mapping = replay_mapping(base, {**spec.overrides, **plan.params}, plan.seed)
    check_manifest(out_dir, _manifest(spec, base, len(plans)), force)
    path = Path(out_dir) / "replay" / f"run_{run:06d}.yaml"
    path.parent.mkdir(parents=True, exist_ok=True)
    head = f"# campaign {spec.name!r} run {run}: base {spec.base}, seed {plan.seed}, swept {json.dumps(plan.params)}\n"
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(head + dump_yaml(mapping), encoding="utf-8")
    os.replace(tmp, path)
    return path
