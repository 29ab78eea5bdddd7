"""``agvnav fleet``: a VDA 5050 master control dispatching jobs to vehicles on an MQTT broker (issue 31)."""

from __future__ import annotations

import signal
import threading
from types import FrameType

import typer

from agvnav.cli.errors import err_console, fail, user_errors

SPEC_ARG = typer.Argument(..., help="Fleet spec YAML: scenario (route network, map), version, manufacturer, "
                          "vehicles [{serial, start}], jobs, timeout_s, traffic (true: traffic control).")
BROKER_OPT = typer.Option(..., "--broker", help="MQTT broker as mqtt://HOST:PORT.")


@user_errors
def fleet(spec: str = SPEC_ARG, broker: str = BROKER_OPT) -> None:
    """Dispatch pick-and-drop jobs over VDA 5050 to SPEC's vehicles (any vendor's), traffic-controlled on request.

    With ``traffic: true`` in SPEC the routes are planned together and each order's base is released
    as far as the traffic control allows (issue 30).
    """
    from agvnav.vda5050.bus import MissingExtraError, parse_broker, require_mqtt, serve_master
    from agvnav.vda5050.master import job_master, load_fleet_spec

    try:
        require_mqtt()
    except MissingExtraError as exc:
        raise fail(str(exc)) from None
    host, port = parse_broker(broker)
    fs = load_fleet_spec(spec)
    try:
        master = job_master(fs)
    except ValueError as exc:
        raise fail(f"{spec}: {exc}") from None
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    say = lambda s: err_console.print(s, markup=False)  # noqa: E731
    say(f"master for {len(fs.vehicles)} vehicle(s) of {fs.manufacturer} (VDA 5050 {fs.version}) on {host}:{port}")
    run = serve_master(master, host, port, fs.version, fs.interface, fs.manufacturer, fs.jobs, fs.timeout_s, stop, say)
    for serial, d in master.vehicles.items():
        print(f"{serial}: {d.done} jobs done, {d.rejected} orders rejected, at {d.node}"
              + (f", failed: {d.failed}" if d.failed else ""))
    print(f"messages sent {run.sent.count} (schema failures {len(run.sent.failures)}), "
          f"received {run.received.count} (schema failures {len(run.received.failures)})")
    if run.sent.failures:
        raise fail(f"the master sent messages its schema refuses: {run.sent.failures[0]}")
    if run.timed_out or (not stop.is_set() and run.jobs_done < fs.jobs * len(fs.vehicles)):
        raise fail(f"{run.jobs_done} of {fs.jobs * len(fs.vehicles)} jobs done in {fs.timeout_s:g} s"
                   + ("" if run.online else "; no vehicle came online"))
