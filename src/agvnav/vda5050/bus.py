"""Moving VDA 5050 messages: topics, an in-process bus on the simulated clock, and MQTT (paho-mqtt).

Topics are ``{interface}/{v2|v3}/{manufacturer}/{serial}/{topic}`` (2.1 §6.3, 3.0 §4.2).
:class:`InProcessBus` carries the messages of simulated runs with the broker's validation
(:class:`Checked`: every message validated against its version's schema and, for what a vehicle
publishes, for unknown keys); :func:`serve_mqtt` runs a :class:`~agvnav.vda5050.vehicle.VdaVehicle`
on a broker: ``connection`` with QoS 1, retained, with the last will CONNECTIONBROKEN
(3.0: CONNECTION_BROKEN), ONLINE on connect and OFFLINE on a stop; ``state``, ``visualization``
and ``factsheet`` with QoS 0 (2.1 §6.2). paho-mqtt is the optional extra ``vda5050``: without it
:func:`require_mqtt` raises one line naming the extra.
"""

from __future__ import annotations

import contextlib
import json
import math
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from types import ModuleType
from urllib.parse import urlparse

from agvnav.vda5050.master import JobMaster
from agvnav.vda5050.schemas import JsonObject, major, problems
from agvnav.vda5050.vehicle import VdaVehicle

__all__ = [
    "MASTER_TOPICS",
    "VEHICLE_TOPICS",
    "Checked",
    "InProcessBus",
    "MasterRun",
    "MissingExtraError",
    "parse_broker",
    "require_mqtt",
    "serve_master",
    "serve_mqtt",
    "topic",
]

#: Topics a vehicle subscribes to, and those it publishes.
MASTER_TOPICS = ("order", "instantActions")
VEHICLE_TOPICS = ("state", "visualization", "connection", "factsheet")
#: The inbox's name for a change of the broker link (not a topic: topics never hold '/').
LINK = "/link"


class MissingExtraError(RuntimeError):
    """An optional extra is not installed (one line naming it)."""


def topic(interface: str, version: str, manufacturer: str, serial: str, name: str) -> str:
    """The MQTT topic of message ``name`` for this vehicle."""
    return f"{interface}/{major(version)}/{manufacturer}/{serial}/{name}"


def require_mqtt() -> ModuleType:
    """paho-mqtt's client module, or :class:`MissingExtraError` naming the extra."""
    try:
        import paho.mqtt.client as mqtt  # noqa: PLC0415 - optional extra, imported when a broker is used
    except ModuleNotFoundError:
        raise MissingExtraError("MQTT needs the optional extra 'vda5050': pip install 'agvnav[vda5050]'") from None
    return mqtt


def parse_broker(url: str) -> tuple[str, int]:
    """``mqtt://HOST:PORT`` -> (host, port) (port 1883 when absent); ValueError naming the problem."""
    u = urlparse(url)
    if u.scheme != "mqtt" or not u.hostname:
        raise ValueError(f"--broker must be mqtt://HOST:PORT, got {url!r}")
    return u.hostname, u.port or 1883


@dataclass
class Checked:
    """Every message that passed, by version and topic, and what was wrong with those that did not."""

    version: str
    count: int = 0
    failures: list[str] = field(default_factory=list)

    def check(self, name: str, message: JsonObject, strict: bool = True) -> bool:
        """Validate ``message`` of topic ``name`` (strict: unknown keys too); counted, failures kept."""
        self.count += 1
        bad = problems(message, self.version, name, strict=strict)
        if bad:
            self.failures.append(f"{name}: {bad[0]}")
        return not bad


