"""``agvnav vehicle`` on a real mosquitto: connection with last will, an order driven, SIGTERM -> OFFLINE, exit 0."""

from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
from pathlib import Path

import paho.mqtt.client as mqtt
from tests.vda5050.conftest import CLI, SRC, wait_for

from agvnav.routes.network import load_network
from agvnav.vda5050.master import MasterMessages
from agvnav.vda5050.schemas import problems


def test_vehicle_on_mosquitto(broker: int, kernels_compiled: None) -> None:
    env = os.environ | {"PYTHONPATH": str(SRC)}
    proc = subprocess.Popen(
        [sys.executable, "-c", CLI, "vehicle", "mission_hall_differential", "--broker",
         f"mqtt://127.0.0.1:{broker}", "--manufacturer", "acme", "--serial", "v1", "--vda", "2.1.0",
         "--time-scale", "4"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    q: queue.Queue[tuple[str, dict[str, object]]] = queue.Queue()
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="test-master")
    client.on_message = lambda c, u, m: q.put((m.topic.rsplit("/", 1)[-1], json.loads(m.payload)))
    client.connect("127.0.0.1", broker)
    client.subscribe([("uagv/v2/acme/v1/state", 0), ("uagv/v2/acme/v1/connection", 1)])
    client.loop_start()
    try:
        wait_for(q, lambda n, m: n == "connection" and m["connectionState"] == "ONLINE", 60)
        st = wait_for(q, lambda n, m: n == "state", 30)
        assert problems(st, "2.1.0", "state") == []
        net = load_network(Path(SRC / "agvnav/data/routes/hall_loop.yaml"))
        mm = MasterMessages(net, "hall", "2.1.0", "acme", "v1")
        client.publish("uagv/v2/acme/v1/order", b"{broken")
        wait_for(q, lambda n, m: n == "state" and any(e["errorType"] == "validationError" for e in m["errors"]), 20)
        client.publish("uagv/v2/acme/v1/order", json.dumps(mm.order("o1", 0, ["S1", "P"], 2)))
        st = wait_for(q, lambda n, m: n == "state" and m["orderId"] == "o1" and m["driving"], 20)
        assert st["errors"] == [] and problems(st, "2.1.0", "state") == []
        client.publish("uagv/v2/acme/v1/instantActions", json.dumps(mm.instant(mm.action("cancelOrder", "c"))))
        wait_for(q, lambda n, m: n == "state" and any(a["actionId"] == "c" and a["actionStatus"] == "FINISHED"
                                                      for a in m["actionStates"]), 20)
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(20) == 0
        wait_for(q, lambda n, m: n == "connection" and m["connectionState"] == "OFFLINE", 10)
    finally:
        if proc.poll() is None:
            proc.kill()
        client.loop_stop()
        client.disconnect()


def test_last_will_is_connectionbroken(broker: int, kernels_compiled: None) -> None:
    env = os.environ | {"PYTHONPATH": str(SRC)}
    proc = subprocess.Popen(
        [sys.executable, "-c", CLI, "vehicle", "mission_hall_differential", "--broker",
         f"mqtt://127.0.0.1:{broker}", "--manufacturer", "acme", "--serial", "v2", "--vda", "3.0.0"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    q: queue.Queue[tuple[str, dict[str, object]]] = queue.Queue()
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="test-master-2")
    client.on_message = lambda c, u, m: q.put((m.topic.rsplit("/", 1)[-1], json.loads(m.payload)))
    client.connect("127.0.0.1", broker)
    client.subscribe("uagv/v3/acme/v2/connection", qos=1)
    client.loop_start()
    try:
        wait_for(q, lambda n, m: m["connectionState"] == "ONLINE", 60)
        proc.kill()  # no goodbye: the broker publishes the will
        msg = wait_for(q, lambda n, m: m["connectionState"] != "ONLINE", 30)
        assert msg["connectionState"] == "CONNECTION_BROKEN" and problems(msg, "3.0.0", "connection") == []
    finally:
        proc.kill()
        client.loop_stop()
        client.disconnect()
