"""Read a recorded vehicle log: an MCAP file of ROS 2 messages or a folder of CSV files (docs/logs.md).

Both give a :class:`RecordedLog`: the odometry instants and increments, the
goniometer reflections (arrival, stamp, bearing), the positioning settings and,
when the log has them, the true and the recorded estimated poses and the path.

CSV layout (a folder):

- ``odometry.csv``: header ``t,delta_d,delta_theta[,delta_lateral]``; the first row
  is the start (its increments ignored), each next row the increment measured since
  the previous row (s, m, rad, m). A differential vehicle may log its encoder counts
  instead, ``t,counts_right,counts_left`` (cumulative counts), with an ``encoders`` entry
  in settings.json (:func:`counts_to_increments`);
- ``reflections.csv``: header ``t,bearing[,stamp]``: arrival time (s), bearing in the
  head frame (rad), the measurement instant (s, default the arrival); other
  columns (``reflector_index``) are ignored;
- ``settings.json`` (optional): the ``/agvnav/settings`` document (docs/logs.md);
- ``truth.csv`` (optional): ``t,x,y,psi`` true base_link poses (s, m, m, rad).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from numpy.typing import NDArray

from agvnav.logs import topics as tp
from agvnav.logs.messages import COV_INDEX, yaw_of
from agvnav.odometry import differential_increments

__all__ = ["RecordedLog", "counts_to_increments", "read_csv_log", "read_log", "read_mcap"]

F64 = NDArray[np.float64]


@dataclass
class RecordedLog:
    """A recorded drive: what an estimator needs, and what a report compares against.

    Attributes
    ----------
    t : (n,) odometry instants (s), increasing.
    increments : (n - 1, 3) body increments (m, rad, m) of the intervals ``(t[k], t[k+1]]``.
    reflection_t : (m,) arrival instants (s), non-decreasing.
    reflection_stamp : (m,) measurement instants delivered with each bearing (s).
    bearing : (m,) bearings in the head frame (rad).
    settings : the positioning settings document (may be empty).
    truth : (n, 3) true poses at ``t`` (m, m, rad), or None.
    estimate, covariance : the recorded estimate (n, 3) and covariance (n, 3, 3) at ``t``, or None.
    path_xy : (k, 2) planned path, or None.
    """

    t: F64
    increments: F64
    reflection_t: F64
    reflection_stamp: F64
    bearing: F64
    settings: dict[str, Any] = field(default_factory=dict)
    truth: F64 | None = None
    estimate: F64 | None = None
    covariance: F64 | None = None
    path_xy: F64 | None = None

    def __post_init__(self) -> None:
        n = self.t.shape[0]
        if n < 2:
            raise ValueError(f"a log needs at least two odometry instants, got {n}")
        if np.any(np.diff(self.t) <= 0):
            raise ValueError("odometry instants must increase strictly")
        if self.increments.shape != (n - 1, 3):
            raise ValueError(f"odometry increments must have shape ({n - 1}, 3), got {self.increments.shape}")
        m = self.reflection_t.shape[0]
        if self.bearing.shape != (m,) or self.reflection_stamp.shape != (m,):
            raise ValueError("reflections need one time, stamp and bearing each")
        if m and np.any(np.diff(self.reflection_t) < 0):
            raise ValueError("reflection arrival times must not decrease")
        if not (np.all(np.isfinite(self.increments)) and np.all(np.isfinite(self.bearing))):
            raise ValueError("odometry increments and bearings must be finite")


def read_log(path: str | Path) -> RecordedLog:
    """A ``.mcap`` file (:func:`read_mcap`) or a folder of CSV files (:func:`read_csv_log`)."""
    p = Path(path)
    if p.is_dir():
        return read_csv_log(p)
    if p.suffix == ".mcap" and p.is_file():
        return read_mcap(p)
    raise ValueError(f"{p}: a log is an .mcap file or a folder with odometry.csv and reflections.csv")


def _sec(stamp: Any) -> float:
    return (int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)) / 1e9


def _pose(p: Any) -> list[float]:
    return [float(p.position.x), float(p.position.y), yaw_of(p.orientation)]


def read_mcap(path: str | Path) -> RecordedLog:
    """Read an agvnav MCAP log (the topics of :mod:`agvnav.logs.topics`); ValueError names the file."""
    p = Path(path)
    wanted = [tp.ODOM, tp.BEARING, tp.SETTINGS, tp.TRUTH, tp.ESTIMATE, tp.PATH]
    got: dict[str, list[Any]] = {k: [] for k in wanted}
    try:
        with p.open("rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for _, channel, message, msg in reader.iter_decoded_messages(topics=wanted, log_time_order=True):
                got[channel.topic].append((message.log_time / 1e9, msg))
    except Exception as exc:  # the mcap library raises its own error types for a damaged file
        raise ValueError(f"{p}: not a readable MCAP log ({exc})") from None
    if not got[tp.ODOM]:
        raise ValueError(f"{p}: no {tp.ODOM} messages: the log has no odometry")
    t = np.array([_sec(msg.header.stamp) for _, msg in got[tp.ODOM]])
    rate = np.array([[msg.twist.twist.linear.x, msg.twist.twist.angular.z, msg.twist.twist.linear.y]
                     for _, msg in got[tp.ODOM]], dtype=np.float64)
    increments = rate[1:] * np.diff(t)[:, None]
    bear = got[tp.BEARING]
    settings = json.loads(got[tp.SETTINGS][0][1].data) if got[tp.SETTINGS] else {}
    return RecordedLog(
        t, increments,
        np.array([lt for lt, _ in bear]), np.array([_sec(msg.header.stamp) for _, msg in bear]),
        np.array([float(msg.vector.x) for _, msg in bear]), settings,
        truth=_poses(got[tp.TRUTH], lambda msg: msg.pose, t.shape[0]),
        estimate=_poses(got[tp.ESTIMATE], lambda msg: msg.pose.pose, t.shape[0]),
        covariance=_covariances(got[tp.ESTIMATE], t.shape[0]),
        path_xy=np.array([_pose(ps.pose)[:2] for ps in got[tp.PATH][0][1].poses]) if got[tp.PATH] else None,
    )


def _poses(items: list[Any], get: Any, n: int) -> F64 | None:
    if len(items) != n:
        return None
    return np.array([_pose(get(msg)) for _, msg in items])


def _covariances(items: list[Any], n: int) -> F64 | None:
    if len(items) != n:
        return None
    idx = np.ix_(COV_INDEX, COV_INDEX)
    return np.array([np.asarray(msg.pose.covariance, dtype=np.float64).reshape(6, 6)[idx] for _, msg in items])


def _csv(path: Path, required: tuple[str, ...]) -> dict[str, F64]:
    try:
        with path.open(encoding="utf-8") as f:
            names = [c.strip() for c in f.readline().strip().split(",")]
            data = np.loadtxt(f, delimiter=",", ndmin=2, dtype=np.float64)
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ValueError(f"{path}: cannot read the CSV ({exc})") from None
    missing = [c for c in required if c not in names]
    if missing:
        raise ValueError(f"{path}: missing column(s) {missing}; the header must name {list(required)}")
    if data.size == 0:
        data = np.zeros((0, len(names)))
    if data.shape[1] != len(names):
        raise ValueError(f"{path}: {data.shape[1]} values per row but {len(names)} column names")
    return {c: data[:, i] for i, c in enumerate(names)}


def counts_to_increments(right: F64, left: F64, encoders: dict[str, Any]) -> F64:
    """``(n - 1, 3)`` body increments of a differential vehicle from cumulative encoder counts ``(n,)``.

    ``encoders``: ``metres_per_count_right``, ``metres_per_count_left`` (m), ``track_m`` (m) and
    optionally ``counter_bits``: a counter that wraps modulo ``2**bits`` is unwrapped (each
    difference taken into ``[-2**(bits-1), 2**(bits-1))``). Wheel distances to ``(ΔD, Δθ)`` by
    [seed002 eq16] (:func:`agvnav.odometry.differential_increments`); ``delta_lateral`` is 0.
    """
    try:
        k_r, k_l = float(encoders["metres_per_count_right"]), float(encoders["metres_per_count_left"])
        track = float(encoders["track_m"])
    except (KeyError, TypeError) as exc:
        raise ValueError(f"encoders needs metres_per_count_right, metres_per_count_left and track_m ({exc})") from None
    dr, dl = np.diff(np.asarray(right, dtype=np.float64)), np.diff(np.asarray(left, dtype=np.float64))
    bits = encoders.get("counter_bits")
    if bits is not None:
        span = float(2 ** int(bits))
        dr, dl = (np.mod(x + span / 2, span) - span / 2 for x in (dr, dl))
    dd, dth = differential_increments(k_r * dr, k_l * dl, track)
    return np.column_stack([dd, dth, np.zeros_like(dd)])


def read_csv_log(folder: str | Path) -> RecordedLog:
    """Read the CSV layout of the module docstring from ``folder``."""
    d = Path(folder)
    settings_file = d / "settings.json"
    settings = json.loads(settings_file.read_text(encoding="utf-8")) if settings_file.is_file() else {}
    counts = _csv(d / "odometry.csv", ("t",))
    if "counts_right" in counts and "delta_d" not in counts:
        odo = _csv(d / "odometry.csv", ("t", "counts_right", "counts_left"))
        if "encoders" not in settings:
            raise ValueError(f"{d / 'odometry.csv'}: encoder counts need an 'encoders' entry in settings.json")
        inc = counts_to_increments(odo["counts_right"], odo["counts_left"], settings["encoders"])
    else:
        odo = _csv(d / "odometry.csv", ("t", "delta_d", "delta_theta"))
        n = odo["t"].shape[0]
        inc = np.column_stack([odo["delta_d"], odo["delta_theta"], odo.get("delta_lateral", np.zeros(n))])[1:]
    refl = _csv(d / "reflections.csv", ("t", "bearing"))
    truth = None
    if (d / "truth.csv").is_file():
        tr = _csv(d / "truth.csv", ("t", "x", "y", "psi"))
        truth = np.column_stack([np.interp(odo["t"], tr["t"], tr[c]) for c in ("x", "y")] +
                                [np.interp(odo["t"], tr["t"], np.unwrap(tr["psi"]))])
    return RecordedLog(odo["t"], inc, refl["t"], refl.get("stamp", refl["t"]), refl["bearing"], settings, truth=truth)
