"""The command line as a whole: tables fit the terminal, --json for scripts, names or paths, file errors."""

from __future__ import annotations

import json
import os

import pytest
from typer.testing import CliRunner

from agvnav.cli import app
from agvnav.world import load_map
from agvnav.world.scenario import builtin_scenario

runner = CliRunner()

BINARY = bytes(range(256)) * 4  # NUL bytes and invalid UTF-8


def _err(res) -> str:
    return res.stderr if res.stderr_bytes is not None else res.output


def test_demo_at_80_columns_drops_low_priority_columns_and_wide_keeps_them():
    narrow = runner.invoke(app, ["demo"], env={"COLUMNS": "80"})
    assert narrow.exit_code == 0, narrow.output
    table = narrow.stdout.split("column(s) hidden")[0]
    assert max(len(line) for line in table.splitlines()) <= 80
    assert "method" in table and "status" in table and "position" in table  # priority 0 stays
    assert "true heading" not in table and "--wide" in narrow.stdout
    wide = runner.invoke(app, ["demo", "--wide"], env={"COLUMNS": "80"})
    assert wide.exit_code == 0
    assert "true heading (deg)" in wide.stdout and "hidden" not in wide.stdout


def _short(tmp_path):
    text = builtin_scenario("guidance_test").read_text().replace(
        "end_hold_s: 1.0", "end_hold_s: 1.0\nduration_s: 3.0", 1
    )
    p = tmp_path / "s.yaml"
    p.write_text(text)
    return p


def test_simulate_json_prints_only_the_metrics_document_on_stdout(tmp_path):
    res = runner.invoke(app, ["simulate", str(_short(tmp_path)), "--out", str(tmp_path / "o"), "--json",
                              "--no-plots", "--seed", "4"])
    assert res.exit_code == 3, res.output  # 3 s do not finish the path: a failed run, still reported
    doc = json.loads(res.stdout)  # nothing else on stdout
    assert doc["scenario"] == "guidance_test" and doc["metrics"]["seed"] == 4
    assert doc["metrics"]["outcome"] == "failed" and "positioning_rms_m" in doc["metrics"]
    assert "wall_time_s" in doc["timing"]
    meta = doc["metadata"]
    assert {"agvnav", "seed", "quick", "python", "numpy", "cpu"} <= set(meta) and meta["seed"] == 4
    assert "wrote" in _err(res) and "run FAILED" in _err(res)


def test_load_map_takes_a_shipped_name_or_a_path(tmp_path, monkeypatch):
    from agvnav.world import builtin_map

    lab = load_map("lab")
    copy = tmp_path / "lab.yaml"
    copy.write_text(builtin_map("lab").read_text())
    assert load_map(copy).reflector_ids == lab.reflector_ids and len(lab.reflectors) > 3
    assert load_map(builtin_map("hall")).reflector_ids == load_map("hall").reflector_ids
    # a local file wins over a shipped name only when it exists: "lab" here is still the shipped map
    monkeypatch.chdir(tmp_path)
    assert load_map("lab").reflector_ids == lab.reflector_ids


@pytest.mark.parametrize("kind", ["map", "scenario", "route network", "layout", "campaign"])
def test_a_binary_file_is_one_line_naming_the_file(tmp_path, kind):
    bad = tmp_path / "blob.yaml"
    bad.write_bytes(BINARY)
    if kind == "map":
        with pytest.raises(ValueError) as info:
            load_map(bad)
        assert str(bad) in str(info.value) and "\n" not in str(info.value)
        return
    argv = {
        "scenario": ["simulate", str(bad), "--out", str(tmp_path / "o")],
        "route network": ["routes", "check", str(bad)],
        "layout": ["layout", str(bad), "--out", str(tmp_path / "o")],
        "campaign": ["campaign", str(bad), "--out", str(tmp_path / "o")],
    }[kind]
    res = runner.invoke(app, argv)
    assert res.exit_code == 2, res.output
    err = _err(res).strip()
    assert err.startswith("error: ") and str(bad) in err and len(err.splitlines()) == 1
    assert "codec" not in err and "Traceback" not in res.output


def test_a_missing_map_names_the_file_and_the_shipped_names(tmp_path):
    with pytest.raises(FileNotFoundError) as info:  # also a ValueError: the CLI's one-line error
        load_map(tmp_path / "nope.yaml")
    assert str(tmp_path / "nope.yaml") in str(info.value) and "lab" in str(info.value)
    assert isinstance(info.value, ValueError)


def test_localize_map_binary_is_exit_2_naming_the_file(tmp_path):
    log = tmp_path / "log"
    log.mkdir()
    (log / "odometry.csv").write_text("t,delta_d,delta_theta\n0,0,0\n0.1,0.01,0\n")
    (log / "reflections.csv").write_text("t,bearing\n0.05,1.0\n")
    bad = tmp_path / "map.yaml"
    bad.write_bytes(BINARY)
    res = runner.invoke(app, ["localize", str(log), "--map", str(bad), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2, res.output
    assert str(bad) in _err(res) and len(_err(res).strip().splitlines()) == 1


@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_an_unreadable_scenario_names_the_file(tmp_path):
    res = runner.invoke(app, ["simulate", str(tmp_path / "missing.yaml"), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and str(tmp_path / "missing.yaml") in _err(res)


def test_every_csv_of_a_run_has_a_units_sidecar_documenting_each_column(tmp_path):
    import csv

    out = tmp_path / "o"
    res = runner.invoke(app, ["simulate", str(_short(tmp_path)), "--out", str(out), "--no-plots"])
    assert res.exit_code == 3, res.output
    for name in ("timeseries", "reflections"):
        header = (out / f"{name}.csv").read_text().splitlines()[0].split(",")
        with open(out / f"{name}.units.csv", newline="") as fh:
            rows = list(csv.DictReader(fh))
        assert [r["column"] for r in rows] == header
        assert all(r["unit"] and r["meaning"] != "not documented" for r in rows), rows
        units = {r["column"]: r["unit"] for r in rows}
        assert units["t"] == "s"
    assert units["bearing"] == "rad"


def test_laps_csv_units_come_from_the_reference(tmp_path):
    import numpy as np

    from agvnav.report.series_csv import units_path, write_csv

    path = write_csv(tmp_path / "laps.csv", {"lap": np.array([1.0]), "with_landmarks_per_lap_m": np.array([0.02]),
                                             "mystery": np.array([3.0])})
    lines = units_path(path).read_text().splitlines()
    assert lines[0] == "column,unit,meaning" and lines[1].startswith("lap,-,")
    assert lines[2].startswith("with_landmarks_per_lap_m,m,") and lines[3] == "mystery,,not documented"


def test_every_bench_command_takes_json_quick_seed_and_wide():
    from typer.main import get_command

    from agvnav.cli.bench import bench_app

    group = get_command(bench_app)
    for name, command in group.commands.items():
        options = {p.name for p in command.params}
        assert {"json", "quick", "seed", "wide"} <= options, (name, options)
