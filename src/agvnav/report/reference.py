"""The output files of a run and every CSV column with its unit: the second half of docs/scenarios.md.

``python -m agvnav.report.reference`` prints the whole scenario reference
(schema keys from :mod:`agvnav.world.reference`, then the outputs documented
here). A test runs every shipped scenario briefly and checks that each column
it writes is in :data:`COLUMNS`, and that docs/scenarios.md equals this output.
"""

from __future__ import annotations

import math

__all__ = [
    "COLUMNS",
    "EVENT_COLUMNS",
    "HYBRID_PARAMETERS",
    "LAP_COLUMNS",
    "PER_OBSTACLE",
    "controllers_reference",
    "outputs_reference",
    "reference_markdown",
]

#: timeseries.csv columns: name -> (unit, meaning). One row per control step.
COLUMNS: dict[str, tuple[str, str]] = {
    "t": ("s", "time since the start"),
    "x": ("m", "true base_link x in map (REP-105)"),
    "y": ("m", "true base_link y in map"),
    "psi": ("rad", "true base_link heading in map"),
    "est_x": ("m", "estimated base_link x"),
    "est_y": ("m", "estimated base_link y"),
    "est_psi": ("rad", "estimated base_link heading"),
    "est_status": ("-", "estimator status: 0 initialising, 1 tracking, 2 dead reckoning, 3 degraded, 4 lost, -1 other"),
    "est_valid": ("-", "1 when the estimator has a fix (status tracking)"),
    "est_x_C": ("m", "estimated tracked point x (C for a steered vehicle guiding C, else base_link)"),
    "est_y_C": ("m", "estimated tracked point y"),
    "x_tracked": ("m", "true guided point x (a mission: C or O, as guided at that instant)"),
    "y_tracked": ("m", "true guided point y"),
    "point_offset": ("m", "distance of the guided point ahead of base_link (C: the wheelbase, O or base_link: 0)"),
    "lateral_error": ("m", (
        "true lateral error of the guided point from its own path, left positive (a mission: the point guided at "
        "that instant, C or O after point switching, against the run it drove)"
    )),
    "heading_error": ("rad", (
        "true heading error: wheel heading error xi_r (steered) or body heading against the path tangent plus "
        "yaw offset"
    )),
    "s_true": ("m", "path abscissa of the true guided point's projection"),
    "eps_c": ("m", "seed 000 Fig. 5 lateral error of the tracked point (steered vehicles)"),
    "eps_o": ("m", "seed 000 Fig. 5 lateral error of O (steered vehicles)"),
    "xi": ("rad", "seed 000 Fig. 5 heading error of the body (steered vehicles)"),
    "xi_r": ("rad", "seed 000 eq. 9 wheel heading error relative to the feed-forward (steered vehicles)"),
    "gamma": ("rad", "true steering angle of the front wheel (tricycle stacker)"),
    "phi": ("rad", "true steering angle (rear-drive steered vehicles, bicycle equivalent)"),
    "phi_left": ("rad", "left front wheel angle (Ackermann)"),
    "phi_right": ("rad", "right front wheel angle (Ackermann)"),
    "x_C": ("m", "true x of the steered wheel C (tricycle stacker)"),
    "y_C": ("m", "true y of the steered wheel C"),
    "v": ("m/s", "true speed of the driven wheel or body"),
    "gamma_rate": ("rad/s", "steering rate of the servo (tricycle stacker)"),
    "phi_rate": ("rad/s", "steering rate of the servo (rear-drive steered vehicles)"),
    "gamma_meas": ("rad", "steering encoder reading"),
    "ds_meas": ("m", "traction encoder distance of the last step"),
    "odo_dd": ("m", "odometry increment: forward body-twist distance of the last step"),
    "odo_dtheta": ("rad", "odometry increment: heading change of the last step"),
    "odo_dlat": ("m", "odometry increment: lateral body-twist distance of the last step (holonomic)"),
    "distance_C": ("m", "distance rolled by the drive wheel C"),
    "distance_O": ("m", "distance rolled by the rear axle midpoint O"),
    "distance": ("m", "distance travelled by base_link"),
    "omega_right": ("rad/s", "right wheel or sprocket speed"),
    "omega_left": ("rad/s", "left wheel or sprocket speed"),
    "omega_fl": ("rad/s", "front-left mecanum wheel speed"),
    "omega_fr": ("rad/s", "front-right mecanum wheel speed"),
    "omega_rl": ("rad/s", "rear-left mecanum wheel speed"),
    "omega_rr": ("rad/s", "rear-right mecanum wheel speed"),
    "v_x": ("m/s", "true forward body speed (holonomic)"),
    "v_y": ("m/s", "true lateral body speed (holonomic)"),
    "yaw_rate": ("rad/s", "true yaw rate"),
    "hitch_angle": ("rad", "tractor heading minus trailer heading"),
    "x_trailer": ("m", "true trailer axle midpoint x"),
    "y_trailer": ("m", "true trailer axle midpoint y"),
    "psi_trailer": ("rad", "true trailer heading"),
    "v_cmd": ("m/s", "speed command of the speed profile (tracked point, signed)"),
    "rate_cmd": ("rad/s", "follower's rate command: steering rate (steered) or yaw rate"),
    "v_lateral_cmd": ("m/s", "follower's lateral speed command (holonomic)"),
    "s_est": ("m", "path progress of the estimated tracked point"),
    "lateral_error_est": ("m", "lateral error the follower sees (estimated pose; eps_c if steered)"),
    "heading_error_est": ("rad", "heading error the follower sees (estimated pose; xi_r if steered)"),
    "remaining": ("m", "path length left"),
    "dock_phase": ("-", "docking (issue 32): 0 recognise, 1 approach, 2 fine, 3 settle, 4 finished, -1 failed"),
    "dock_x": ("m", "docking: estimated base_link x in the station frame"),
    "dock_y": ("m", "docking: estimated base_link y in the station frame"),
    "dock_psi": ("rad", "docking: estimated heading in the station frame"),
    "dock_sigma3_m": ("m", "docking: 3 sigma of the station-relative position (largest axis)"),
    "station_offset_x": ("m", "docking: measured station offset from its map pose, x (station frame)"),
    "station_offset_y": ("m", "docking: measured station offset, y"),
    "station_offset_psi": ("rad", "docking: measured station offset, heading"),
    "guard_level": ("-", "positioning guard: 0 normal, 1 slow (degraded), 2 stop (lost, or 3 sigma over the limit)"),
    "speed_scale": ("-", "factor the guard applies to the planned speed (1, safety.slow_speed_fraction or 0)"),
    "lateral_3sigma_est": ("m", "3 sigma of the estimated position across the vehicle's heading"),
    "est_cov_xx": ("m²", "reported covariance of the estimate: x x"),
    "est_cov_xy": ("m²", "reported covariance: x y"),
    "est_cov_xpsi": ("m·rad", "reported covariance: x heading"),
    "est_cov_yy": ("m²", "reported covariance: y y"),
    "est_cov_ypsi": ("m·rad", "reported covariance: y heading"),
    "est_cov_psipsi": ("rad²", "reported covariance: heading heading"),
    "est_quality": ("-", "the estimator's 0-1 quality figure (NaN when it reports none)"),
    "est_reflectors_used": ("-", "distinct reflectors behind the estimate over the integrity window (NaN if none)"),
    "est_n_dropped": ("-", "readings the estimator dropped as implausible so far (NaN when it counts none)"),
    "leg": ("-", "mission: index of the job being driven or waited for"),
    "nodes_passed": ("-", "mission: route network nodes passed so far (topological position)"),
    "dwelling": ("-", "mission: 1 while stopped at a station for a job"),
    "reaction_level": ("-", "reactive control: 0 clear, 1 slow (warning field), 2 stop (protective field or ranger)"),
    "field_v_max": ("m/s", "reactive control: top speed of the selected safety-field set (NaN without a scanner)"),
    "protective_length": ("m", "reactive control: the selected protective field's reach beyond the body"),
    "field_trigger": ("-", (
        "reactive control: index of the obstacle in the most severe intruded field; -2 a wall, -3 the stopping "
        "ultrasonic ranger, -1 none"
    )),
    "ranger_stop_range": ("m", "reactive control: last reading of the stopping ultrasonic ranger (NaN none)"),
    "avoiding": ("-", "reactive control: 1 while driving a detour around an obstacle"),
    "detour_target": ("-", "reactive control: index of the obstacle the detour passes (-1 none or unknown)"),
    "corridor_excess": ("m", "reactive control: how far the body reaches beyond the corridor (0 inside; NaN none)"),
    "fault__<id>": ("-", "injected fault: 1 while it is active; `<id>` its index and kind, e.g. `fault__0_blind`"),
    "obstacle_x__<id>": ("m", "obstacle `<id>`: x of its centre (NaN while it is not there)"),
    "obstacle_y__<id>": ("m", "obstacle `<id>`: y of its centre (NaN while it is not there)"),
    "clearance__<id>": ("m", (
        "reactive control: one column per obstacle (`<id>` its id): distance from the true footprint to it (exact "
        "within 2 m, beyond a lower bound from the bounding circles)"
    )),
}

