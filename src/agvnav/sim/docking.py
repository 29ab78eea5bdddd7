"""A docking scenario wired into the closed loop (issue 32), and its judgement on the truth.

:func:`agvnav.sim.build.build_docking` reads the map's docking target (:mod:`agvnav.world.docking`, located
errors), checks it against the vehicle and the goniometer, places the station as it really
stands (the scenario's ``docking.truth``: offset from its map pose, missing or moved
reflectors, clutter, a person), draws the straight approach relative to the map's station
and wires the :class:`~agvnav.navigation.docking.DockingAutopilot` with the global EKF and the
station estimator side by side. :func:`docking_figures` judges the end on the true pose
relative to the true station.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path as FsPath

import numpy as np
from numpy.typing import NDArray

from agvnav.geometry import se2, wrap_angle_scalar
from agvnav.guidance import LineSegment, Path
from agvnav.navigation.docking import DockingAutopilot
from agvnav.odometry import OdometryNoise, wheel_pair_noise
from agvnav.positioning.station import to_station
from agvnav.roles import BearingEstimator, Sensor
from agvnav.routes.network import RouteNetwork
from agvnav.sensors.goniometer import Goniometer
from agvnav.sim.reactive import OccludedReflections
from agvnav.sim.roles import GoniometerSensor
from agvnav.world import WorldMap, builtin_map, builtin_map_names
from agvnav.world.docking import DockingTarget, approach_start, check_target, load_docking_targets
from agvnav.world.map import Reflector, Wall
from agvnav.world.obstacles import Obstacle, ObstacleSet
from agvnav.world.scenario import Scenario
from agvnav.world.vehicle_specs import SteeredVehicleSpec, WheeledVehicleSpec

__all__ = [
    "PERSON_SIDE_M", "DockingNode", "approach_path", "compose", "docking_figures", "docking_node", "goniometer_role",
    "station_noise",
    "true_station", "true_world", "turn_radius", "walking_person",
]

#: Side of the square a standing person occupies (m).
PERSON_SIDE_M = 0.4


def compose(a: tuple[float, float, float] | NDArray[np.float64],
            b_: tuple[float, float, float] | NDArray[np.float64]) -> tuple[float, float, float]:
    """SE(2) ``a b`` of two poses (m, m, rad)."""
    x, y, psi = se2.compose(np.asarray(a, dtype=np.float64), np.asarray(b_, dtype=np.float64))
    return float(x), float(y), float(psi)


def _map_file(sc: Scenario) -> FsPath:
    spec = sc.map
    if isinstance(spec, dict):
        raise sc.error(("map",), "a docking reads its target from a map file: give a map name or file")
    if spec in builtin_map_names():
        return builtin_map(spec)
    p = FsPath(spec)
    return sc.base_dir / p if not p.is_absolute() and sc.base_dir is not None else p


def turn_radius(sc: Scenario) -> float:
    """The vehicle's smallest turning radius of point O (m): ``L / tan(gamma_max)`` [seed000 eq8]; 0 if it turns
    on the spot (a vehicle that is not steered, or a steering limit of 90 deg)."""
    v = sc.vehicle
    if not isinstance(v, SteeredVehicleSpec):
        return 0.0
    gmax = math.radians(v.steering.max_angle_deg)
    return 0.0 if gmax >= 0.5 * math.pi - 1e-9 else float(v.wheelbase_m) / math.tan(gmax)


def load_target(sc: Scenario) -> DockingTarget:
    """The scenario's docking target, checked for its vehicle and goniometer (errors name file, line, key)."""
    assert sc.docking is not None
    if sc.goniometer is None:
        raise sc.error(("docking",), "docking recognises its target with the goniometer: mount one")
    doc = load_docking_targets(_map_file(sc))
    ids = [t.id for t in doc.docking_targets]
    if sc.docking.target not in ids:
        raise sc.error(("docking", "target"), f"no docking target {sc.docking.target!r} in the map (has {ids})")
    return check_target(doc, ids.index(sc.docking.target), sc.goniometer.pulses_per_rev, turn_radius(sc))


