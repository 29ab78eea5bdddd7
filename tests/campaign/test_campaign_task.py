"""The task function: one flat record per run; failures and errors are records, never exceptions."""

import json
import math

from agvnav.campaign import load_base, load_campaign, plan_runs, run_batch, run_one, write_replay
from agvnav.campaign.overrides import apply_overrides, dump_yaml
from agvnav.sim import simulate
from agvnav.world.scenario import load_scenario, parse_scenario
from agvnav.world.strict import load_yaml_document

#: Metrics that depend on the machine, not on the seed.
TIMING = {"wall_time_s", "real_time_factor"}


def _base_text(spec):
    base = load_base(spec.resolve_base())
    return dump_yaml(apply_overrides(base.mapping, spec.overrides))


def test_record_is_flat_and_replays_alone(write_campaign, tmp_path):
    spec = load_campaign(write_campaign("seed: 4\nruns: 2\nrandom:\n  goniometer.p_miss: {uniform: [0.0, 0.2]}\n"))
    plan = plan_runs(spec)[1]
    rec = run_one(_base_text(spec), plan.params, plan.seed, index=1)
    assert rec["run"] == 1 and rec["seed"] == plan.seed and rec["outcome"] == "completed" and rec["reason"] == ""
    assert json.loads(rec["overrides"]) == plan.params
    assert rec["param.goniometer.p_miss"] == plan.params["goniometer.p_miss"]
    assert all(isinstance(v, int | float | str) or v is None for v in rec.values())
    assert rec["cpu_time_s"] > 0 and rec["sim_time_s"] > 0
    # the replay file, run alone by the simulator, gives the same metrics bit for bit
    replayed = simulate(load_scenario(write_replay(spec, 1, tmp_path / "out"))).metrics.to_dict()
    for name, value in replayed.items():
        if name not in TIMING:
            want = None if value is None else float(value)
            assert rec[f"metric.{name}"] == want, name


def test_same_seed_same_record_other_seed_differs(write_campaign):
    spec = load_campaign(write_campaign("runs: 1\n"))
    text = _base_text(spec)
    a, b, c = (run_one(text, {}, s, ["positioning_rms_m", "max_abs_lateral_error_m"]) for s in (11, 11, 12))
    assert a["metric.positioning_rms_m"] == b["metric.positioning_rms_m"]
    assert a["metric.positioning_rms_m"] != c["metric.positioning_rms_m"]
    assert {k for k in a if k.startswith("metric.")} == {"metric.positioning_rms_m", "metric.max_abs_lateral_error_m"}


def test_unfinished_run_is_failed(write_campaign):
    spec = load_campaign(write_campaign("runs: 1\n"))
    rec = run_one(_base_text(spec), {"duration_s": 0.5}, 3, ["path_completed", "integrity.max_true_lateral_error_m"])
    assert rec["outcome"] == "failed" and rec["reason"] == "timeout"  # the simulator's reason
    assert rec["metric.integrity.max_true_lateral_error_m"] > 0.0
    assert rec["metric.path_completed"] == 0.0 and math.isclose(rec["sim_time_s"], 0.5)


def test_errors_are_records(write_campaign):
    spec = load_campaign(write_campaign("runs: 1\n"))
    text = _base_text(spec)
    runs = [(0, {"goniometer.p_miss": 3.0}, 1), (1, {"map": "no_such_map.yaml"}, 1), (2, {}, 1)]
    recs = run_batch(text, runs, ["path_completed"])
    assert [r["run"] for r in recs] == [0, 1, 2]
    assert [r["outcome"] for r in recs] == ["error", "error", "completed"]
    assert "goniometer.p_miss" in recs[0]["reason"] and "no_such_map.yaml" in recs[1]["reason"]
    assert run_one("{not: yaml", {}, 0)["outcome"] == "error"


def test_shipped_map_given_inline_gives_the_same_record(write_campaign):
    """The task hands a shipped map to the simulator inline (no YAML parse per run): same results as by name."""
    spec = load_campaign(write_campaign("seed: 2\nruns: 1\n"))
    text = _base_text(spec)
    swept = {"map": "hall", "duration_s": 2.0}
    rec = run_one(text, swept, 7)
    by_name = parse_scenario(dump_yaml(apply_overrides(load_yaml_document(text, "<t>")[0], swept)), source="<t>")
    assert by_name.map == "hall"  # the simulator itself loads the shipped file here
    metrics = simulate(by_name.with_seed(7)).metrics.to_dict()
    checked = [k for k, v in metrics.items() if k not in TIMING and isinstance(v, int | float)]
    assert checked
    for k in checked:
        got, want = rec[f"metric.{k}"], float(metrics[k])
        assert got == want or (math.isnan(got) and math.isnan(want)), k