#: A column ``PREFIX__ID`` (one per obstacle) is documented under ``PREFIX__<id>`` in :data:`COLUMNS`.
PER_OBSTACLE = "__<id>"

#: reflections.csv columns (one row per goniometer reflection).
EVENT_COLUMNS: dict[str, tuple[str, str]] = {
    "t": ("s", "instant of the reflection"),
    "bearing": ("rad", "measured bearing in the head frame, quantised by the encoder"),
    "reflector_index": ("-", (
        "ground truth: index of the reflector in the true map, -1 spurious (never used by positioning)"
    )),
    "stamp": ("s", "with a reflection_delay fault: the time stamp delivered to the estimator (t is the arrival)"),
}


#: laps.csv columns of a route scenario (seed 004): one row per lap, per mode (with/without landmarks).
LAP_COLUMNS: dict[str, tuple[str, str]] = {
    "lap": ("-", "lap number, from 1"),
    "with_landmarks_per_lap_m": ("m", ("with landmarks: distance between consecutive true lap end points (seed 004 "
                                 "Tables I-II; the route start before lap 1)")),
    "with_landmarks_from_start_m": ("m", "with landmarks: distance of the true lap end point from the route start"),
    "without_landmarks_per_lap_m": ("m", "without landmarks (dead reckoning): error per lap, as above"),
    "without_landmarks_from_start_m": ("m", "without landmarks: distance of the lap end from the route start"),
}


