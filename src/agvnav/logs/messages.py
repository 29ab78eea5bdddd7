"""ROS 2 messages of a planar vehicle as plain dicts (the form the MCAP ROS 2 encoder takes).

Planar poses: z = 0, orientation the unit quaternion of a rotation by ``psi`` about z
(REP-103: x forward, y left, z up, counter-clockwise positive).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "COV_INDEX",
    "covariance6",
    "header",
    "planar_pose",
    "quaternion_yaw",
    "stamp",
    "stamp_ns",
    "transform",
    "vector3",
    "yaw_of",
]

Msg = dict[str, Any]

#: (row, col) of the planar covariance (x, y, psi) in a ROS 6x6 (x, y, z, roll, pitch, yaw).
COV_INDEX = (0, 1, 5)


def stamp_ns(t: float) -> int:
    """Nanoseconds of ``t`` s (nearest)."""
    if not math.isfinite(t) or t < 0:
        raise ValueError(f"a log time must be a finite non-negative number of seconds, got {t!r}")
    return round(t * 1e9)


def stamp(t: float) -> Msg:
    """builtin_interfaces/Time of ``t`` s."""
    ns = stamp_ns(t)
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def header(t: float, frame: str) -> Msg:
    """std_msgs/Header at ``t`` s in ``frame``."""
    return {"stamp": stamp(t), "frame_id": frame}


def quaternion_yaw(psi: float) -> Msg:
    """geometry_msgs/Quaternion of a rotation by ``psi`` rad about z."""
    return {"x": 0.0, "y": 0.0, "z": math.sin(0.5 * psi), "w": math.cos(0.5 * psi)}


def yaw_of(q: Any) -> float:
    """Yaw (rad, in (-pi, pi]) of a quaternion with fields x, y, z, w (a rotation about z)."""
    return 2.0 * math.atan2(float(q.z), float(q.w)) if abs(float(q.z)) + abs(float(q.w)) > 0 else 0.0


def vector3(x: float, y: float = 0.0, z: float = 0.0) -> Msg:
    """geometry_msgs/Vector3 (or Point)."""
    return {"x": float(x), "y": float(y), "z": float(z)}


def planar_pose(x: float, y: float, psi: float) -> Msg:
    """geometry_msgs/Pose of a planar pose (m, m, rad)."""
    return {"position": vector3(x, y), "orientation": quaternion_yaw(float(psi))}


def transform(t: float, parent: str, child: str, pose: Sequence[float]) -> Msg:
    """geometry_msgs/TransformStamped: ``child`` in ``parent`` at ``t`` s, planar ``pose`` (m, m, rad)."""
    return {
        "header": header(t, parent),
        "child_frame_id": child,
        "transform": {"translation": vector3(pose[0], pose[1]), "rotation": quaternion_yaw(float(pose[2]))},
    }


def covariance6(cov3: ArrayLike) -> list[float]:
    """The 36 row-major values of a ROS pose covariance from a planar ``(3, 3)`` (x, y, psi) covariance."""
    c = np.asarray(cov3, dtype=np.float64)
    if c.shape != (3, 3):
        raise ValueError(f"a planar covariance must have shape (3, 3), got {c.shape}")
    out = np.zeros((6, 6))
    out[np.ix_(COV_INDEX, COV_INDEX)] = c
    return [float(v) for v in out.ravel()]
