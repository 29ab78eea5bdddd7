"""A solved map as a reflector map YAML (``agvnav simulate``/``agvnav localize`` load it) and a summary.

Each reflector carries its 2x2 covariance in the site frame (``covariance_m2``, m²: the marginal block of
the joint covariance, the anchor's and the trajectory's errors included) and ``survey_std_m``, the std per
axis the positioning estimators read as the reflector's own survey error (the EKF's consider filter,
issue 12, takes each reflector's error as independent of the others'). The two differ: most of a mapped
reflector's marginal variance is the frame's (the anchor's translation, rotation and scale, shared by every
reflector), and a shared error moves the vehicle's estimate with the map, rigidly: no filter can average it
out, and given to the consider filter as independent per-reflector errors it only deweights the bearings.
``survey_std_m`` is therefore ``sqrt(tr(C_j) / 2)`` of the frame-free covariance, the joint covariance
S-transformed to the inner-constraint datum of a similarity over all mapped reflectors
(:func:`frame_free_covariance`, Baarda's S-transformation); the frame's own std (:func:`frame_std`) is
stated in the map's header and :func:`map_summary`. Hall, seed 1, EKF replay against the exact map
(told it is exact): baseline map 1.47 mm RMS with the frame-free std (ratio 1.005) and 1.79 mm with the
marginal one (1.22; its far reflectors 3.5 mm from the head's yaw calibration, a frame rotation, against
0.1-0.4 mm real errors). Walls are copied from a given map (the mapping drive does not see walls).
"""

from __future__ import annotations

import math
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from agvnav.mapping.slam import MappingResult
from agvnav.world import Reflector, WorldMap, save_map

__all__ = [
    "MAP_HEADER", "MapFileError", "check_map_file", "frame_free_covariance", "frame_std", "is_agvnav_map",
    "map_summary", "result_to_map", "write_map",
]


#: Degrees of freedom of the map's frame removed by :func:`frame_free_covariance`: translation (2),
#: rotation and scale (bearings carry no scale: a uniformly scaled map gives the same bearings from a scaled
#: pose, and the odometry's disagreement, ~1e-4 relative, is far below its noise).
FRAME_DOF = 4


def _frame_basis(xy: np.ndarray) -> np.ndarray:
    """``(2N, 4)`` the map's similarity motions at the centroid: x and y shift, rotation, scale."""
    c = xy - xy.mean(axis=0)
    n = xy.shape[0]
    G = np.zeros((2 * n, FRAME_DOF))
    G[0::2, 0] = 1.0
    G[1::2, 1] = 1.0
    G[0::2, 2], G[1::2, 2] = -c[:, 1], c[:, 0]
    G[0::2, 3], G[1::2, 3] = c[:, 0], c[:, 1]
    return G


def frame_free_covariance(xy: np.ndarray, joint: np.ndarray) -> np.ndarray:
    """The joint covariance ``(2N, 2N)`` (m²) of the reflector centres ``xy (N, 2)`` (m) free of the frame.

    Baarda's S-transformation to the inner-constraint (minimum-trace) datum: ``S C Sᵀ`` with
    ``S = I - G (GᵀG)⁻¹ Gᵀ``, ``G`` the similarity motions (shift, rotation, scale) of all reflectors about
    their centroid [Baarda 1973, S-transformations and criterion matrices]: what remains is the error of
    the reflectors relative to each other. With fewer than three reflectors the frame takes every degree of
    freedom: the covariance is returned unchanged. ValueError on mismatched shapes.
    """
    xy = np.asarray(xy, dtype=np.float64)
    C = np.asarray(joint, dtype=np.float64)
    if xy.ndim != 2 or xy.shape[1] != 2 or C.shape != (2 * xy.shape[0], 2 * xy.shape[0]):
        raise ValueError(f"need xy (N, 2) and a (2N, 2N) joint covariance, got {xy.shape} and {C.shape}")
    if xy.shape[0] < 3:
        return C.copy()
    G = _frame_basis(xy)
    S = np.eye(C.shape[0]) - G @ np.linalg.solve(G.T @ G, G.T)
    out = S @ C @ S.T
    return 0.5 * (out + out.T)


def frame_std(xy: np.ndarray, joint: np.ndarray) -> dict[str, float]:
    """The std of the map's frame (its similarity at the reflectors' centroid) from the joint covariance:
    ``shift_m`` (per axis, m), ``rotation_rad`` and ``scale`` (relative): ``(GᵀG)⁻¹ Gᵀ C G (GᵀG)⁻¹``."""
    xy = np.asarray(xy, dtype=np.float64)
    if xy.shape[0] < 3:
        return {"shift_m": float("nan"), "rotation_rad": float("nan"), "scale": float("nan")}
    G = _frame_basis(xy)
    P = np.linalg.solve(G.T @ G, G.T)
    F = P @ np.asarray(joint, dtype=np.float64) @ P.T
    v = np.sqrt(np.maximum(np.diag(F), 0.0))
    return {"shift_m": float(math.sqrt(0.5 * (v[0] ** 2 + v[1] ** 2))), "rotation_rad": float(v[2]),
            "scale": float(v[3])}


