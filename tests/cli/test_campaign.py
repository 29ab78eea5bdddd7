"""``agvnav campaign``: a small campaign through ``--scheduler`` (an in-process cluster); one-line errors.

The 2-worker process cluster of ``agvnav campaign --workers`` runs in tests/campaign.
"""

import json
import logging

import pytest
from distributed import LocalCluster
from typer.testing import CliRunner

from agvnav.campaign import load_campaign, plan_runs
from agvnav.cli import app
from agvnav.world.scenario import load_scenario

runner = CliRunner()

SPEC = """\
name: cli_tiny
base: guidance_test
seed: 3
seeds: 2
overrides:
  path.segments: [{type: line, length_m: 0.4}]
  start.lateral_offset_m: 0.02
grid:
  traction.speed_m_s: [0.2, 0.3]
metrics: [positioning_rms_m, max_abs_lateral_error_m]
"""


@pytest.fixture(scope="module")
def scheduler():
    """A one-thread cluster inside this process: no worker processes to start."""
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None, silence_logs=logging.ERROR,
        scheduler_kwargs={"dashboard_address": ":0"},
    ) as cluster:
        yield cluster.scheduler_address


def _spec(tmp_path, text=SPEC):
    p = tmp_path / "c.yaml"
    p.write_text(text)
    return p


def test_campaign_runs_and_writes_everything(tmp_path, scheduler):
    out = tmp_path / "out"
    res = runner.invoke(app, ["campaign", str(_spec(tmp_path)), "--out", str(out), "--scheduler", scheduler, "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    assert (doc["runs"], doc["ran"], doc["workers"]) == (4, 4, 1) and doc["runs_per_s"] > 0
    assert doc["campaign"] == "cli_tiny" and doc["metadata"]["seed"] == 3 and doc["metadata"]["numpy"]
    groups = doc["summary"]["groups"]
    assert [g["params"] for g in groups] == [{}, {"traction.speed_m_s": 0.2}, {"traction.speed_m_s": 0.3}]
    assert groups[0]["outcomes"]["completed"] == 4 and groups[0]["metrics"]["positioning_rms_m"]["n"] == 4
    assert json.loads((out / "summary.json").read_text()) == doc["summary"]
    assert {p.name for p in (out / "plots").iterdir()} == {
        "campaign_positioning_rms_m.png", "campaign_max_abs_lateral_error_m.png"
    }
    args = ["campaign", str(_spec(tmp_path)), "--out", str(out), "--no-plots", "--scheduler", scheduler]
    again = runner.invoke(app, args, env={"COLUMNS": "200"})
    assert again.exit_code == 0, again.output
    text = " ".join(again.output.split())
    assert "0 runs done, 4 already there" in text and "positioning rms (mm)" in text and "(4 completed)" in text


def test_replay_writes_a_scenario_for_simulate(tmp_path):
    out = tmp_path / "out"
    res = runner.invoke(app, ["campaign", str(_spec(tmp_path)), "--out", str(out), "--replay", "3"])
    assert res.exit_code == 0, res.output
    path = out / "replay" / "run_000003.yaml"
    assert f"agvnav simulate {path}" in res.output.replace("\n", "")
    sc = load_scenario(path)
    assert sc.traction.speed_m_s == 0.3 and sc.start.lateral_offset_m == 0.02
    assert sc.seed == plan_runs(load_campaign(_spec(tmp_path)))[3].seed


def test_bad_spec_is_one_line_exit_2(tmp_path):
    bad = _spec(tmp_path, SPEC.replace("[0.2, 0.3]", "[0.2, -0.3]"))
    res = runner.invoke(app, ["campaign", str(bad), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    line = SPEC.splitlines().index("  traction.speed_m_s: [0.2, 0.3]") + 1
    assert f"c.yaml:{line}: grid.traction.speed_m_s[1]:" in res.output
    assert len(res.output.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_workers_and_scheduler_together_refused(tmp_path):
    res = runner.invoke(app, ["campaign", str(_spec(tmp_path)), "--out", str(tmp_path / "o"), "--workers", "2",
                              "--scheduler", "tcp://127.0.0.1:1"])
    assert res.exit_code == 2 and "not both" in res.output and not (tmp_path / "o").exists()


def test_missing_file_and_bad_replay(tmp_path):
    res = runner.invoke(app, ["campaign", str(tmp_path / "none.yaml")])
    assert res.exit_code == 2 and "no such campaign file" in res.output
    res = runner.invoke(app, ["campaign", str(_spec(tmp_path)), "--out", str(tmp_path / "o"), "--replay", "4"])
    assert res.exit_code == 2 and "--replay 4: the campaign has runs 0..3 (4 runs)" in res.output  # names the option


def test_campaign_never_writes_into_a_users_folder(tmp_path):
    """issue 29: `campaign --out mydocs` wrote runs/, summary.json and plots/ beside the user's notes.txt, exit 0.
    Now one line, exit 2, before anything runs (with --force too), for a run and for --replay."""
    docs = tmp_path / "mydocs"
    docs.mkdir()
    (docs / "notes.txt").write_text("mine", encoding="utf-8")
    for extra in ([], ["--force"], ["--replay", "1"]):
        res = runner.invoke(app, ["campaign", str(_spec(tmp_path)), "--out", str(docs), "--workers", "1", *extra])
        assert res.exit_code == 2, res.output
        lines = [ln for ln in res.output.splitlines() if ln.strip()]
        assert len(lines) == 1 and "not an agvnav campaign" in lines[0] and "choose another folder" in lines[0]
    assert [p.name for p in docs.iterdir()] == ["notes.txt"]
    (tmp_path / "f").write_text("x", encoding="utf-8")
    res = runner.invoke(app, ["campaign", str(_spec(tmp_path)), "--out", str(tmp_path / "f"), "--replay", "1"])
    assert res.exit_code == 2 and "it is a file" in res.output


def test_another_campaigns_folder_is_replaced_only_with_force(tmp_path):
    out = tmp_path / "out"
    assert runner.invoke(app, ["campaign", str(_spec(tmp_path)), "--out", str(out), "--replay", "1"]).exit_code == 0
    assert (out / "campaign.json").is_file()  # a replay makes the folder this campaign's
    assert runner.invoke(app, ["campaign", str(_spec(tmp_path)), "--out", str(out), "--replay", "2"]).exit_code == 0
    other = tmp_path / "other.yaml"
    other.write_text(SPEC.replace("seed: 3", "seed: 4"))
    res = runner.invoke(app, ["campaign", str(other), "--out", str(out), "--replay", "1"])
    assert res.exit_code == 2 and "another campaign ('cli_tiny'" in res.output and "use --force" in res.output
    assert sorted(p.name for p in (out / "replay").iterdir()) == ["run_000001.yaml", "run_000002.yaml"]
    res = runner.invoke(app, ["campaign", str(other), "--out", str(out), "--replay", "3", "--force"])
    assert res.exit_code == 0, res.output
    assert [p.name for p in (out / "replay").iterdir()] == ["run_000003.yaml"]  # replaced whole, not mixed
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.yaml", "other.yaml", "out"]  # nothing left aside
