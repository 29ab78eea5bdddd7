"""The closed loop of seed 000 Fig. 9: fixed step, deterministic, every signal recorded."""

from agvnav.sim.engine import Autopilot, ClosedLoop, Estimator, LoopOutput, Plant, Sensor
from agvnav.sim.metrics import RunMetrics, TransientSpec, compute_metrics, lateral_position_error, transient_end_index
from agvnav.sim.recorder import EventLog, Recorder
from agvnav.sim.run import SimResult, simulate

__all__ = [
    "Autopilot",
    "ClosedLoop",
    "Estimator",
    "EventLog",
    "LoopOutput",
    "Plant",
    "Recorder",
    "RunMetrics",
    "Sensor",
    "SimResult",
    "TransientSpec",
    "compute_metrics",
    "lateral_position_error",
    "simulate",
    "transient_end_index",
]
