"""The HTML report: self-contained, complete, and clean in a real browser (headless Chromium, network off).

The browser is driven through the DevTools protocol over a pipe (``--remote-debugging-pipe``,
fds 3 and 4), with the standard library only: console errors, uncaught exceptions and
every network request are collected, the time slider is moved, a screenshot is taken.
"""

import base64
import fcntl
import io
import json
import math
import os
import select
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from PIL import Image

from agvnav.bench.common import format_number
from agvnav.report.files import save_result
from agvnav.report.html import (
    REPORT_HEADER,
    RunFolder,
    covariance_ellipse,
    load_run,
    metrics_table,
    point_covariance,
    render_html,
    tracked_points,
    write_html_report,
)
from agvnav.sim import simulate
from agvnav.world.scenario import load_scenario

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
NEEDS_CHROMIUM = pytest.mark.skipif(
    CHROMIUM is None, reason="headless Chromium is not installed (Debian package `chromium`; CI installs it)"
)
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--no-first-run", "--disable-dev-shm-usage")


def _short():
    """The seed-000 guidance test's first 10 s (the transient and the straight): a short log."""
    return load_scenario("guidance_test").model_copy(update={"duration_s": 10.0})


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("html") / "run"
    save_result(simulate(_short()), out, plots=False, report=True)
    return out


def test_the_report_is_one_self_contained_file(run_dir):
    text = (run_dir / "report.html").read_text(encoding="utf-8")
    lower = text.lower()
    assert "http://" not in lower and "https://" not in lower and "<link" not in lower and "@import" not in lower
    assert "<script src" not in lower.replace(" ", " ") and 'src="data:image/png;base64,' in text
    for part in ("guidance_test", "Metrics", "Map", "Guidance errors against time", "Positioning errors against time",
                 "Positioning error histogram", "Estimator status", 'type="range"', "outcome"):
        assert part in text, part
    assert text.count("<img") == 5


def test_metrics_have_units_and_seed_figures_only_for_a_seed_scenario(run_dir):
    metrics = load_run(run_dir).metrics
    table = metrics_table(metrics)
    assert "<td>max abs lateral error</td>" in table and "<td>mm</td>" in table and "<td>deg</td>" in table
    assert "_error_m" not in table and "16.5 mm, seed 000 §4.3" in table and "3.8 deg, seed 000 §4.3" in table
    mine = metrics_table({**metrics, "scenario": "my_own_scenario"})
    assert "seed 000" not in mine and "<th>seed</th>" not in mine
    value = metrics["max_abs_lateral_error_m"]
    assert f"<td class=num>{format_number(value, 1000.0)}</td><td>mm</td>" in table  # metres shown as millimetres


def test_a_log_without_truth_or_layout_still_reports(run_dir, tmp_path):
    """A localization (no truth columns, no layout.json): map and status only."""
    run = load_run(run_dir)
    keep = ("t", "est_x", "est_y", "est_psi", "est_status")
    series = {k: run.series[k][:40] for k in keep}
    text = render_html(RunFolder(tmp_path, {"scenario": "a log"}, series, None))
    assert text.count("<img") == 2 and "<svg" in text and "Estimator status" in text
    with pytest.raises(ValueError, match="not a readable agvnav run folder"):
        load_run(tmp_path / "missing")


def test_covariance_ellipse_axes_are_three_sigma_along_the_eigenvectors():
    c = np.array([[4e-4, 0.0], [0.0, 1e-4]])  # sigma 2 cm along x, 1 cm along y
    e = covariance_ellipse(c, 3.0, n=721)
    assert np.max(np.abs(e[:, 0])) == pytest.approx(0.06) and np.max(np.abs(e[:, 1])) == pytest.approx(0.03)
    rot = np.array([[math.cos(0.5), -math.sin(0.5)], [math.sin(0.5), math.cos(0.5)]])
    er = covariance_ellipse(rot @ c @ rot.T, 3.0, n=721)
    assert np.max(np.hypot(er[:, 0], er[:, 1])) == pytest.approx(0.06, rel=1e-4)
    # every point is on the 3-sigma contour: Mahalanobis distance 3
    m = np.einsum("ij,jk,ik->i", er, np.linalg.inv(rot @ c @ rot.T), er)
    np.testing.assert_allclose(m, 9.0, rtol=1e-9)


@given(st.floats(-math.pi, math.pi), st.floats(0.0, 3.0))
def test_point_covariance_is_the_numerical_jacobian_sandwich(psi, offset):
    rng = np.random.default_rng(7)
    a = rng.normal(size=(3, 3))
    p3 = a @ a.T * 1e-4
    pose = np.array([1.0, -2.0, psi])

    def point(q):
        return q[:2] + offset * np.array([math.cos(q[2]), math.sin(q[2])])

    h = 1e-6
    jac = np.column_stack([(point(pose + h * e) - point(pose - h * e)) / (2 * h) for e in np.eye(3)])
    np.testing.assert_allclose(point_covariance(p3, psi, offset), jac @ p3 @ jac.T, rtol=1e-6, atol=1e-14)


