"""Interoperation with an independent VDA 5050 implementation: coatyio's ``vda-5050-lib`` (npm, MIT, VDA 5050 2.0).

Its ``MasterController`` (``interop/master_drives_agvnav.js``) drives ``agvnav vehicle --vda 2.0.0``
on a mosquitto the tests start, through an order with pick and drop whose horizon an order update
releases, a pause, a cancelOrder and an invalid order that must be rejected; every step's verdict
is the library's own view of the vehicle's answers (its callbacks), printed as JSON lines.

The library comes from the npm registry, pinned by ``interop/package-lock.json``, installed with
``npm ci`` once into a cache folder keyed on the lock file (``$AGVNAV_NPM_CACHE``, default
``~/.cache/agvnav/npm``). Decision: this test never skips. Without ``node``/``npm`` (or without the
registry on a first run) it FAILS naming the fix, so a CI machine lacking them shows red instead of
silently testing less, as the broker tests do for mosquitto.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import math
import os
import queue
import shutil
import subprocess
import sys
import time
from pathlib import Path

import paho.mqtt.client as mqtt
import pytest
from tests.vda5050.conftest import CLI, SRC

from agvnav.sim.mission import load_mission_network
from agvnav.world.scenario import load_scenario

HERE = Path(__file__).resolve().parent / "interop"


def interop_dir() -> Path:
    """The cache folder holding the pinned npm packages and the scripts (``npm ci`` on first use)."""
    node, npm = shutil.which("node"), shutil.which("npm")
    if node is None or npm is None:
        pytest.fail("node and npm are needed for the VDA 5050 interoperation test: apt-get install nodejs npm")
    lock = (HERE / "package-lock.json").read_bytes()
    root = Path(os.environ.get("AGVNAV_NPM_CACHE", Path.home() / ".cache" / "agvnav" / "npm"))
    folder = root / f"vda5050-interop-{hashlib.sha256(lock).hexdigest()[:16]}"
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder.with_suffix(".lock"), "w") as lockfile:  # two xdist workers never install at once
        fcntl.flock(lockfile, fcntl.LOCK_EX)
        if not (folder / "node_modules" / ".agvnav-complete").is_file():
            for name in ("package.json", "package-lock.json"):
                shutil.copy(HERE / name, folder / name)
            done = subprocess.run([npm, "ci", "--no-audit", "--no-fund"], cwd=folder, capture_output=True,
                                  text=True, timeout=300, check=False)
            if done.returncode != 0:
                pytest.fail(f"npm ci of the pinned vda-5050-lib failed in {folder}: {done.stderr.strip()[-500:]}")
            (folder / "node_modules" / ".agvnav-complete").write_text("ok\n")
        for script in HERE.glob("*.js"):
            shutil.copy(script, folder / script.name)
    return folder


def network_json(path: Path) -> None:
    """The hall network's node positions as the master script reads them."""
    sc = load_scenario("mission_hall_differential")
    net = load_mission_network(sc)
    nodes = {n.id: {"x": n.x, "y": n.y, "theta": math.remainder(n.heading or 0.0, 2 * math.pi)}
             for n in net.nodes.values()}
    path.write_text(json.dumps({"mapId": sc.map, "nodes": nodes}), encoding="utf-8")


def test_vda_5050_lib_master_drives_agvnav_vehicle(broker: int, tmp_path: Path, kernels_compiled: None) -> None:
    folder = interop_dir()
    network_json(tmp_path / "net.json")
    env = os.environ | {"PYTHONPATH": str(SRC)}
    proc = subprocess.Popen(
        [sys.executable, "-c", CLI, "vehicle", "mission_hall_differential", "--broker", f"mqtt://127.0.0.1:{broker}",
         "--manufacturer", "acme", "--serial", "interop", "--vda", "2.0.0", "--time-scale", "4"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    online: queue.Queue[str] = queue.Queue()
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="test-interop-watch")
    client.on_message = lambda c, u, m: online.put(json.loads(m.payload)["connectionState"])
    client.connect("127.0.0.1", broker)
    client.subscribe("uagv/v2/acme/interop/connection", qos=1)
    client.loop_start()
    try:
        end = time.monotonic() + 60
        while online.get(timeout=max(0.1, end - time.monotonic())) != "ONLINE":
            pass
        run = subprocess.run(["node", "master_drives_agvnav.js", f"mqtt://127.0.0.1:{broker}", "acme", "interop",
                              str(tmp_path / "net.json")], cwd=folder, capture_output=True, text=True, timeout=90,
                             check=False)
    finally:
        proc.terminate()
        proc.wait(20)
        client.loop_stop()
        client.disconnect()
    steps = {r["step"]: r for r in (json.loads(line) for line in run.stdout.splitlines() if line.startswith("{"))
             if "step" in r}
    assert list(steps) == ["order base with pick", "order update with drop", "startPause", "stopPause",
                           "cancelOrder", "invalid order rejected"], run.stdout + run.stderr
    assert all(r["ok"] for r in steps.values()), run.stdout
    assert run.returncode == 0
    assert steps["invalid order rejected"]["error"]["errorType"] == "noRouteError"


def test_agvnav_master_drives_vda_5050_lib_vehicle(broker: int, tmp_path: Path, kernels_compiled: None) -> None:
    """``agvnav fleet`` drives the library's AgvController (its VirtualAgvAdapter) through a pick and a drop job."""
    folder = interop_dir()
    network_json(tmp_path / "net.json")
    agv = subprocess.Popen(["node", "agv_for_agvnav_master.js", f"mqtt://127.0.0.1:{broker}", "vlib", "x1",
                            str(tmp_path / "net.json"), "S1"], cwd=folder, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True)
    spec = tmp_path / "fleet.yaml"
    spec.write_text("scenario: mission_hall_differential\nversion: 2.0.0\nmanufacturer: vlib\n"
                    "vehicles: [{serial: x1, start: S1}]\njobs: 2\ntimeout_s: 50\naction_s: 0.5\n", encoding="utf-8")
    try:
        assert agv.stdout is not None and json.loads(agv.stdout.readline())["event"] == "started"
        run = subprocess.run([sys.executable, "-c", CLI, "fleet", str(spec), "--broker", f"mqtt://127.0.0.1:{broker}"],
                             env=os.environ | {"PYTHONPATH": str(SRC)}, capture_output=True, text=True, timeout=90,
                             check=False)
    finally:
        agv.terminate()
        out = agv.communicate(timeout=20)[0]
    assert run.returncode == 0, run.stdout + run.stderr
    assert "x1: 2 jobs done, 0 orders rejected" in run.stdout
    assert "(schema failures 0), received" in run.stdout and run.stdout.rstrip().endswith("(schema failures 0)")
    orders = [json.loads(line) for line in out.splitlines() if line.startswith('{"event":"order"')]
    assert [o["orderUpdateId"] for o in orders][:2] == [0, 1]  # the horizon released by an update