def station_noise(sc: Scenario, noise: OdometryNoise) -> OdometryNoise:
    """The station estimator's odometry model: the global one's, completed for two driven wheels.

    A vehicle on two driven wheels (differential, tractor) fine-positions with turns on the spot,
    where Crowley's form [seed002 eq17] puts the translation variance at zero while the wheels'
    slips shift the base: :func:`agvnav.odometry.wheel_pair_noise` on the vehicle's track (issue 32,
    the false alarm of the consistency test after a spot turn). Other vehicles keep ``noise``.
    """
    if isinstance(sc.vehicle, WheeledVehicleSpec):
        return wheel_pair_noise(noise, float(sc.vehicle.track_m))
    return noise


def true_station(sc: Scenario, target: DockingTarget) -> tuple[float, float, float]:
    """The station's true pose in ``map``: its map pose moved by ``docking.truth.station_offset``."""
    assert sc.docking is not None
    o = sc.docking.truth.station_offset
    return compose(target.station, (o[0] * 1e-3, o[1] * 1e-3, math.radians(o[2])))


def true_world(sc: Scenario, base: WorldMap, target: DockingTarget) -> WorldMap:
    """The world the goniometer sees: ``base`` (the surveyed map's truth) plus the target on the true
    station, its faults, clutter reflectors and a person (a closed wall) as ``docking.truth`` says."""
    assert sc.docking is not None
    truth = sc.docking.truth
    st = true_station(sc, target)
    for i, rid in enumerate([*truth.missing, *truth.moved]):
        if rid not in target.reflector_ids:
            key = ("docking", "truth", "missing" if i < len(truth.missing) else "moved")
            raise sc.error(key, f"no reflector {rid!r} in target {target.id!r} ({list(target.reflector_ids)})")
    refl = list(base.reflectors)
    for rid, (x, y) in zip(target.reflector_ids, target.reflector_xy, strict=True):
        if rid in truth.missing:
            continue
        dx, dy = truth.moved.get(rid, (0.0, 0.0))
        px, py, _ = compose(st, (float(x) + dx * 1e-3, float(y) + dy * 1e-3, 0.0))
        refl.append(Reflector(f"target:{rid}", px, py, target.radius))
    for k, (x, y) in enumerate(truth.clutter):
        px, py, _ = compose(st, (x, y, 0.0))
        refl.append(Reflector(f"clutter:{k}", px, py, target.radius))
    walls = list(base.walls)
    if truth.person is not None:
        h = 0.5 * PERSON_SIDE_M
        corners = [compose(st, (truth.person[0] + u, truth.person[1] + v, 0.0))[:2]
                   for u, v in ((-h, -h), (h, -h), (h, h), (-h, h))]
        walls.append(Wall("person", np.array(corners), closed=True))
    return dataclasses.replace(base, reflectors=tuple(refl), walls=tuple(walls))


def walking_person(sc: Scenario, target: DockingTarget) -> Obstacle | None:
    """``docking.truth.person_walking`` as a moving cylinder in ``map`` (its path carried from the true station's
    frame), or None."""
    assert sc.docking is not None
    walk = sc.docking.truth.person_walking
    if walk is None:
        return None
    st = true_station(sc, target)
    points = np.array([compose(st, (x, y, 0.0))[:2] for x, y in walk.path], dtype=np.float64)
    return Obstacle("person_walking", "cylinder", (walk.radius_m,), points, walk.speed_m_s, walk.start_s)


def goniometer_role(sc: Scenario, target: DockingTarget, goniometer: Goniometer, world: WorldMap,
                    estimate: BearingEstimator) -> Sensor:
    """The goniometer scanning the true ``world`` (:func:`true_world`) for ``estimate``; a reflection whose line
    of sight a walking person (:func:`walking_person`) cuts at its instant is dropped."""
    role = GoniometerSensor(goniometer, world, estimate)
    person = walking_person(sc, target)
    if person is None:
        return role
    assert sc.goniometer is not None
    g = sc.goniometer
    return OccludedReflections(role, ObstacleSet((person,)), world.reflector_xy,
                               (g.mount[0], g.mount[1], math.radians(g.mount[2])))


