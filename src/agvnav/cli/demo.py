"""``agvnav demo``: positioning on a built-in reflector layout (placeholder until issue 2 lands)."""

from __future__ import annotations

from agvnav.cli.errors import user_errors


@user_errors
def demo() -> None:
    """Triangulate a vehicle on a built-in reflector layout and print a table."""
    raise ValueError("demo is not built yet")
