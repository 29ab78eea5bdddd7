"""Outputs safe to trust (issue 12 §4): atomic folder, --force, byte-identical results for a seed."""

import json

import pytest
from typer.testing import CliRunner

import agvnav.report.files as files
from agvnav.cli import app
from agvnav.report.files import OutputFolderError, atomic_dir, check_out_dir, save_result
from agvnav.sim import simulate
from agvnav.world.scenario import builtin_scenario, parse_scenario

runner = CliRunner()


@pytest.fixture(scope="module")
def result():
    text = builtin_scenario("guidance_test").read_text().replace("end_hold_s: 1.0", "end_hold_s: 1.0\nduration_s: 2.0")
    return simulate(parse_scenario(text, "short.yaml"))


def test_atomic_dir_replaces_only_on_success(tmp_path):
    out = tmp_path / "run"
    with atomic_dir(out) as tmp:
        (tmp / "metrics.json").write_text("{}")
        assert not out.exists()  # nothing visible until the end
    assert (out / "metrics.json").read_text() == "{}"
    with pytest.raises(RuntimeError), atomic_dir(out, force=True) as tmp:
        (tmp / "metrics.json").write_text("new")
        raise RuntimeError("crash while saving")
    assert (out / "metrics.json").read_text() == "{}"  # the old run is intact
    assert [p.name for p in tmp_path.iterdir()] == ["run"]  # no temporary folder left behind


def test_check_out_dir_rules(tmp_path):
    check_out_dir(tmp_path / "new")  # absent: fine
    (tmp_path / "empty").mkdir()
    check_out_dir(tmp_path / "empty")
    run = tmp_path / "run"
    run.mkdir()
    (run / "metrics.json").write_text("{}")
    with pytest.raises(OutputFolderError, match="--force"):
        check_out_dir(run)
    check_out_dir(run, force=True)
    other = tmp_path / "other"
    other.mkdir()
    (other / "thesis.tex").write_text("x")
    with pytest.raises(OutputFolderError, match="not an agvnav run"):
        check_out_dir(other, force=True)  # never replaced, even with force


def test_save_result_refuses_then_force_replaces_the_whole_folder(result, tmp_path):
    out = tmp_path / "o"
    save_result(result, out, plots=False)
    (out / "stale.csv").write_text("from an older run")
    with pytest.raises(OutputFolderError):
        save_result(result, out, plots=False)
    written = save_result(result, out, plots=False, force=True)
    assert {p.name for p in out.iterdir()} == {p.name for p in written}  # the stale file is gone
    assert {"metrics.json", "timing.json", "timeseries.csv", "reflections.csv"} <= {p.name for p in written}


def test_a_crash_while_writing_keeps_the_previous_run(result, tmp_path, monkeypatch):
    out = tmp_path / "o"
    save_result(result, out, plots=False)
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def broken(path, columns):
        raise OSError("disk full")

    monkeypatch.setattr(files, "write_csv", broken)
    with pytest.raises(OSError):
        save_result(result, out, plots=False, force=True)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_same_seed_same_bytes_except_timing(tmp_path):
    text = builtin_scenario("guidance_test").read_text().replace("end_hold_s: 1.0", "end_hold_s: 1.0\nduration_s: 1.5")
    a, b = tmp_path / "a", tmp_path / "b"
    save_result(simulate(parse_scenario(text, "s.yaml")), a, plots=True)
    save_result(simulate(parse_scenario(text, "s.yaml")), b, plots=True)
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir()) and "timing.json" in names
    for name in names:
        if name != "timing.json":
            assert (a / name).read_bytes() == (b / name).read_bytes(), name
    metrics = json.loads((a / "metrics.json").read_text())
    assert "wall_time_s" not in metrics and "integrity" in metrics


def test_cli_refuses_a_used_folder_without_force(tmp_path):
    text = builtin_scenario("guidance_test").read_text().replace("end_hold_s: 1.0", "end_hold_s: 1.0\nduration_s: 0.5")
    sc = tmp_path / "s.yaml"
    sc.write_text(text)
    out = tmp_path / "o"
    args = ["simulate", str(sc), "--out", str(out), "--no-plots"]
    assert runner.invoke(app, args).exit_code == 3  # 0.5 s: the run times out (written, reported failed)
    res = runner.invoke(app, args)
    assert res.exit_code == 2 and "use --force" in res.output and "Traceback" not in res.output
    assert runner.invoke(app, [*args, "--force"]).exit_code == 3