def _column_table(columns: dict[str, tuple[str, str]]) -> list[str]:
    lines = ["| column | unit | meaning |", "| --- | --- | --- |"]
    lines += [f"| `{name}` | {unit} | {meaning} |" for name, (unit, meaning) in columns.items()]
    return lines


def outputs_reference() -> list[str]:
    """Markdown lines: the files a run writes and every column of its CSVs."""
    return [
        "## Outputs of `agvnav simulate --out DIR`",
        "",
        (
            "- `metrics.json`: outcome (`completed` or `failed` with a reason: `collision`, `jackknife`, "
            "`infeasible`, `positioning_lost`, `timeout`, `off_path_at_end`), the run's figures (SI units), "
            "the transient definition and an `integrity` section (time and distance per estimator status, "
            "stops for positioning against the braking distance, quality and reflectors-used percentiles, "
            "readings dropped (`n_dropped`), NEES, longest silent "
            "failure, largest true lateral error); with reactive control (issue 18) a `reactive` section: "
            "`stops`, `time_stopped_s`, `detours`, `max_corridor_excess_m` (null without a corridor) and per "
            "obstacle id its `min_clearance_m` and encounter `result` (`collision`, `avoid`, `stop`, `slow` or "
            "`none`); an `events` section with what happened when (s), only the kinds that did: `faults` "
            "(`kind`, `start_s`, `end_s`), `estimator` (windows not tracking, with `status`), "
            "`positioning_guard` (`windows` slowed or stopped, `stops`, `time_slow_s`, `time_stop_s`, "
            "`max_lateral_3sigma_m` while a fault is active and the limits `lateral_3sigma_slow_m`, "
            "`lateral_3sigma_stop_m`), `reactive` (windows of `level` slow or stop with their `trigger`), "
            "`detours`, `station_stops` (`station`, `t_s`, `stop_error_m`, `stop_heading_error_rad`); "
            "identical bytes for the same scenario and seed. Heading figures fit the vehicle: "
            "`max_abs_wheel_heading_error_rad` (seed 000's xi_r) for a steered vehicle, null otherwise; "
            "`max_abs_heading_error_rad` (body heading against the path's reference heading, read from "
            "1 m past each of `heading_reorientations` steps of it, e.g. a holonomic yaw offset changing). "
            "A mission's `max_abs_lateral_error_m` is the largest of its `max_lateral_m.<edge kind>` (both "
            "over the samples where the vehicle moves);"
        ),
        "- `timing.json`: wall time (s) and real-time factor (the only file that differs between equal runs);",
        "- `timeseries.csv`: one row per control step, the columns below (a vehicle writes the ones it has);",
        "- `reflections.csv`: one row per goniometer reflection;",
        (
            "- `map.png` (with obstacles' tracks and where the vehicle stopped), `errors.png` (errors named for "
            "the vehicle, then the commanded speed over the windows of faults, dead reckoning, guard and field "
            "slow/stop and station stops, and the clearance to each obstacle), `positioning_histogram.png`: "
            "the plots;"
        ),
        (
            "- `layout.json`: the planned path (`path_xy`, m), its segment joins (`segment_starts_m`), the "
            "reflectors (`[x, y, radius]`, m) and walls (m), and the positioning method: what the report draws;"
        ),
        "- `report.html` (with `--report`, or `agvnav report DIR` later): one self-contained HTML report;",
        (
            "- `NAME.units.csv` beside every `NAME.csv`: one row per column of that file (`column,unit,meaning`), "
            "so the units travel with the data; the CSV headers keep the plain names below."
        ),
        "",
        (
            "A route scenario (the seed-004 tracked robot, `route:`) writes instead `metrics.json` and `laps.json` "
            "(per mode: mean, maximum and final error per lap in m, laps, simulated and wall time, the automaton's "
            "transitions), `laps.csv` (columns below), `timeseries_with_landmarks.csv` and "
            "`timeseries_without_landmarks.csv` (time-series columns as above) and `laps.png`."
        ),
        "",
        ("`agvnav simulate --json` prints metrics.json and timing.json as one JSON document on stdout, with a "
        "`metadata` record (agvnav version, seed, Python, NumPy, CPU)."),
        "",
        "`--log run.mcap` also writes the run as an MCAP file of ROS 2 messages; docs/logs.md lists its topics.",
        "",
        (
            "The files appear all at once when the run ends (written to a temporary folder, then renamed). "
            "A DIR that holds another run (a metrics.json) is refused unless `--force`, which replaces it "
            "whole; a non-empty DIR without a metrics.json is never replaced."
        ),
        "",
        "### timeseries.csv",
        "",
        *_column_table(COLUMNS),
        "",
        "### reflections.csv",
        "",
        *_column_table(EVENT_COLUMNS),
        "",
        "### laps.csv (route scenarios)",
        "",
        *_column_table(LAP_COLUMNS),
    ]


