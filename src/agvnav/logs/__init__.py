"""Logs in the robotics ecosystem's formats: MCAP files of ROS 2 messages, and positioning on recorded data.

MCAP files need the ``logs`` extra (``pip install agvnav[logs]``: ``mcap``, ``mcap-ros2-support``,
``rosbags``); without it this package imports, reads and localizes CSV logs, and an MCAP file
raises :class:`MissingExtraError` (a ValueError naming the extra). Topic names and message
types are in :mod:`agvnav.logs.topics`; the layout and the NAV350-like interface are
documented in docs/logs.md.
"""

from agvnav.logs.extra import MissingExtraError
from agvnav.logs.localize import Localization, Verdict, estimator_from_settings, judge, localize
from agvnav.logs.reader import RecordedLog, read_csv_log, read_log, read_mcap
from agvnav.logs.runlog import positioning_settings, write_run_log
from agvnav.logs.settings import check_settings
from agvnav.logs.topics import TOPICS
from agvnav.logs.writer import LogWriter

__all__ = [
    "TOPICS",
    "Localization",
    "LogWriter",
    "MissingExtraError",
    "RecordedLog",
    "Verdict",
    "check_settings",
    "estimator_from_settings",
    "judge",
    "localize",
    "positioning_settings",
    "read_csv_log",
    "read_log",
    "read_mcap",
    "write_run_log",
]
