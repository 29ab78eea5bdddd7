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
- ``reflections.csv``: header ``t,bearing[,stamp][,reflector_index]``: arrival time (s),
  bearing in the head frame (rad), the measurement instant (s, default the arrival), and
  the reflector a simulation saw (ignored); at least one reflection;
- ``settings.json`` (optional): the ``/agvnav/settings`` document (docs/logs.md,
  :mod:`agvnav.logs.settings`);
- ``truth.csv`` (optional): ``t,x,y,psi`` true base_link poses (s, m, m, rad).

A file-format key the reader does not know is refused, as a scenario key is: a CSV column
(file, line 1 and column named) or a settings key (:func:`agvnav.logs.settings.check_settings`).
A bearing beyond 2π in magnitude can only be degrees and is refused (file and line named),
as is a log with no reflections. Reading an ``.mcap`` file needs the ``logs`` extra
(:class:`agvnav.logs.extra.MissingExtraError` otherwise); a CSV folder does not.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvnav.logs import topics as tp
from agvnav.logs.extra import require_logs_extra
from agvnav.logs.messages import COV_INDEX, yaw_of
from agvnav.logs.settings import ANGLE_LIMIT_RAD, check_settings
from agvnav.odometry import differential_increments

try:  # the logs extra: only an .mcap file needs it, a CSV folder is read without it
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
except ImportError as exc:
    _MCAP_MISSING: ImportError | None = exc
else:
    _MCAP_MISSING = None

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
        far = np.flatnonzero(np.abs(self.bearing) > ANGLE_LIMIT_RAD)
        if far.size:
            raise ValueError(f"bearing {self.bearing[far[0]]:g} (reflection {far[0]}) is beyond 2π in magnitude: "
                             f"bearings are radians ({far.size} of {m} look like degrees)")


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
    """Read an agvnav MCAP log (the topics of :mod:`agvnav.logs.topics`); ValueError names the file.

    Needs the ``logs`` extra: :class:`agvnav.logs.extra.MissingExtraError` (a ValueError naming it) without.
    """
    require_logs_extra(_MCAP_MISSING, "reading an MCAP log")
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
    if not bear:
        raise ValueError(f"{p}: no {tp.BEARING} messages: the log has no reflections to position with")
    bearing = np.array([float(msg.vector.x) for _, msg in bear])
    _check_bearings(bearing, f"{p}: {tp.BEARING} message ", np.arange(len(bear)))
    settings = _settings(got[tp.SETTINGS][0][1].data, f"{p} {tp.SETTINGS}") if got[tp.SETTINGS] else {}
    try:
        return RecordedLog(
            t, increments, np.array([lt for lt, _ in bear]), np.array([_sec(msg.header.stamp) for _, msg in bear]),
            bearing, settings,
            truth=_poses(got[tp.TRUTH], lambda msg: msg.pose, t.shape[0]),
            estimate=_poses(got[tp.ESTIMATE], lambda msg: msg.pose.pose, t.shape[0]),
            covariance=_covariances(got[tp.ESTIMATE], t.shape[0]),
            path_xy=np.array([_pose(ps.pose)[:2] for ps in got[tp.PATH][0][1].poses]) if got[tp.PATH] else None,
        )
    except ValueError as exc:
        raise ValueError(f"{p}: {exc}") from None


def _settings(text: str, source: str) -> dict[str, Any]:
    """The settings document in JSON ``text``, checked (:func:`agvnav.logs.settings.check_settings`)."""
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{source}:{exc.lineno}: invalid JSON: {exc.msg}") from None
    return check_settings(doc, source, text)


def _check_bearings(bearing: F64, where: str, index: NDArray[np.int64]) -> None:
    """Refuse bearings beyond 2π in magnitude: they can only be degrees. ``where`` + ``index[i]`` locates one."""
    far = np.flatnonzero(np.abs(bearing) > ANGLE_LIMIT_RAD)
    if far.size:
        raise ValueError(f"{where}{index[far[0]]}: bearing {bearing[far[0]]:g} is beyond 2π in magnitude: bearings "
                         f"are radians ({far.size} of {bearing.size} look like degrees)")


def _poses(items: list[Any], get: Any, n: int) -> F64 | None:
    if len(items) != n:
        return None
    return np.array([_pose(get(msg)) for _, msg in items])


def _covariances(items: list[Any], n: int) -> F64 | None:
    if len(items) != n:
        return None
    idx = np.ix_(COV_INDEX, COV_INDEX)
    return np.array([np.asarray(msg.pose.covariance, dtype=np.float64).reshape(6, 6)[idx] for _, msg in items])


