"""Write ROS 2 messages (CDR) into an MCAP file that Foxglove and ``ros2 bag`` open.

The encoding is done by ``mcap-ros2-support`` from the standard message
definitions, which come from the ROS 2 Humble type store of ``rosbags`` (both in
the ``logs`` extra: ``pip install agvnav[logs]``). Nothing is encoded by hand. Without the
extra this module imports, and :class:`LogWriter` raises :class:`agvnav.logs.extra.MissingExtraError`.
"""

from __future__ import annotations

from pathlib import Path
from types import TracebackType
from typing import Any

from agvnav.logs.extra import require_logs_extra
from agvnav.logs.messages import stamp_ns
from agvnav.logs.topics import TOPICS

try:  # the logs extra: without it agvnav reads CSV logs, and writing MCAP says which extra to install
    from mcap_ros2.writer import Writer
    from rosbags.typesys import Stores, get_typestore
except ImportError as exc:
    _MISSING: ImportError | None = exc
    _STORE: Any = None
else:
    _MISSING = None
    _STORE = get_typestore(Stores.ROS2_HUMBLE)

__all__ = ["LogWriter", "logs_extra_installed", "message_definition"]


def logs_extra_installed() -> bool:
    """Whether the ``logs`` extra is installed (MCAP files can be written and read)."""
    return _MISSING is None


def message_definition(msgtype: str) -> tuple[str, str]:
    """``(datatype, text)`` of a standard ROS 2 message, e.g. ``nav_msgs/msg/Odometry``.

    ``datatype`` is the ``pkg/msg/Name`` form MCAP schemas carry; ``text`` the
    concatenated ``.msg`` definitions (ros2msg encoding) with its dependencies. Needs the ``logs`` extra.
    """
    require_logs_extra(_MISSING, "an MCAP message definition")
    if msgtype not in _STORE.types:
        raise ValueError(f"unknown ROS 2 message type {msgtype!r}")
    text, _ = _STORE.generate_msgdef(msgtype, ros_version=2)
    return msgtype, text


class LogWriter:
    """An MCAP file of ROS 2 messages on the topics of :data:`agvnav.logs.topics.TOPICS`.

    Use as a context manager; :meth:`write` takes a topic, a message as a dict and
    its time ``t`` (s since the run's start, also the header stamps' origin) and
    optionally a log time (the arrival, s) when it differs from ``t``.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        if self.path.suffix != ".mcap":
            raise ValueError(f"a log file must end in .mcap, got {self.path}")
        require_logs_extra(_MISSING, "writing an MCAP log")
        self._file = self.path.open("wb")
        self._writer = Writer(self._file)
        self._schemas: dict[str, Any] = {}
        self.counts: dict[str, int] = {}

    def write(self, topic: str, message: dict[str, Any], t: float, log_t: float | None = None) -> None:
        """Append ``message`` on ``topic`` at ``t`` s (log time ``log_t`` s, default ``t``)."""
        if topic not in TOPICS:
            raise ValueError(f"unknown log topic {topic!r}; the topics are {list(TOPICS)}")
        schema = self._schemas.get(topic)
        if schema is None:
            schema = self._writer.register_msgdef(*message_definition(TOPICS[topic][0]))
            self._schemas[topic] = schema
        ns = stamp_ns(t if log_t is None else log_t)
        seq = self.counts.get(topic, 0)
        self._writer.write_message(topic, schema, message, log_time=ns, publish_time=ns, sequence=seq)
        self.counts[topic] = seq + 1

    def close(self) -> None:
        """Finish the MCAP file (summary, index) and close it."""
        try:
            self._writer.finish()
        finally:
            self._file.close()

    def __enter__(self) -> LogWriter:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, value: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