def test_the_map_draws_the_tracked_point_the_path_is_planned_for(run_dir):
    s = load_run(run_dir).series
    true, est, off = tracked_points(s)
    np.testing.assert_array_equal(true[:, 0], s["x_tracked"])
    np.testing.assert_array_equal(est[:, 1], s["est_y_C"])
    assert off == pytest.approx(np.median(np.hypot(s["x_C"] - s["x"], s["y_C"] - s["y"])), rel=0.05)


class DevTools:
    """Chromium's DevTools protocol over ``--remote-debugging-pipe`` (JSON messages ended by NUL)."""

    def __init__(self, user_dir: Path) -> None:
        to_browser, from_browser = os.pipe(), os.pipe()
        child_in = fcntl.fcntl(to_browser[0], fcntl.F_DUPFD, 100)
        child_out = fcntl.fcntl(from_browser[1], fcntl.F_DUPFD, 100)

        def wire() -> None:
            os.dup2(child_in, 3)
            os.dup2(child_out, 4)

        args = [CHROMIUM, *FLAGS, f"--user-data-dir={user_dir}", "--remote-debugging-pipe", "about:blank"]
        self.proc = subprocess.Popen(args, preexec_fn=wire, close_fds=False,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        for fd in (child_in, child_out, to_browser[0], from_browser[1]):
            os.close(fd)
        self.out, self.inp = to_browser[1], from_browser[0]
        self.buffer = b""
        self.next_id = 0
        self.events: list[dict] = []
        self.session = None

    def send(self, method: str, params: dict | None = None, timeout: float = 30.0) -> dict:
        self.next_id += 1
        msg = {"id": self.next_id, "method": method, "params": params or {}}
        if self.session is not None:
            msg["sessionId"] = self.session
        os.write(self.out, json.dumps(msg).encode() + b"\0")
        while True:
            reply = self._receive(timeout)
            if reply.get("id") == self.next_id:
                assert "error" not in reply, reply
                return reply["result"]
            self.events.append(reply)

    def wait_event(self, method: str, timeout: float = 30.0) -> dict:
        for e in self.events:
            if e.get("method") == method:
                return e
        while True:
            e = self._receive(timeout)
            self.events.append(e)
            if e.get("method") == method:
                return e

    def _receive(self, timeout: float) -> dict:
        deadline = time.monotonic() + timeout
        while b"\0" not in self.buffer:
            ready, _, _ = select.select([self.inp], [], [], max(0.0, deadline - time.monotonic()))
            if not ready:
                raise TimeoutError("no answer from Chromium")
            chunk = os.read(self.inp, 1 << 20)
            if not chunk:
                raise EOFError("Chromium closed the pipe")
            self.buffer += chunk
        raw, self.buffer = self.buffer.split(b"\0", 1)
        return json.loads(raw)

    def close(self) -> None:
        self.proc.terminate()
        self.proc.wait(timeout=10)
        os.close(self.out)
        os.close(self.inp)


def _visit(html_file: Path, user_dir: Path, script: str | None = None) -> tuple[dict, bytes, str | None]:
    """Load ``html_file`` offline; return the problems seen, a PNG screenshot and ``script``'s value."""
    cdp = DevTools(user_dir)
    try:
        target = cdp.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        cdp.session = cdp.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        for domain in ("Runtime", "Log", "Network", "Page"):
            cdp.send(f"{domain}.enable")
        cdp.send("Network.emulateNetworkConditions",
                 {"offline": True, "latency": 0, "downloadThroughput": -1, "uploadThroughput": -1})
        cdp.send("Emulation.setDeviceMetricsOverride",
                 {"width": 1100, "height": 1500, "deviceScaleFactor": 1, "mobile": False})
        cdp.send("Page.navigate", {"url": html_file.resolve().as_uri()})
        cdp.wait_event("Page.loadEventFired")
        value = None
        if script is not None:
            value = cdp.send("Runtime.evaluate", {"expression": script, "returnByValue": True})["result"].get("value")
        png = base64.b64decode(cdp.send("Page.captureScreenshot", {"format": "png"})["data"])
        cdp.send("Runtime.evaluate", {"expression": "1"})  # flush events queued before the screenshot
        events = cdp.events
    finally:
        cdp.close()
    problems = {
        "console": [e["params"]["args"] for e in events
                    if e.get("method") == "Runtime.consoleAPICalled" and e["params"]["type"] in ("error", "assert")],
        "exceptions": [e["params"]["exceptionDetails"] for e in events if e.get("method") == "Runtime.exceptionThrown"],
        "log": [e["params"]["entry"] for e in events
                if e.get("method") == "Log.entryAdded" and e["params"]["entry"]["level"] == "error"],
        "requests": [e["params"]["request"]["url"] for e in events
                     if e.get("method") == "Network.requestWillBeSent"
                     and not e["params"]["request"]["url"].startswith(("file:", "data:", "about:"))],
    }
    return problems, png, value


SLIDE = """(function () {
  var s = document.getElementById('time'), a = document.getElementById('agv');
  var before = a.getAttribute('transform');
  s.value = s.max; s.dispatchEvent(new Event('input'));
  return [before, a.getAttribute('transform'), document.getElementById('time-label').textContent];
})()"""


@NEEDS_CHROMIUM
def test_chromium_opens_the_report_offline_without_errors(run_dir, tmp_path):
    problems, png, slid = _visit(run_dir / "report.html", tmp_path / "profile", SLIDE)
    assert problems == {"console": [], "exceptions": [], "log": [], "requests": []}
    before, after, label = slid
    assert before != after and label.startswith("t = ") and "lateral error" in label  # the slider drives
    image = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.float64)
    assert image.shape[:2] == (1500, 1100)
    not_white = np.mean(np.any(image < 240, axis=2))
    assert not_white > 0.03 and image.std() > 20  # text, table, drawing: not a blank page
    (tmp_path / "report.png").write_bytes(png)


