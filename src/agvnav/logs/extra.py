"""The ``logs`` extra (``mcap``, ``mcap-ros2-support``, ``rosbags``) is optional: only MCAP files need it.

A folder of CSV files is read without it; reading or writing an ``.mcap`` file without it
raises :class:`MissingExtraError`, whose one-line message names the extra to install.
"""

from __future__ import annotations

__all__ = ["LOGS_EXTRA", "MissingExtraError", "require_logs_extra"]

#: How to install the extra, as the messages say it.
LOGS_EXTRA = "pip install 'agvnav[logs]'"


class MissingExtraError(ImportError, ValueError):
    """An optional extra is not installed; the message names it.

    An ImportError (what it is) and a ValueError, so a command's one-line user-error
    handling (:func:`agvnav.cli.errors.user_errors`) reports it with exit 2, not a traceback.
    """


def require_logs_extra(missing: ImportError | None, what: str) -> None:
    """Raise :class:`MissingExtraError` for ``what`` (``"reading an MCAP log"``) when ``missing`` is set."""
    if missing is not None:
        raise MissingExtraError(f"{what} needs the logs extra: {LOGS_EXTRA} ({missing})")
