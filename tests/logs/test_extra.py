"""Without the ``logs`` extra: a CSV log is read and localized, an MCAP file is one line naming the extra (issue 29).

The test environment has the extra installed, so its absence is simulated in a subprocess:
``sys.modules[name] = None`` makes ``import mcap`` (and the others) raise ImportError.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest
from _csv_log import write_csv_log

import agvnav
import agvnav.logs.reader as reader
from agvnav.logs import MissingExtraError

_RUN = """
import sys
for name in ("mcap", "mcap_ros2", "rosbags"):
    sys.modules[name] = None
from agvnav.cli import app
app(sys.argv[1:], prog_name="agvnav")
"""


def _agvnav(*args, cwd):
    src = str(Path(agvnav.__file__).parents[1])  # the agvnav this test imported, wherever it runs from
    env = {**os.environ, "COLUMNS": "120", "PYTHONPATH": os.pathsep.join([src, os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-c", _RUN, *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          env=env, timeout=300)


@pytest.fixture(scope="module")
def folder(short_run, tmp_path_factory):
    return write_csv_log(short_run, tmp_path_factory.mktemp("noextra") / "log")


def test_localize_reads_a_csv_folder_without_the_extra(folder, tmp_path):
    res = _agvnav("localize", folder, "--out", tmp_path / "loc", "--no-plots", cwd=tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "Traceback" not in res.stderr and "agvnav[logs]" in res.stdout  # estimate.mcap not written, says why
    assert sorted(p.name for p in (tmp_path / "loc").iterdir()) == [
        "layout.json", "metrics.json", "timeseries.csv", "timeseries.units.csv"]


@pytest.mark.parametrize("command", ["localize", "map"])
def test_an_mcap_file_without_the_extra_is_one_line_naming_it(command, tmp_path):
    (tmp_path / "run.mcap").write_bytes(b"")
    res = _agvnav(command, "run.mcap", "--out", tmp_path / "out", cwd=tmp_path)
    assert res.returncode == 2, res.stdout + res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "needs the logs extra: pip install 'agvnav[logs]'" in lines[0]


def test_map_reads_a_csv_folder_without_the_extra(folder, tmp_path):
    """No anchor: map refuses the drive for what it is (scale unobservable), not for a missing module."""
    res = _agvnav("map", folder, "--out", tmp_path / "m.yaml", cwd=tmp_path)
    assert "Traceback" not in res.stderr and "No module named" not in res.stderr, res.stderr
    assert res.returncode == 2 and "scale" in res.stderr


def test_the_library_error_is_an_import_error_and_a_value_error(monkeypatch, tmp_path):
    monkeypatch.setattr(reader, "_MCAP_MISSING", ImportError("No module named 'mcap'"))
    with pytest.raises(MissingExtraError, match=r"agvnav\[logs\]") as err:
        reader.read_mcap(tmp_path / "x.mcap")
    assert isinstance(err.value, ImportError) and isinstance(err.value, ValueError)
