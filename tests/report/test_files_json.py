"""Every JSON agvnav writes is strict: a mission run's metrics.json and the HTML report of it.

A tiny mission on a network without clothoid or NURBS edges leaves those figures
unmeasured (NaN inside); metrics.json must hold ``null`` for them, never the ``NaN``
literal strict parsers (JavaScript, jq) refuse. Its HTML report shows every figure in a
display unit beside a label without the SI suffix, and no number with an exponent.
"""

import json
import math
import re

import pytest

from agvnav.bench.common import json_document, json_text, plain_json
from agvnav.report.files import save_result
from agvnav.sim import simulate
from agvnav.world.scenario import parse_scenario

NET = """\
nodes:
  - {id: A, x: 0, y: 0, heading_deg: 0, kind: station}
  - {id: B, x: 4, y: 0, heading_deg: 0}
  - {id: C, x: 6, y: 2, heading_deg: 90, kind: station}
edges:
  - {id: ab, from: A, to: B}
  - {id: bc, from: B, to: C, speed_m_s: 0.3, geometry: {type: arc, radius_m: 2, sweep_deg: 90}}
"""

SCENARIO = """\
name: tiny_json_mission
seed: 3
step_s: 0.05
vehicle: {model: differential, track_m: 0.5, wheel_radius_m: 0.08, encoder_counts_per_rev: 4096}
traction: {speed_m_s: 0.5, max_accel_m_s2: 0.3, max_decel_m_s2: 0.3}
map: {reflectors: [{id: R1, x: -5, y: -5}, {id: R2, x: 12, y: -5}, {id: R3, x: 0, y: 12}]}
positioning: {method: dead_reckoning, initial_std: [0.0, 0.0, 0.0]}
controller: {name: kanayama, params: {convergence_distance: 1.0}}
mission:
  network: tiny.yaml
  start: A
  jobs:
    - {action: pick, station: C, duration_s: 1.0}
"""


def _strict(text):
    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


@pytest.fixture(scope="module")
def mission_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("mission")
    (d / "tiny.yaml").write_text(NET)
    sc = parse_scenario(SCENARIO, str(d / "tiny_json_mission.yaml"), d)
    result = simulate(sc)
    save_result(result, d / "run", plots=False, report=True)
    return d / "run", result


def test_a_mission_run_writes_strict_json_with_null_for_unmeasured_figures(mission_run):
    out, result = mission_run
    assert math.isnan(result.extra["max_lateral_m.nurbs"])  # the case: a figure that was not measured
    for name in ("metrics.json", "timing.json", "layout.json"):
        _strict((out / name).read_text())
    metrics = _strict((out / "metrics.json").read_text())
    assert metrics["max_lateral_m.nurbs"] is None and metrics["rms_lateral_m.clothoid"] is None
    assert metrics["max_lateral_m.line"] == pytest.approx(result.extra["max_lateral_m.line"])


def test_json_on_stdout_is_strict_too():
    body = {"metrics": {"a_m": float("nan"), "b": [float("inf"), 1.5], "c": (1, -float("inf"))}}
    doc = _strict(json_document("scenario", "x", body, 1, None))
    assert doc["metrics"] == {"a_m": None, "b": [None, 1.5], "c": [1, None]}
    np = pytest.importorskip("numpy")
    assert plain_json({"v": np.float64("nan"), "w": np.arange(2), "k": np.int64(3)}) == {"v": None, "w": [0, 1], "k": 3}
    assert _strict(json_text({"v": np.array([np.nan, 2.0])}, indent=2)) == {"v": [None, 2.0]}


def test_the_html_report_shows_labels_without_si_suffixes_beside_display_units(mission_run):
    out, _ = mission_run
    text = (out / "report.html").read_text(encoding="utf-8")
    metrics = text[text.index("<h2>Metrics</h2>"): text.index("<h2>Drive</h2>")]
    cells = re.findall(r"<t[dh][^>]*>(.*?)</t[dh]>", metrics)
    assert not [c for c in cells if re.search(r"_(m|rad|s)\b|_m[\[.]", c)], "an SI key beside a display value"
    assert not re.search(r"\d[eE][+-]?\d", " ".join(cells)), "a number with an exponent"
    rows = re.findall(r"<tr><td>(.*?)</td><td class=num>(.*?)</td><td>(.*?)</td>", metrics)
    shown = {label: (value, unit) for label, value, unit in rows}
    metrics_doc = _strict((out / "metrics.json").read_text())
    value, unit = shown["max abs lateral error"]  # below 1 m: in mm
    assert unit == "mm" and float(value) == pytest.approx(1000 * metrics_doc["max_abs_lateral_error_m"], rel=1e-3)
    value, unit = shown["distance travelled"]  # several metres: in m, not 7.475e+04 mm
    assert unit == "m" and float(value) == pytest.approx(metrics_doc["distance_travelled_m"], rel=1e-3)
    assert "Per station stop" in metrics and "stop error (mm)" in metrics and "stop heading error (deg)" in metrics
    assert "Per kind of path edge" in metrics and "max lateral (mm)" in metrics