class InProcessBus:
    """The messages between a master and vehicles on the simulated clock, validated as on the broker.

    ``publish_master(serial, name, message)`` delivers an order or instant actions to the vehicle
    (a message that fails the schema is still delivered: the vehicle must reject it);
    :meth:`step` steps every vehicle and hands what they published to ``on_message(serial, name,
    message)`` after checking it strictly.
    """

    def __init__(self, vehicles: dict[str, VdaVehicle], version: str,
                 on_message: Callable[[str, str, JsonObject], None] | None = None) -> None:
        self.vehicles = vehicles
        self.checked = Checked(version)
        self.on_message = on_message

    def publish_master(self, serial: str, name: str, message: JsonObject) -> None:
        """A master's message to vehicle ``serial`` (checked, then delivered as its JSON text)."""
        if name not in MASTER_TOPICS:
            raise ValueError(f"a master publishes {', '.join(MASTER_TOPICS)}, not {name!r}")
        self.checked.check(name, message)
        self.vehicles[serial].receive(name, json.dumps(message))

    def step(self) -> None:
        """One step of every vehicle; their messages checked and handed on."""
        for serial, v in self.vehicles.items():
            v.step()
            for name, msg in v.drain():
                msg = json.loads(json.dumps(msg))  # as it would travel
                self.checked.check(name, msg)
                if self.on_message is not None:
                    self.on_message(serial, name, msg)


def serve_mqtt(vehicle: VdaVehicle, host: str, port: int, time_scale: float = 1.0,
               stop: threading.Event | None = None, log: Callable[[str], None] | None = None) -> int:
    """Run ``vehicle`` on the broker at ``host:port`` until ``stop`` is set; returns the exit code (0).

    The simulated clock runs ``time_scale`` times faster than the wall clock. Incoming messages are
    handed to the vehicle between steps (paho's network thread only queues them). A lost broker: the
    vehicle holds (the order keeps its base), paho reconnects, ONLINE is published again, and an
    information line says so through ``log``.

    A lost broker (:meth:`~agvnav.vda5050.vehicle.VdaVehicle.link_lost`): the vehicle stands still
    at once, as on a pause, while paho reconnects (every 1 to 5 s); on reconnection ONLINE is
    published again with the last will set anew, the vehicle reports an information entry
    ``brokerConnectionLost`` (how long, how far it moved while stopping) in its next state and
    goes on with its order. Meanwhile the broker has published the will (CONNECTIONBROKEN) if it
    saw the connection break while it stayed up.
    """
    mqtt = require_mqtt()
    if not (math.isfinite(time_scale) and time_scale > 0):
        raise ValueError(f"--time-scale must be a positive number, got {time_scale!r}")
    c = vehicle.cfg
    stop = stop or threading.Event()
    inbox: queue.Queue[tuple[str, bytes]] = queue.Queue()
    connected = threading.Event()
    say = log or (lambda _s: None)

    def t(name: str) -> str:
        return topic(c.interface, c.version, c.manufacturer, c.serial, name)

    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"agvnav-{c.manufacturer}-{c.serial}")
    client.will_set(t("connection"), json.dumps(vehicle.connection("BROKEN")), qos=1, retain=True)

    def on_connect(cl: object, userdata: object, flags: object, rc: object, props: object = None) -> None:
        client.subscribe([(t(n), 0) for n in MASTER_TOPICS])
        client.publish(t("connection"), json.dumps(vehicle.connection("ONLINE")), qos=1, retain=True)
        if connected.is_set():
            say("reconnected to the broker")
            inbox.put((LINK, b"up"))
        connected.set()

    def on_disconnect(cl: object, userdata: object, flags: object, rc: object, props: object = None) -> None:
        if not stop.is_set():
            inbox.put((LINK, b"down"))
            say(f"broker connection lost ({rc}); the vehicle stands still; reconnecting")

    def on_message(cl: object, userdata: object, msg: object) -> None:
        inbox.put((str(getattr(msg, "topic", "")).rsplit("/", 1)[-1], bytes(getattr(msg, "payload", b""))))

    client.on_connect, client.on_disconnect, client.on_message = on_connect, on_disconnect, on_message
    client.reconnect_delay_set(min_delay=1, max_delay=5)
    client.connect(host, port, keepalive=10)
    client.loop_start()
    try:
        if not connected.wait(10.0):
            raise ConnectionError(f"no answer from the MQTT broker at {host}:{port}")
        client.publish(t("factsheet"), json.dumps(vehicle.factsheet()), qos=0)
        start_wall, start_sim = time.monotonic(), vehicle.t
        while not stop.is_set():
            while not inbox.empty():
                name, payload = inbox.get_nowait()
                if name != LINK:
                    vehicle.receive(name, payload)
                elif payload == b"down":
                    vehicle.link_lost()
                else:
                    vehicle.link_restored()
            target = start_sim + (time.monotonic() - start_wall) * time_scale
            if vehicle.t + vehicle.dt <= target:
                vehicle.step()
                for name, msg in vehicle.drain():
                    client.publish(t(name), json.dumps(msg), qos=0)
            else:
                stop.wait(min(0.005, (vehicle.t + vehicle.dt - target) / time_scale))
    finally:
        info = client.publish(t("connection"), json.dumps(vehicle.connection("OFFLINE")), qos=1, retain=True)
        with contextlib.suppress(RuntimeError, ValueError):
            info.wait_for_publish(timeout=3.0)
        client.disconnect()
        client.loop_stop()
    return 0


