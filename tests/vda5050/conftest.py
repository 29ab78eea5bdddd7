"""Fixtures of the VDA 5050 tests: a Debian ``mosquitto`` broker started on a free local port.

The broker tests never skip: a machine without mosquitto fails them, naming the fix (``make test``
installs it as root through the Makefile's ``broker`` target; elsewhere ``apt-get install mosquitto``).
"""

from __future__ import annotations

import queue
import shutil
import socket
import subprocess
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

#: The source folder the vehicle processes import agvnav from, and how they run the command line.
SRC = Path(__file__).resolve().parents[2] / "src"
CLI = "from agvnav.cli import main; main()"

#: A message seen on the broker: (topic's last part, its JSON).
Msg = tuple[str, dict[str, object]]


def wait_for(q: queue.Queue[Msg], pred: Callable[[str, dict[str, object]], bool], timeout: float) -> dict[str, object]:
    """The first message of ``q`` for which ``pred(topic, message)`` holds, within ``timeout`` s."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            name, msg = q.get(timeout=0.2)
        except queue.Empty:
            continue
        if pred(name, msg):
            return msg
    raise AssertionError("timed out waiting for a message")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Mosquitto:
    """A mosquitto on 127.0.0.1:``port`` that a test may kill and start again on the same port."""

    def __init__(self, folder: Path) -> None:
        exe = shutil.which("mosquitto") or next(
            (p for p in ("/usr/sbin/mosquitto", "/usr/bin/mosquitto") if Path(p).exists()), None)
        if exe is None:
            pytest.fail("mosquitto is not installed: run `make broker` (root) or `apt-get install mosquitto`")
        self.exe, self.port = exe, _free_port()
        self.conf = folder / "mosquitto.conf"
        self.conf.write_text(f"listener {self.port} 127.0.0.1\nallow_anonymous true\npersistence false\n")
        self.proc: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        """Start it and wait until it accepts connections (fails the test after 10 s)."""
        self.proc = subprocess.Popen([self.exe, "-c", str(self.conf)], stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 10.0
        while True:
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=0.2).close()
                return
            except OSError:
                if self.proc.poll() is not None or time.monotonic() > deadline:
                    self.proc.kill()
                    pytest.fail(f"mosquitto did not start on port {self.port}")
                time.sleep(0.05)

    def kill(self) -> None:
        """SIGKILL: the broker goes away without a word."""
        if self.proc is not None:
            self.proc.kill()
            self.proc.wait(5.0)

    def stop(self) -> None:
        """SIGTERM, then SIGKILL after 5 s."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(5.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()


@pytest.fixture(scope="session")
def broker(tmp_path_factory: pytest.TempPathFactory) -> Iterator[int]:
    """A mosquitto on 127.0.0.1 (its port), stopped after the session."""
    m = Mosquitto(tmp_path_factory.mktemp("mosquitto"))
    m.start()
    yield m.port
    m.stop()


@pytest.fixture
def own_broker(tmp_path: Path) -> Iterator[Mosquitto]:
    """A mosquitto of this test alone (started), to kill and restart."""
    m = Mosquitto(tmp_path)
    m.start()
    yield m
    m.stop()


@pytest.fixture(scope="session")
def kernels_compiled() -> None:
    """The vehicle's kernels compiled into the on-disk cache before a test starts ``agvnav vehicle`` processes.

    On a fresh checkout the first vehicle compiles agvnav's kernels (a minute or more on a busy
    machine) before it connects; compiled here once, every process started after loads them. The
    vehicle drives an order for a while, so the kernels first called on the move (gating, updates,
    integrity checks) are compiled too: compiled lazily mid-drive, they would stall a vehicle
    process for seconds and a test waiting on its messages would time out.
    """
    from agvnav.routes.network import load_network
    from agvnav.vda5050.master import MasterMessages
    from agvnav.vda5050.vehicle import VdaVehicle, VehicleConfig
    from agvnav.world.scenario import load_scenario

    v = VdaVehicle(load_scenario("mission_hall_differential"), VehicleConfig("warm", "up", "2.1.0"))
    mm = MasterMessages(load_network(SRC / "agvnav/data/routes/hall_loop.yaml"), "hall", "2.1.0", "warm", "up")
    v.receive("order", mm.order("warm", 0, ["S1", "P"], 2))
    v.run_until(15.0)
