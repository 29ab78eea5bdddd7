"""A small campaign on a 2-worker LocalCluster: Parquet rows, resume after an interruption, summary."""

import json

import pyarrow.parquet as pq
import pytest

from agvnav.campaign import finished_runs, load_base, load_campaign, plan_runs, read_results, run_campaign, run_one
from agvnav.campaign.overrides import apply_overrides, dump_yaml
from agvnav.campaign.runner import batch_plans, fingerprint

BODY = """\
seed: 21
seeds: 3
grid:
  duration_s: [null, 0.5]
metrics: [positioning_rms_m, path_completed]
"""


def test_small_campaign_writes_parquet(write_campaign, scheduler, tmp_path):
    spec = load_campaign(write_campaign(BODY))
    out = tmp_path / "out"
    res = run_campaign(spec, out, scheduler=scheduler, progress=False)
    assert (res.total, res.ran, res.skipped, res.workers) == (6, 6, 0, 2)
    table = read_results(out)
    assert table["run"].to_pylist() == list(range(6))
    cols = set(table.column_names)
    assert {"seed", "outcome", "reason", "cpu_time_s", "sim_time_s", "param.duration_s",
            "metric.positioning_rms_m", "metric.path_completed"} <= cols
    assert table["outcome"].to_pylist() == ["completed"] * 3 + ["failed"] * 3
    assert table["param.duration_s"].to_pylist() == [None] * 3 + [0.5] * 3
    summary = json.loads((out / "summary.json").read_text())
    assert [g["params"] for g in summary["groups"]] == [{}, {"duration_s": None}, {"duration_s": 0.5}]
    assert summary["groups"][0]["outcomes"] == {"completed": 3, "failed": 3, "error": 0}
    assert summary["groups"][1]["metrics"]["path_completed"]["mean"] == 1.0
    parts = list((out / "runs").glob("part-*.parquet"))
    assert sum(pq.read_metadata(p).num_rows for p in parts) == 6
    # a worker's record is the record of the same run in this process (pure, seeded task)
    plan = plan_runs(spec)[1]
    base = load_base(spec.resolve_base())
    alone = run_one(dump_yaml(apply_overrides(base.mapping, spec.overrides)), plan.params, plan.seed, spec.metrics)
    assert alone["metric.positioning_rms_m"] == table["metric.positioning_rms_m"].to_pylist()[1]


def test_interrupted_campaign_resumes_without_redoing(write_campaign, scheduler, tmp_path):
    spec = load_campaign(write_campaign(BODY))
    out = tmp_path / "out"

    def stop_after_first(done, total):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_campaign(spec, out, scheduler=scheduler, progress=stop_after_first, batch_size=2)
    first = finished_runs(out)
    assert len(first) == 2
    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "runs").glob("part-*.parquet")}
    res = run_campaign(spec, out, scheduler=scheduler, progress=False, batch_size=2)
    assert (res.ran, res.skipped) == (4, 2)
    assert read_results(out)["run"].to_pylist() == list(range(6))  # every run exactly once
    assert all((out / "runs" / name).stat().st_mtime_ns == t for name, t in stamps.items())
    again = run_campaign(spec, out, scheduler=scheduler, progress=False)
    assert (again.ran, again.skipped, again.workers) == (0, 6, 0)


def test_other_campaign_in_same_folder_is_refused(write_campaign, scheduler, tmp_path):
    out = tmp_path / "out"
    run_campaign(load_campaign(write_campaign("runs: 1\n")), out, scheduler=scheduler, progress=False)
    other = load_campaign(write_campaign("runs: 1\nseed: 5\n", name="other.yaml"))
    with pytest.raises(ValueError, match="another campaign"):
        run_campaign(other, out, scheduler=scheduler, progress=False)
    stale = out / "runs" / "part-stale.parquet.note"
    stale.write_text("from the first campaign")
    res = run_campaign(other, out, scheduler=scheduler, progress=False, force=True)  # replaced whole, not mixed
    assert (res.ran, res.skipped) == (1, 0) and not stale.exists()
    manifest = json.loads((out / "campaign.json").read_text())
    assert manifest["fingerprint"] == fingerprint(other, load_base(other.resolve_base()))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.yaml", "other.yaml", "out"]


def test_a_folder_of_other_files_is_never_written_into(write_campaign, tmp_path):
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "notes.txt").write_text("mine")
    spec = load_campaign(write_campaign("runs: 1\n"))
    for force in (False, True):  # refused before any cluster starts
        with pytest.raises(ValueError, match="not an agvnav campaign"):
            run_campaign(spec, docs, scheduler="tcp://127.0.0.1:1", progress=False, force=force)
    assert [p.name for p in docs.iterdir()] == ["notes.txt"]


def test_more_runs_extend_a_gridless_campaign(write_campaign, scheduler, tmp_path):
    out = tmp_path / "out"
    run_campaign(load_campaign(write_campaign("runs: 1\n")), out, scheduler=scheduler, progress=False)
    res = run_campaign(load_campaign(write_campaign("runs: 2\n", name="more.yaml")), out, scheduler=scheduler,
                       progress=False)
    assert (res.ran, res.skipped) == (1, 1)
    assert json.loads((out / "campaign.json").read_text())["runs"] == 2


def test_batches():
    plans = list(range(10))
    assert [len(b) for b in batch_plans(plans, 2)] == [2, 1, 1, 1, 1, 1, 1, 1, 1]
    assert [len(b) for b in batch_plans(list(range(20)), 1)] == [5, 4, 3, 2, 2, 1, 1, 1, 1]
    sizes = [len(b) for b in batch_plans(list(range(10_000)), 2)]
    assert sizes[:480] == [20] * 480 and len(sizes) == 520  # full batches, then shrinking ones
    assert sizes == sorted(sizes, reverse=True) and sizes[-8:] == [1] * 8
    for n, workers in ((1, 2), (7, 1), (37, 3), (500, 4)):
        batches = batch_plans(list(range(n)), workers)
        assert [p for b in batches for p in b] == list(range(n))  # every run once, in order
        assert all(1 <= len(b) <= 20 for b in batches)
    assert [len(b) for b in batch_plans(plans, 2, batch_size=4)] == [4, 4, 2]
    with pytest.raises(ValueError, match="batch_size"):
        batch_plans(plans, 2, batch_size=0)


def test_local_cluster_workers_run_without_the_dashboard_diagnostics(scheduler):
    """The cluster's workers have the profiler off and slow diagnostics ticks; the caller's config is untouched."""
    import dask
    from distributed import Client

    from agvnav.campaign.runner import CLUSTER_CONFIG

    keys = list(CLUSTER_CONFIG)
    with Client(scheduler) as client:
        seen = client.run(lambda: [dask.config.get(k) for k in keys])
    assert seen and all(v == list(CLUSTER_CONFIG.values()) for v in seen.values())
    assert dask.config.get("distributed.worker.profile.enabled") is True  # this process: the default