@dataclass
class MasterRun:
    """How a master's run on a broker ended: messages checked both ways, jobs done, vehicles seen."""

    sent: Checked
    received: Checked
    jobs_done: int
    online: set[str]
    timed_out: bool


def serve_master(master: JobMaster, host: str, port: int, version: str, interface: str, manufacturer: str,
                 jobs: int, timeout_s: float, stop: threading.Event | None = None,
                 log: Callable[[str], None] | None = None) -> MasterRun:
    """Run ``master`` on the broker until every vehicle has done ``jobs`` jobs, ``timeout_s`` (s) or ``stop``.

    What the master sends is checked strictly against the schema (as on the in-process bus);
    what the vehicles send is checked too (counted in ``received``; a vendor's extra keys count
    as failures there but are still handed to the master). The master's clock is the wall clock.
    """
    mqtt = require_mqtt()
    stop = stop or threading.Event()
    say = log or (lambda _s: None)
    inbox: queue.Queue[tuple[str, str, bytes]] = queue.Queue()
    run = MasterRun(Checked(version), Checked(version), 0, set(), False)
    serials = list(master.vehicles)
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"agvnav-master-{manufacturer}")

    def on_connect(cl: object, userdata: object, flags: object, rc: object, props: object = None) -> None:
        client.subscribe([(topic(interface, version, manufacturer, s, n), 1 if n == "connection" else 0)
                          for s in serials for n in ("state", "connection")])

    def on_message(cl: object, userdata: object, msg: object) -> None:
        parts = str(getattr(msg, "topic", "")).split("/")
        inbox.put((parts[-2], parts[-1], bytes(getattr(msg, "payload", b""))))

    def send(serial: str, name: str, message: JsonObject) -> None:
        run.sent.check(name, message)
        client.publish(topic(interface, version, manufacturer, serial, name), json.dumps(message), qos=0)

    master.send, master.max_jobs = send, jobs
    client.on_connect, client.on_message = on_connect, on_message
    client.reconnect_delay_set(min_delay=1, max_delay=5)
    client.connect(host, port, keepalive=10)
    client.loop_start()
    start = time.monotonic()
    try:
        while not stop.is_set():
            t = time.monotonic() - start
            if t > timeout_s:
                run.timed_out = True
                break
            while not inbox.empty():
                serial, name, payload = inbox.get_nowait()
                try:
                    msg = json.loads(payload)
                except ValueError:
                    run.received.count += 1
                    run.received.failures.append(f"{serial}/{name}: malformed JSON")
                    continue
                run.received.check(name, msg)
                if name == "connection" and msg.get("connectionState") == "ONLINE" and serial not in run.online:
                    run.online.add(serial)
                    say(f"vehicle {manufacturer}/{serial} online")
                master.on_message(serial, name, msg)
            if all(s in run.online for s in serials):
                master.tick(t)
            if all(d.done >= jobs for d in master.vehicles.values()):
                break
            stop.wait(0.02)
    finally:
        client.disconnect()
        client.loop_stop()
    run.jobs_done = master.jobs_done
    return run