@NEEDS_CHROMIUM
def test_the_browser_check_catches_errors_and_external_requests(tmp_path):
    """The checks above can fail: a page with a script error and an external script is caught."""
    page = tmp_path / "bad.html"
    page.write_text('<!DOCTYPE html><html><body><p>x</p><script src="https://example.com/a.js"></script>'
                    "<script>console.error('boom'); undefinedFunction();</script></body></html>", encoding="utf-8")
    problems, _, _ = _visit(page, tmp_path / "profile")
    assert problems["console"] and problems["exceptions"]
    assert problems["requests"] == ["https://example.com/a.js"]


def test_the_events_section_is_a_table_per_kind_with_units():
    """A fault window and a guard window show as rows with their times in s, never as a raw list (issue 29)."""
    from agvnav.report.html import metrics_table

    page = metrics_table({"scenario": "x", "events": {
        "faults": [{"index": 0, "kind": "blind", "start_s": 4.0, "end_s": 16.0}],
        "positioning_guard": {"windows": [{"level": "slow", "start_s": 5.0, "end_s": 17.05}], "stops": 0},
    }})
    assert "{'" not in page and "start_s" not in page
    assert "<h4>faults</h4>" in page and "<h4>positioning guard windows</h4>" in page
    assert "<th>start (s)</th><th>end (s)</th>" in page
    assert "<td class=num>blind</td><td class=num>4.000</td><td class=num>16.00</td>" in page


def test_the_rows_of_one_figure_share_one_unit():
    """distance_in_status_m per status: 0.7 m and 4.2 m both in m, not 695.1 mm beside 4.194 m (issue 29)."""
    page = metrics_table({"scenario": "x", "integrity": {
        "distance_in_status_m": {"dead_reckoning": 0.6951, "tracking": 4.194},
        "time_in_status_s": {"dead_reckoning": 0.5, "tracking": 23.55},
    }})
    assert "<td>distance in status (dead reckoning)</td><td class=num>0.6951</td><td>m</td>" in page
    assert "<td>distance in status (tracking)</td><td class=num>4.194</td><td>m</td>" in page
    assert "<td>time in status (dead reckoning)</td><td class=num>0.5000</td><td>s</td>" in page
    assert "mm" not in page and "ms" not in page
    alone = metrics_table({"scenario": "x", "integrity": {"distance_in_status_m": {"tracking": 0.5}}})
    assert "<td class=num>500.0</td><td>mm</td>" in alone  # a figure alone keeps its own unit


def test_the_heading_figure_fits_the_vehicle():
    """A steered vehicle shows xi_r, not its body heading against the tangent (43 deg on fault_blackout's arc);
    a holonomic one its body heading, without an empty wheel heading row (issue 29)."""
    steered = metrics_table({"scenario": "x", "max_abs_wheel_heading_error_rad": 0.0219,
                             "max_abs_heading_error_rad": 0.7613, "heading_reorientations": 0})
    assert "wheel heading error" in steered and "max abs heading error" not in steered
    assert "reorientations" not in steered
    holonomic = metrics_table({"scenario": "x", "max_abs_wheel_heading_error_rad": None,
                               "max_abs_heading_error_rad": 0.01, "heading_reorientations": 2})
    assert "wheel heading" not in holonomic and "max abs heading error" in holonomic and "reorientations" in holonomic


