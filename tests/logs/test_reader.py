"""The log readers refuse what they cannot trust, naming the file, line and key (issue 29).

Each case was accepted silently before: an unknown CSV column, bearings in degrees, a file of
reflections with a header only; each is one located ValueError now.
"""

import json

import numpy as np
import pytest
from _csv_log import write_csv_log

from agvnav.logs import RecordedLog, read_csv_log


def test_the_written_layout_reads_back(short_run, tmp_path):
    log = read_csv_log(write_csv_log(short_run, tmp_path / "log"))
    assert log.bearing.size == short_run.events["reflections"]["t"].size and log.truth is not None


@pytest.mark.parametrize(("name", "header", "column"), [
    ("reflections.csv", "t,bearing,bearing_deg", "bearing_deg"),
    ("reflections.csv", "t,bearings", "bearings"),
    ("odometry.csv", "t,delta_d,delta_theta,delta_lat", "delta_lat"),
    ("truth.csv", "t,x,y,psi,yaw", "yaw"),
])
def test_an_unknown_csv_column_is_refused_with_file_line_and_column(short_run, tmp_path, name, header, column):
    folder = write_csv_log(short_run, tmp_path / "log")
    path = folder / name
    lines = path.read_text().splitlines()
    extra = header.count(",") - lines[0].count(",")
    path.write_text("\n".join([header] + [line + ",0" * extra for line in lines[1:]]) + "\n")
    with pytest.raises(ValueError, match=rf"{name}:1: unknown column '{column}'"):
        read_csv_log(folder)


def test_a_simulation_s_reflector_index_column_is_known(short_run, tmp_path):
    folder = write_csv_log(short_run, tmp_path / "log")
    refl = short_run.events["reflections"]
    np.savetxt(folder / "reflections.csv", np.column_stack([refl["t"], refl["bearing"], refl["reflector_index"]]),
               delimiter=",", header="t,bearing,reflector_index", comments="", fmt="%.17g")
    assert read_csv_log(folder).bearing.size == refl["t"].size


def test_bearings_in_degrees_are_refused_naming_the_line(short_run, tmp_path):
    folder = write_csv_log(short_run, tmp_path / "log")
    refl = short_run.events["reflections"]
    deg = np.degrees(refl["bearing"])
    first = int(np.flatnonzero(np.abs(deg) > 2 * np.pi)[0])
    np.savetxt(folder / "reflections.csv", np.column_stack([refl["t"], deg]), delimiter=",", header="t,bearing",
               comments="", fmt="%.17g")
    with pytest.raises(ValueError, match=rf"reflections\.csv:{first + 2}: bearing .* beyond 2π .*radians"):
        read_csv_log(folder)
    with pytest.raises(ValueError, match="beyond 2π"):  # the API refuses them too
        RecordedLog(np.array([0.0, 1.0]), np.zeros((1, 3)), np.array([0.5]), np.array([0.5]), np.array([90.0]))


def test_bearings_over_the_full_circle_in_radians_are_accepted(short_run, tmp_path):
    """[0, 2π) is as good a convention as (-π, π]: only a magnitude beyond 2π is degrees."""
    folder = write_csv_log(short_run, tmp_path / "log")
    refl = short_run.events["reflections"]
    np.savetxt(folder / "reflections.csv", np.column_stack([refl["t"], np.mod(refl["bearing"], 2 * np.pi)]),
               delimiter=",", header="t,bearing", comments="", fmt="%.17g")
    assert read_csv_log(folder).bearing.max() > np.pi


def test_a_reflections_file_with_a_header_only_is_refused(short_run, tmp_path):
    folder = write_csv_log(short_run, tmp_path / "log")
    (folder / "reflections.csv").write_text("t,bearing\n")
    with pytest.raises(ValueError, match=r"reflections\.csv: no reflections"):
        read_csv_log(folder)


def test_a_misspelt_settings_key_is_refused_with_its_line(short_run, tmp_path):
    folder = write_csv_log(short_run, tmp_path / "log")
    doc = json.loads((folder / "settings.json").read_text())
    doc["initial_pos"] = doc.pop("initial_pose")
    text = json.dumps(doc, indent=2)
    (folder / "settings.json").write_text(text)
    line = 1 + text.splitlines().index(next(x for x in text.splitlines() if '"initial_pos"' in x))
    with pytest.raises(ValueError, match=rf"settings\.json:{line}: initial_pos: unknown key"):
        read_csv_log(folder)


def test_increments_and_counts_together_are_refused(short_run, tmp_path):
    folder = write_csv_log(short_run, tmp_path / "log")
    lines = (folder / "odometry.csv").read_text().splitlines()
    (folder / "odometry.csv").write_text("\n".join([lines[0] + ",counts_right,counts_left"] +
                                                    [x + ",0,0" for x in lines[1:]]) + "\n")
    with pytest.raises(ValueError, match=r"odometry\.csv:1: give increments .* or encoder counts"):
        read_csv_log(folder)


def _replace_line(path, line, text):
    lines = path.read_text(encoding="utf-8").splitlines()
    lines[line - 1] = text
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
@pytest.mark.parametrize("line", [2, 20])  # the first row too: its increments are ignored, not its garbage
def test_a_value_that_is_not_finite_is_refused_with_file_line_and_column(short_run, tmp_path, value, line):
    """issue 29: a NaN increment was 'odometry increments and bearings must be finite' (no file, no line)."""
    folder = write_csv_log(short_run, tmp_path / "log")
    t = short_run.series["t"][line - 2]
    _replace_line(folder / "odometry.csv", line, f"{float(t)!r},{value},0.0")
    with pytest.raises(ValueError, match=rf"odometry\.csv:{line}: delta_d: {value} is not a finite number"):
        read_csv_log(folder)
    folder = write_csv_log(short_run, tmp_path / "log2")
    refl = short_run.events["reflections"]
    _replace_line(folder / "reflections.csv", line, f"{float(refl['t'][line - 2])!r},{value}")
    with pytest.raises(ValueError, match=rf"reflections\.csv:{line}: bearing: {value} is not a finite number"):
        read_csv_log(folder)


def test_times_going_back_are_refused_with_file_and_line(short_run, tmp_path):
    """issue 29: was 'odometry instants must increase strictly' with no file or line."""
    folder = write_csv_log(short_run, tmp_path / "log")
    _replace_line(folder / "odometry.csv", 30, "0.1,0.0,0.0")
    with pytest.raises(ValueError, match=r"odometry\.csv:30: t: 0\.1 after .*: the times must increase strictly"):
        read_csv_log(folder)
    folder = write_csv_log(short_run, tmp_path / "log2")
    refl = short_run.events["reflections"]
    _replace_line(folder / "reflections.csv", 30, f"{float(refl['t'][27])!r},0.5")  # the same instant as line 29: fine
    assert read_csv_log(folder).bearing.size == refl["t"].size
    _replace_line(folder / "reflections.csv", 30, "0.0,0.5")
    with pytest.raises(ValueError, match=r"reflections\.csv:30: t: 0 after .*: the times must not decrease"):
        read_csv_log(folder)
