"""A fleet-sizing campaign (issue 28): fleet.size swept over a fleet scenario's vehicles; deliveries per hour."""

import pytest

from agvnav.campaign import load_base, load_campaign, plan_runs, run_batch
from agvnav.campaign.overrides import apply_overrides, dump_yaml
from agvnav.campaign.store import records_table
from agvnav.campaign.summary import summarize
from agvnav.world.strict import ScenarioError

#: Three vehicles in the lab, each dropping once at the end of a short line (a path vehicle: one job).
FLEET = """\
name: lab_trio
seed: 3
step_s: 0.05
duration_s: 8.0
map: lab
world_truth: {reflector_survey_std_m: 0.002}
traction: {speed_m_s: 0.5, max_accel_m_s2: 0.5, max_decel_m_s2: 0.5}
goniometer: {mount: [0.0, 0.0, 0.0], p_miss: 0.05}
positioning: {method: ekf, odometry_noise: [5.0e-5, 8.0e-4, 2.0e-4]}
vehicle: {model: differential, track_m: 0.5, wheel_radius_m: 0.08, encoder_counts_per_rev: 4096}
controller: {name: kanayama, params: {convergence_distance: 1.0}}
fleet:
  vehicles:
    - {id: a, path: {start: [3.0, 2.0, 0.0], segments: [{type: line, length_m: 1.0}]}}
    - {id: b, path: {start: [3.0, 4.0, 0.0], segments: [{type: line, length_m: 1.0}]}}
    - {id: c, path: {start: [3.0, 6.0, 0.0], segments: [{type: line, length_m: 1.0}]}}
"""


def _campaign(tmp_path, grid: str):
    (tmp_path / "trio.yaml").write_text(FLEET)
    p = tmp_path / "size.yaml"
    p.write_text(f"name: sizing\nbase: trio.yaml\nseeds: 1\ngrid:\n{grid}")
    return load_campaign(p)


def test_fleet_size_is_swept_and_the_summary_gives_the_figures_per_size(tmp_path) -> None:
    spec = _campaign(tmp_path, "  fleet.size: [1, 3]\n")
    base = load_base(spec.resolve_base())
    plans = plan_runs(spec)
    records = run_batch(dump_yaml(apply_overrides(base.mapping, spec.overrides)), [(p.index, p.params, p.seed)
                                                                                   for p in plans])
    assert [r["outcome"] for r in records] == ["completed", "completed"], [r["reason"] for r in records]
    assert [r["metric.fleet.vehicles"] for r in records] == [1.0, 3.0]
    assert [r["metric.fleet.jobs_completed"] for r in records] == [1.0, 3.0]
    summary = summarize(records_table(records, {"fleet.size": True}), group_by=["fleet.size"])
    sizes = {g["params"]["fleet.size"]: g["metrics"] for g in summary["groups"][1:]}
    assert sorted(sizes) == [1, 3]
    assert sizes[3]["fleet.jobs_completed"]["mean"] == 3.0
    assert "fleet.deliveries_per_hour" in sizes[1] and "fleet.cpu_time_s" not in sizes[1]


def test_a_fleet_size_beyond_the_listed_vehicles_is_refused_at_its_line(tmp_path) -> None:
    with pytest.raises(ScenarioError, match=r"size.yaml:5: grid.fleet.size\[1\]: fleet.size: 4 is not a fleet size of "
                                            r"1 to 3"):
        _campaign(tmp_path, "  fleet.size: [1, 4]\n")
