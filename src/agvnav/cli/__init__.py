"""Command-line interface."""

from agvnav.cli.app import app, main

__all__ = ["app", "main"]