def approach_path(target: DockingTarget) -> Path:
    """The straight approach of the guided point, drawn relative to the map's station (``map`` frame)."""
    start = compose(target.station, approach_start(target))
    tangent = start[2] if target.direction > 0 else start[2] + math.pi
    return Path([LineSegment(np.array(start[:2]), tangent, target.approach, target.direction)])


def docking_figures(sc: Scenario, series: dict[str, NDArray[np.float64]], pilot: DockingAutopilot) -> dict[str, float]:
    """The docking judged on the truth: true error of the guided point against the docking pose on the
    true station (m, rad), the measured and true station offsets, the time to dock (s)."""
    target = pilot.target
    st = true_station(sc, target)
    rel = to_station(st, (series["x"][-1], series["y"][-1], series["psi"][-1]))
    d = target.docking_pose
    assert sc.docking is not None
    o = sc.docking.truth.station_offset
    return {
        "dock_error_m": float(math.hypot(rel[0] - d[0], rel[1] - d[1])),
        "dock_heading_error_rad": abs(wrap_angle_scalar(float(rel[2] - d[2]))),
        "dock_time_s": float(pilot.dock_time_s),
        "station_offset_measured_x_m": float(pilot.offset[0]),
        "station_offset_measured_y_m": float(pilot.offset[1]),
        "station_offset_measured_psi_rad": float(pilot.offset[2]),
        "station_offset_true_m": float(math.hypot(o[0], o[1]) * 1e-3),
        "docking_reported_finished": float(pilot.phase == "finished"),
    }



@dataclasses.dataclass(frozen=True)
class DockingNode:
    """Where a route network docks at a target: the docking ``node``, the ``approach`` node, the approach ``edge``."""

    node: str
    approach: str
    edge: str


def docking_node(sc: Scenario, network: RouteNetwork, target: DockingTarget) -> DockingNode:
    """The docking node of ``target`` in ``network`` (module doc); ScenarioError naming the file, line and key.

    The node named as the target must stand at the docking pose as the map places the station (within the
    network's ``gap_m``; its ``heading_deg``, if given, within ``heading_deg``), and exactly one straight edge
    must lead into it from a node at the approach start: the docking drives that edge.
    """
    spec = network.spec
    if target.id not in network.nodes:
        raise sc.error(("docking", "target"), f"no node {target.id!r} in route network {network.name!r} "
                       f"({spec.source}): the docking node is the network node named as the target")
    i = [n.id for n in spec.nodes].index(target.id)
    tol = spec.tolerances
    node = network.nodes[target.id]
    dock = compose(target.station, target.docking_pose)
    off = math.hypot(node.x - dock[0], node.y - dock[1])
    if off > tol.gap_m:
        raise spec.error(("nodes", i), f"docking node {target.id!r} is {off * 1e3:.1f} mm from the docking pose "
                         f"({dock[0]:.4f}, {dock[1]:.4f}) m of target {target.id!r} as the map places the station "
                         f"(gap tolerance {tol.gap_m * 1e3:g} mm)")
    if node.heading is not None and abs(wrap_angle_scalar(node.heading - dock[2])) > math.radians(tol.heading_deg):
        raise spec.error(("nodes", i, "heading_deg"), f"docking node {target.id!r}: heading "
                         f"{math.degrees(node.heading):.2f} deg, the docking pose's is {math.degrees(dock[2]):.2f} deg")
    start = compose(target.station, approach_start(target))
    into = [e for e in network.edges.values() if e.target == target.id and e.curve.kind == "line"
            and math.hypot(network.nodes[e.source].x - start[0], network.nodes[e.source].y - start[1]) <= tol.gap_m]
    if not into:
        raise spec.error(("nodes", i, "id"), f"no straight edge into docking node {target.id!r} from a node at its "
                         f"approach start ({start[0]:.4f}, {start[1]:.4f}) m, {target.approach:g} m out: the "
                         "docking drives that edge")
    if len(into) > 1:
        raise spec.error(into[1].key, f"docking node {target.id!r} has two approach edges ({into[0].id!r}, "
                         f"{into[1].id!r}): ambiguous")
    return DockingNode(target.id, into[0].source, into[0].id)