def result_to_map(result: MappingResult, radius: float = 0.04, walls_from: WorldMap | None = None) -> WorldMap:
    """The mapped reflectors as a :class:`WorldMap` (radius ``radius`` m, walls of ``walls_from``):
    ``covariance_m2`` the marginal covariance, ``survey_std_m`` the frame-free std (module docstring)."""
    joint = result.joint_covariance
    free = frame_free_covariance(result.xy, joint) if joint is not None else None
    refl = []
    for j, (rid, xy, cov) in enumerate(zip(result.ids, result.xy, result.covariance, strict=True)):
        c = 0.5 * (cov + cov.T)
        own = c if free is None else free[2 * j:2 * j + 2, 2 * j:2 * j + 2]
        std = math.sqrt(max(0.5 * float(np.trace(own)), 0.0))
        refl.append(Reflector(rid, float(xy[0]), float(xy[1]), radius, std,
                              ((float(c[0, 0]), float(c[0, 1])), (float(c[0, 1]), float(c[1, 1])))))
    return WorldMap(tuple(refl), walls_from.walls if walls_from is not None else ())


#: How every map :func:`write_map` writes begins: agvnav recognises its own map files by this first line.
MAP_HEADER = "# agvnav map:"


class MapFileError(ValueError):
    """The map file to write exists and may not be replaced (or is not a file)."""


def is_agvnav_map(path: str | Path) -> bool:
    """True when ``path`` is a file whose first line starts with :data:`MAP_HEADER` (a map :func:`write_map` wrote)."""
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            return fh.readline().startswith(MAP_HEADER)
    except OSError:
        return False


def check_map_file(path: str | Path, force: bool = False, option: str = "--out") -> None:
    """Refuse to write the map to ``path`` when it exists, unless ``force``; say whose file it is.

    Absent: fine. A folder, or a missing parent folder: always refused. A map agvnav wrote (first line
    :data:`MAP_HEADER`):
    refused unless ``force`` ("holds a map agvnav wrote"). Any other file (a surveyed map, a
    hand-made one): refused unless ``force`` too, with a message saying it is not agvnav's.
    Raises :class:`MapFileError` (a ValueError) naming ``option`` and the file.
    """
    p = Path(path)
    if not p.parent.is_dir():  # found before the work, not as a bare OSError on the temporary file after it
        raise MapFileError(f"{option} {p}: the folder {p.parent} does not exist")
    if not p.exists():
        return
    if p.is_dir():
        raise MapFileError(f"{option} {p}: it is a folder, not a map file")
    if force:
        return
    if is_agvnav_map(p):
        raise MapFileError(f"{option} {p}: the file holds a map agvnav wrote earlier; use --force to replace it")
    raise MapFileError(f"{option} {p}: the file exists and is not a map agvnav wrote (its first line is not "
                       f"'{MAP_HEADER}'); choose another file, or use --force to overwrite it")


def write_map(result: MappingResult, path: str | Path, radius: float = 0.04,
              walls_from: WorldMap | None = None, force: bool = False) -> WorldMap:
    """Write the map YAML (a header comment states the anchor) and return the map.

    The file begins with :data:`MAP_HEADER` (how agvnav recognises its own maps); an existing file is
    refused unless ``force`` (:func:`check_map_file`). Atomic: the map is written to a temporary file
    beside ``path`` and renamed over it, so ``path`` is the old file or the whole new one, never a part.
    """
    world = result_to_map(result, radius, walls_from)
    p = Path(path)
    check_map_file(p, force)
    head = (f"{MAP_HEADER} {len(result.ids)} reflectors from a mapping drive; frame and scale anchored by "
            f"{result.anchor}; odometry scale {result.scale:.5f} +- {result.scale_std:.5f}\n"
            "# covariance_m2: 2x2 covariance of each centre in the site frame (m^2); survey_std_m: std per axis of "
            "its error relative to the other reflectors (frame-free)\n")
    if result.joint_covariance is not None and len(result.ids) >= 3:
        f = frame_std(result.xy, result.joint_covariance)
        head += (f"# frame std (shared by all reflectors): shift {f['shift_m'] * 1000:.2f} mm per axis, rotation "
                 f"{math.degrees(f['rotation_rad']):.4f} deg, scale {f['scale'] * 1e6:.1f} ppm\n")
    fd, name = tempfile.mkstemp(prefix=f".{p.name}.partial-", suffix=".yaml", dir=p.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        save_map(world, tmp)
        tmp.write_text(head + tmp.read_text(encoding="utf-8"), encoding="utf-8")
        os.replace(tmp, p)
    finally:
        tmp.unlink(missing_ok=True)
    return world


def map_summary(result: MappingResult) -> dict[str, Any]:
    """JSON-ready figures of a solved map (SI units)."""
    stds = [math.sqrt(max(float(np.linalg.eigvalsh(c).max()), 0.0)) for c in result.covariance]
    frame = frame_std(result.xy, result.joint_covariance) if result.joint_covariance is not None else None
    return {
        "anchor": result.anchor,
        "reflectors": len(result.ids),
        "new_reflectors": len([i for i in result.ids if i not in result.existing_ids]),
        "reflections": result.reflections,
        "associated": result.associated,
        "odometry_scale": result.scale,
        "odometry_scale_std": result.scale_std,
        "odometry_heading_rate_rad_m": result.heading_rate,
        "odometry_turn_scale": result.turn_scale,
        "odometry_noise": list(result.odometry_noise) if result.odometry_noise is not None else None,
        "max_std_m": max(stds) if stds else None,
        "frame_std": None if frame is None or not math.isfinite(frame["shift_m"]) else frame,
        "chi2_per_dof": result.chi2_per_dof,
        "runtime_s": result.runtime_s,
    }
