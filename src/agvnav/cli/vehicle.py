"""``agvnav vehicle``: run a scenario's vehicle as a VDA 5050 vehicle on an MQTT broker (issue 31)."""

from __future__ import annotations

import signal
import threading
from types import FrameType

import typer

from agvnav.cli.errors import err_console, fail, user_errors

SCENARIO_ARG = typer.Argument(..., help="Scenario YAML file or shipped name, with a route network (mission.network).")
BROKER_OPT = typer.Option(..., "--broker", help="MQTT broker as mqtt://HOST:PORT.")
MANUFACTURER_OPT = typer.Option(..., "--manufacturer", help="VDA 5050 manufacturer (a topic level).")
SERIAL_OPT = typer.Option(..., "--serial", help="VDA 5050 serial number (a topic level).")
INTERFACE_OPT = typer.Option("uagv", "--interface", help="Interface name, the first topic level.")
VDA_OPT = typer.Option("2.1.0", "--vda", help="Protocol version: 2.0.0, 2.1.0 or 3.0.0.")
SCALE_OPT = typer.Option(1.0, "--time-scale", help="Simulated seconds per wall-clock second.")
STATE_OPT = typer.Option(30.0, "--state-period", help="State published at least every this many s (<= 30).")
VIS_OPT = typer.Option(1.0, "--visualization-period", help="Visualization period in s (0: none).")


@user_errors
def vehicle(
    scenario: str = SCENARIO_ARG,
    broker: str = BROKER_OPT,
    manufacturer: str = MANUFACTURER_OPT,
    serial: str = SERIAL_OPT,
    interface: str = INTERFACE_OPT,
    vda: str = VDA_OPT,
    time_scale: float = SCALE_OPT,
    state_period: float = STATE_OPT,
    visualization_period: float = VIS_OPT,
) -> None:
    """Run a scenario's vehicle as a VDA 5050 vehicle on an MQTT broker until SIGINT/SIGTERM."""
    from agvnav.vda5050.bus import MissingExtraError, parse_broker, require_mqtt, serve_mqtt
    from agvnav.vda5050.vehicle import VdaVehicle, VehicleConfig
    from agvnav.world.scenario import load_scenario

    try:
        require_mqtt()
    except MissingExtraError as exc:
        raise fail(str(exc)) from None
    host, port = parse_broker(broker)
    cfg = VehicleConfig(manufacturer, serial, vda, interface, state_period, visualization_period)
    v = VdaVehicle(load_scenario(scenario), cfg)
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    err_console.print(f"vehicle {manufacturer}/{serial} (VDA 5050 {vda}) on {host}:{port}", markup=False)
    try:
        code = serve_mqtt(v, host, port, time_scale, stop, log=lambda s: err_console.print(s, markup=False))
    except ConnectionError as exc:
        raise fail(str(exc)) from None
    raise typer.Exit(code)