#: The seed-004 hybrid automaton's ``controller.params`` (:class:`agvnav.guidance.hybrid.HybridParams`):
#: field -> (scenario key, unit, meaning). A field in radians is written in degrees (``_deg``, ``_deg_s``).
HYBRID_PARAMETERS: dict[str, tuple[str, str, str]] = {
    "cruise_speed": ("cruise_speed", "m/s", "speed along the legs (seed 004)"),
    "correction_rate": ("correction_rate_deg_s", "deg/s", "turn rate of a heading correction (seed 004)"),
    "turn_rate": ("turn_rate_deg_s", "deg/s", "turn rate at a corner (seed 004)"),
    "min_turn_rate": ("min_turn_rate_deg_s", "deg/s", "smallest turn rate near the end of a turn"),
    "turn_gain": ("turn_gain", "1/s", "turn rate per radian of heading still to turn (between the two rates)"),
    "turn_tolerance": ("turn_tolerance_deg", "deg", "a turn ends within this of its target heading"),
    "convergence_distance": ("convergence_distance", "m", "distance within which a lateral error is corrected"),
    "decel": ("decel", "m/s²", "deceleration towards the end of a leg"),
    "min_speed": ("min_speed", "m/s", "slowest speed while braking"),
    "detect_range": ("detect_range", "m", "a range reading counts only up to this range (seed 004: 0.60 m)"),
    "gate": ("gate", "m", "largest measured - predicted range for a side sensor to be associated with a wall"),
    "front_gate": ("front_gate", "m", "the same for the front sensor"),
    "end_margin": ("end_margin", "m", "a side pair must see the wall at least this far inside its ends"),
    "calibration_gain": ("calibration_gain", "-", "blend of each correction, in (0, 1] (1 replaces, as the seed)"),
    "pair_max_age": ("pair_max_age", "s", "the two readings of a side pair are at most this old"),
    "loss_timeout": ("loss_timeout", "s", "time without landmarks before they count as lost"),
    "dwell": ("dwell", "s", "wait before starting the next lap"),
    "lateral_calibration": ("lateral_calibration", "-", "also fix the distance to a side wall (an extension)"),
    "parallel_tolerance": ("parallel_tolerance_deg", "deg", "a wall within this angle of the heading is alongside"),
}


