"""A broker that goes away (issue 31): the vehicle stands still, reconnects, says what happened; the will shows.

mosquitto is killed (SIGKILL) while ``agvnav vehicle`` drives an order, started again on the same
port 3 s later: the vehicle must not have driven on meanwhile (its position in the first
visualization after reconnection against the last before the loss, and its own account in the
``brokerConnectionLost`` information), publishes ONLINE again, answers a stateRequest with it, drives on, and its last
will (set anew on reconnection) shows CONNECTIONBROKEN when it is killed afterwards.
"""

from __future__ import annotations

import json
import math
import os
import queue
import subprocess
import sys
import time

import paho.mqtt.client as mqtt
from tests.vda5050.conftest import CLI, SRC, Mosquitto, Msg, wait_for

from agvnav.routes.network import load_network
from agvnav.vda5050.master import MasterMessages
from agvnav.vda5050.schemas import problems

PREFIX = "uagv/v2/acme/lost"




def xy(msg: dict[str, object]) -> tuple[float, float]:
    pos = msg["agvPosition"]
    assert isinstance(pos, dict)
    return float(pos["x"]), float(pos["y"])


def test_broker_killed_and_restarted(own_broker: Mosquitto, kernels_compiled: None) -> None:
    port = own_broker.port
    env = os.environ | {"PYTHONPATH": str(SRC)}
    proc = subprocess.Popen(
        [sys.executable, "-c", CLI, "vehicle", "mission_hall_differential", "--broker", f"mqtt://127.0.0.1:{port}",
         "--manufacturer", "acme", "--serial", "lost", "--vda", "2.1.0", "--visualization-period", "0.2"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    q: queue.Queue[Msg] = queue.Queue()
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="test-master-lost")
    client.on_connect = lambda c, u, f, rc, p=None: c.subscribe(
        [(f"{PREFIX}/{n}", 1) for n in ("state", "visualization", "connection")])
    client.on_message = lambda c, u, m: q.put((m.topic.rsplit("/", 1)[-1], json.loads(m.payload)))
    client.reconnect_delay_set(min_delay=1, max_delay=1)
    client.connect("127.0.0.1", port)
    client.loop_start()
    try:
        wait_for(q, lambda n, m: n == "connection" and m["connectionState"] == "ONLINE", 60)
        wait_for(q, lambda n, m: n == "state", 30)
        mm = MasterMessages(load_network(SRC / "agvnav/data/routes/hall_loop.yaml"), "hall", "2.1.0", "acme", "lost")
        client.publish(f"{PREFIX}/order", json.dumps(mm.order("o1", 0, ["S1", "P"], 2)), qos=1)
        wait_for(q, lambda n, m: n == "state" and m["orderId"] == "o1" and m["driving"], 20)
        time.sleep(2.0)  # under way, about 0.5 m/s
        while not q.empty():
            q.get_nowait()
        before = wait_for(q, lambda n, m: n == "visualization", 5)
        own_broker.kill()
        lost = time.monotonic()
        time.sleep(3.0)
        own_broker.start()
        # the vehicle's ONLINE is retained: this master sees it once both are back, then asks for the state
        wait_for(q, lambda n, m: n == "connection" and m["connectionState"] == "ONLINE", 30)
        client.publish(f"{PREFIX}/instantActions", json.dumps(mm.instant(mm.action("stateRequest", "sr", "NONE"))))
        st = wait_for(q, lambda n, m: n == "state" and any(i["infoType"] == "brokerConnectionLost"
                                                           for i in m.get("information", [])), 10)
        assert time.monotonic() - lost > 3.0
        assert problems(st, "2.1.0", "state") == []
        info = next(i for i in st["information"] if i["infoType"] == "brokerConnectionLost")  # type: ignore[union-attr]
        assert info["infoLevel"] == "INFO"
        moved = float(str(info["infoDescription"]).split("(")[1].split(" m")[0])
        assert moved < 0.6  # stopping from 0.5 m/s at 0.3 m/s^2: 0.42 m
        after = wait_for(q, lambda n, m: n == "visualization", 5)
        # the first visualization after the loss: had it driven on for 3 s it would be 1.5 m further
        assert math.dist(xy(before), xy(after)) < 0.5 * 0.2 + 0.6
        assert st["orderId"] == "o1" and st["errors"] == []
        wait_for(q, lambda n, m: n == "visualization" and math.dist(xy(m), xy(after)) > 0.3, 20)  # it drives on
        proc.kill()  # no goodbye: the will registered on reconnection
        msg = wait_for(q, lambda n, m: n == "connection" and m["connectionState"] != "ONLINE", 30)
        assert msg["connectionState"] == "CONNECTIONBROKEN"
    finally:
        if proc.poll() is None:
            proc.kill()
        client.loop_stop()
        client.disconnect()