def _csv(
    path: Path, required: tuple[str, ...], allowed: tuple[str, ...] = (), strictly_increasing: bool = True
) -> tuple[dict[str, F64], NDArray[np.int64]]:
    """The columns of CSV file ``path`` (a header line, then numbers) and the file line (1-based) of each row.

    Every column must be one of ``required`` and ``allowed``: an unknown column (``bearing_deg``) is refused
    naming the file, line 1 and the column, as a scenario key is. Blank lines and ``#`` comments are skipped.
    Every value must be finite (``nan``, ``inf`` refused) and the ``t`` column must increase (strictly, or
    only not decrease when ``strictly_increasing`` is False: reflections share an instant), each refused
    naming the file, the line and the column.
    """
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: cannot read the CSV ({exc})") from None
    names = [c.strip() for c in lines[0].split(",")] if lines else []
    unknown = [c for c in names if c not in required + allowed]
    if unknown:
        optional = "".join(f"[,{c}]" for c in allowed)
        raise ValueError(f"{path}:1: unknown column {unknown[0]!r}; the header is {','.join(required)}{optional}")
    if len(set(names)) != len(names):
        raise ValueError(f"{path}:1: a column is named twice in {names}")
    missing = [c for c in required if c not in names]
    if missing:
        raise ValueError(f"{path}: missing column(s) {missing}; the header must name {list(required)}")
    rows = [(k, line) for k, line in enumerate(lines[1:], start=2)
            if line.strip() and not line.lstrip().startswith("#")]
    data = np.zeros((len(rows), len(names)))
    for i, (k, line) in enumerate(rows):
        values = line.split(",")
        if len(values) != len(names):
            raise ValueError(f"{path}:{k}: {len(values)} values but {len(names)} column names")
        try:
            data[i] = [float(v) for v in values]
        except ValueError as exc:
            raise ValueError(f"{path}:{k}: not a number ({exc})") from None
        bad = np.flatnonzero(~np.isfinite(data[i]))
        if bad.size:
            raise ValueError(f"{path}:{k}: {names[bad[0]]}: {values[bad[0]].strip()} is not a finite number")
    if "t" in names and len(rows) > 1:
        step = np.diff(data[:, names.index("t")])
        back = np.flatnonzero(step <= 0.0 if strictly_increasing else step < 0.0)
        if back.size:
            order = "increase strictly" if strictly_increasing else "not decrease"
            raise ValueError(f"{path}:{rows[back[0] + 1][0]}: t: {data[back[0] + 1, names.index('t')]:g} after "
                             f"{data[back[0], names.index('t')]:g}: the times must {order}")
    return {c: data[:, i] for i, c in enumerate(names)}, np.array([k for k, _ in rows], dtype=np.int64)


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


#: Columns of odometry.csv: body increments, or a differential vehicle's cumulative encoder counts.
ODOMETRY_INCREMENTS = ("t", "delta_d", "delta_theta")
ODOMETRY_COUNTS = ("t", "counts_right", "counts_left")


def read_csv_log(folder: str | Path) -> RecordedLog:
    """Read the CSV layout of the module docstring from ``folder``."""
    d = Path(folder)
    settings_file = d / "settings.json"
    settings: dict[str, Any] = {}
    if settings_file.is_file():
        try:
            text = settings_file.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ValueError(f"{settings_file}: cannot read the settings ({exc})") from None
        settings = _settings(text, str(settings_file))
    odo, _ = _csv(d / "odometry.csv", ("t",), (*ODOMETRY_INCREMENTS[1:], "delta_lateral", *ODOMETRY_COUNTS[1:]))
    counts = [c for c in ODOMETRY_COUNTS[1:] if c in odo]
    if counts and any(c in odo for c in ("delta_d", "delta_theta", "delta_lateral")):
        raise ValueError(f"{d / 'odometry.csv'}:1: give increments ({','.join(ODOMETRY_INCREMENTS)}[,delta_lateral]) "
                         f"or encoder counts ({','.join(ODOMETRY_COUNTS)}), not both")
    if counts:
        missing = [c for c in ODOMETRY_COUNTS if c not in odo]
        if missing:
            raise ValueError(f"{d / 'odometry.csv'}: missing column(s) {missing}; the header must name "
                             f"{list(ODOMETRY_COUNTS)}")
        if "encoders" not in settings:
            raise ValueError(f"{d / 'odometry.csv'}: encoder counts need an 'encoders' entry in settings.json")
        inc = counts_to_increments(odo["counts_right"], odo["counts_left"], settings["encoders"])
    else:
        missing = [c for c in ODOMETRY_INCREMENTS if c not in odo]
        if missing:
            raise ValueError(f"{d / 'odometry.csv'}: missing column(s) {missing}; the header must name "
                             f"{list(ODOMETRY_INCREMENTS)}")
        n = odo["t"].shape[0]
        inc = np.column_stack([odo["delta_d"], odo["delta_theta"], odo.get("delta_lateral", np.zeros(n))])[1:]
    refl_file = d / "reflections.csv"
    refl, lines = _csv(refl_file, ("t", "bearing"), ("stamp", "reflector_index"), strictly_increasing=False)
    if refl["t"].size == 0:
        raise ValueError(f"{refl_file}: no reflections (a header only): positioning needs the goniometer's readings")
    _check_bearings(refl["bearing"], f"{refl_file}:", lines)
    truth = None
    if (d / "truth.csv").is_file():
        tr, _ = _csv(d / "truth.csv", ("t", "x", "y", "psi"))
        truth = np.column_stack([np.interp(odo["t"], tr["t"], tr[c]) for c in ("x", "y")] +
                                [np.interp(odo["t"], tr["t"], np.unwrap(tr["psi"]))])
    return RecordedLog(odo["t"], inc, refl["t"], refl.get("stamp", refl["t"]), refl["bearing"], settings, truth=truth)