def _hybrid_default(field: str, value: object) -> str:
    unit = HYBRID_PARAMETERS[field][1]
    if unit.startswith("deg") and isinstance(value, float):
        return f"{math.degrees(value):.4g}"
    return repr(value)


def controllers_reference() -> list[str]:
    """Markdown lines: every controller by vehicle family with its parameters, units and defaults.

    Generated from the follower registry (:func:`agvnav.guidance.follower_parameters`: the
    constructors' signatures) and :class:`agvnav.guidance.hybrid.HybridParams`, so it cannot go stale.
    """
    from agvnav.guidance import FOLLOWERS, follower_parameters  # noqa: PLC0415 (deferred: see reference_markdown)
    from agvnav.guidance.hybrid import HybridParams  # noqa: PLC0415

    lines = [
        "## Controllers (`controller`)",
        "",
        "`controller.name` picks the path follower; which names fit which vehicle family (the first is",
        "the family's default): steered (tricycle, tricycle_rear, ackermann, tractor_trailer), unicycle",
        "(differential), holonomic (mecanum); tracked vehicles drive the seed-004 `hybrid` automaton.",
        "A follower's parameters go under `controller.params` (e.g. `params: {lookahead: 1.5}`), except",
        "`point`, `poles_per_m` and `gains`, which are `controller.point`, `controller.poles_per_m` and",
        "`controller.gains`. A parameter the follower does not take is refused, naming the ones it does.",
        "Defaults \"none\" are designed by the follower (see the meaning). Units here are the follower's",
        "own (SI, radians).",
    ]
    for family, names in FOLLOWERS.items():
        for name in names:
            lines += ["", f"### `{name}` ({family})", "", "| parameter | unit | default | meaning |",
                      "| --- | --- | --- | --- |"]
            for p in follower_parameters(name, family):
                cells = (f"`{p.name}`", p.unit, p.default, p.meaning)
                lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    lines += ["", "### `hybrid` (tracked, seed 004)", "",
              "`controller.laps`, `controller.landmarks` and `controller.compare_landmarks` (above), and under",
              "`controller.params` (angles in degrees, as the key says):", "",
              "| parameter | unit | default | meaning |", "| --- | --- | --- | --- |"]
    defaults = HybridParams()
    for field, (key, unit, meaning) in HYBRID_PARAMETERS.items():
        lines.append(f"| `{key}` | {unit} | {_hybrid_default(field, getattr(defaults, field))} | {meaning} |")
    return lines


def reference_markdown() -> str:
    """The whole of docs/scenarios.md.

    The schema references are imported here: the output columns above are read by every
    ``agvnav simulate``, which should not load the route and scenario schemas' documentation (issue 11).
    """
    from agvnav.routes.reference import network_reference  # noqa: PLC0415 (deferred: see the docstring)
    from agvnav.world.reference import scenario_reference  # noqa: PLC0415

    return scenario_reference([*controllers_reference(), "", *outputs_reference(), "", *network_reference()])


if __name__ == "__main__":  # pragma: no cover - the documented regeneration command
    print(reference_markdown(), end="")