def test_the_report_refuses_a_file_it_did_not_write(run_dir, tmp_path):
    """--out FILE: someone else's file is refused unless force, an earlier report is replaced, a missing folder
    is one clear error; nothing partial is left beside the target (issue 29)."""
    mine = tmp_path / "notes.html"
    mine.write_text("my notes", encoding="utf-8")
    with pytest.raises(ValueError, match="not a report agvnav wrote"):
        write_html_report(run_dir, mine)
    assert mine.read_text(encoding="utf-8") == "my notes"
    with pytest.raises(ValueError, match="does not exist"):
        write_html_report(run_dir, tmp_path / "nowhere" / "r.html")
    with pytest.raises(ValueError, match="folder"):
        write_html_report(run_dir, tmp_path)
    out = tmp_path / "r.html"
    write_html_report(run_dir, out)
    write_html_report(run_dir, out)  # its own report: replaced
    assert out.read_text(encoding="utf-8").startswith(REPORT_HEADER)
    write_html_report(run_dir, mine, force=True)
    assert mine.read_text(encoding="utf-8").startswith(REPORT_HEADER)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.html", "r.html"]


FLEET = """\
name: lab_pair
seed: 3
step_s: 0.05
duration_s: 4.0
map: lab
traction: {speed_m_s: 0.5, max_accel_m_s2: 0.5, max_decel_m_s2: 0.5}
goniometer: {mount: [0.0, 0.0, 0.0], p_miss: 0.05}
positioning: {method: ekf, odometry_noise: [5.0e-5, 8.0e-4, 2.0e-4]}
vehicle: {model: differential, track_m: 0.5, wheel_radius_m: 0.08, encoder_counts_per_rev: 4096}
controller: {name: kanayama, params: {convergence_distance: 1.0}}
fleet:
  vehicles:
    - {id: south, path: {start: [3.0, 2.0, 0.0], segments: [{type: line, length_m: 1.0}]}}
    - {id: west, path: {start: [2.0, 4.0, 90.0], segments: [{type: line, length_m: 1.0}]}}
"""


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory):
    from agvnav.report.fleet import save_fleet
    from agvnav.sim.fleet import simulate_fleet
    from agvnav.world.fleet import parse_fleet

    out = tmp_path_factory.mktemp("fleet_html") / "fleet"
    save_fleet(simulate_fleet(parse_fleet(FLEET, "pair.yaml")), out, plots=False, report=True)
    return out


def test_a_fleet_report_holds_every_vehicle_and_agvnav_report_writes_it_too(fleet_dir, tmp_path):
    from agvnav.report.fleet_html import fleet_slider_data

    page = (fleet_dir / "report.html").read_text(encoding="utf-8")
    assert page.startswith(REPORT_HEADER) and 'id="agv0"' in page and 'id="agv1"' in page
    assert "<td>south</td>" in page and "<td>west</td>" in page and "http" not in page.split("<body>")[1]
    again = write_html_report(fleet_dir, tmp_path / "again.html")
    assert again.read_text(encoding="utf-8") == page  # the folder alone gives the same report
    # the slider's poses are the recorded ones: the last instant is each vehicle's last row
    cols = {}
    with (fleet_dir / "timeseries.csv").open() as f:
        names = f.readline().strip().split(",")
        data = np.loadtxt(f, delimiter=",", ndmin=2)
    cols = {n: data[:, i] for i, n in enumerate(names)}
    d = fleet_slider_data(cols, 2)
    for i in range(2):
        last = cols["x"][cols["vehicle"] == i][-1]
        assert d["x"][i][-1] == pytest.approx(last, abs=1e-4)
        assert d["x"][i][0] == pytest.approx(cols["x"][cols["vehicle"] == i][0], abs=1e-4)


FLEET_SLIDE = """(function () {
  var s = document.getElementById('time'), a = document.getElementById('agv1');
  var before = a.getAttribute('transform');
  s.value = s.max; s.dispatchEvent(new Event('input'));
  return [before, a.getAttribute('transform'), document.getElementById('time-label').textContent];
})()"""


@NEEDS_CHROMIUM
def test_chromium_opens_the_fleet_report_offline_and_its_slider_moves_the_vehicles(fleet_dir, tmp_path):
    problems, png, slid = _visit(fleet_dir / "report.html", tmp_path / "profile", FLEET_SLIDE)
    assert problems == {"console": [], "exceptions": [], "log": [], "requests": []}
    before, after, label = slid
    assert before != after and label.startswith("t = ") and label.endswith("2 vehicles")
    image = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.float64)
    assert np.mean(np.any(image < 240, axis=2)) > 0.03 and image.std() > 20
    (tmp_path / "fleet_report.png").write_bytes(png)
