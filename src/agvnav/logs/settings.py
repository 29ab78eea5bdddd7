"""The positioning settings of a log (``settings.json``, ``/agvnav/settings``): every key known, SI and radians.

A key the schema does not know is refused, as a scenario key is: a misspelt
``initial_pos`` would otherwise be ignored and leave the estimator searching its
start pose for the whole log. Angles are radians; a mount yaw, start heading or
bearing offset beyond 2π in magnitude can only be degrees and is refused. The
error names the document (the file, or the MCAP file and topic), the line where
it is known and the key: ``settings.json:4: initial_pos: unknown key``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Annotated, Any

import yaml
from pydantic import AfterValidator, Field, ValidationError

from agvnav.world.strict import Finite, NonNegFloat, PosFloat, ScenarioError, StrictModel, first_error, node_line
from agvnav.world.yaml_strict import compose

__all__ = ["ANGLE_LIMIT_RAD", "LogSettings", "check_angle_rad", "check_settings"]

#: Largest magnitude (rad) an angle of a log may have: beyond a full turn it can only be degrees.
ANGLE_LIMIT_RAD = 2.0 * math.pi


def check_angle_rad(value: float) -> float:
    """``value`` (rad) if ``|value| <= 2π``; else ValueError: an angle beyond a full turn is in degrees."""
    if abs(value) > ANGLE_LIMIT_RAD:
        raise ValueError(f"{value!r} is beyond 2π in magnitude: angles are radians (is this degrees?)")
    return value


Radians = Annotated[float, Field(allow_inf_nan=False), AfterValidator(check_angle_rad)]
Triple = tuple[Finite, Finite, Finite]
Pose = tuple[Finite, Finite, Radians]


class WheelOdometry(StrictModel):
    """The steered-wheel odometry model (:class:`agvnav.odometry.SteeredOdometryNoise`, SI)."""

    model: str
    wheelbase_m: PosFloat
    slip_k: NonNegFloat
    steering_std: NonNegFloat = 0.0
    step_m: NonNegFloat = 0.0
    radius_scale_std: NonNegFloat = 0.0
    steering_offset_std: NonNegFloat = 0.0
    max_steering_rad: Radians | None = None


class Encoders(StrictModel):
    """A differential vehicle's encoders (odometry.csv of counts): m per count, track (m), counter width."""

    metres_per_count_right: PosFloat
    metres_per_count_left: PosFloat
    track_m: PosFloat
    counter_bits: Annotated[int, Field(gt=0, le=64)] | None = None


class LogSettings(StrictModel):
    """The keys of a log's settings document (docs/logs.md); all optional, SI units and radians."""

    scenario: str | None = None
    map: str | None = None
    method: str | None = None
    mount: Pose | None = None
    initial_pose: Pose | None = None
    initial_covariance: tuple[Triple, Triple, Triple] | None = None
    pulses_per_rev: Annotated[int, Field(gt=0)] | None = None
    bearing_offset: Radians | None = None
    rate_hz: PosFloat | None = None
    max_range_m: PosFloat | None = None
    map_std_m: NonNegFloat | None = None
    step_s: PosFloat | None = None
    odometry_noise: tuple[NonNegFloat, NonNegFloat, NonNegFloat] | None = None
    wheel_odometry: WheelOdometry | None = None
    encoders: Encoders | None = None
    params: dict[str, Any] | None = None


def check_settings(doc: Any, source: str = "settings", text: str | None = None) -> dict[str, Any]:
    """``doc`` (a settings mapping) unchanged if :class:`LogSettings` accepts it; else a located ValueError.

    ``source`` names the document in the message (a file, or ``run.mcap /agvnav/settings``);
    ``text``, the document's JSON text, gives the line of the offending key.
    """
    if not isinstance(doc, Mapping):
        raise ScenarioError("the settings document must be a JSON object of keys", (), 1 if text else None, source)
    try:
        LogSettings.model_validate(doc)
    except ValidationError as exc:
        key, msg = first_error(exc, doc)
        raise ScenarioError(msg, key, _line(text, key), source) from None
    return dict(doc)


def _line(text: str | None, key: tuple[str | int, ...]) -> int | None:
    """The line of ``key`` in JSON ``text`` (JSON is YAML flow syntax: the YAML composer locates it)."""
    if text is None:
        return None
    try:
        return node_line(compose(text), key)
    except yaml.YAMLError:  # a JSON layout PyYAML does not read as YAML: the message goes without a line
        return None
