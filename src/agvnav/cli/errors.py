"""Turn user mistakes into one-line messages and a non-zero exit, never a traceback."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import ParamSpec, TypeVar

import typer
from rich.console import Console

P = ParamSpec("P")
R = TypeVar("R")

err_console = Console(stderr=True, highlight=False, soft_wrap=True)

#: Exit code for a user mistake (bad scenario, bad argument value, missing file).
USER_ERROR_EXIT = 2


def fail(message: str) -> typer.Exit:
    """Print ``error: message`` on one line to stderr and return the Exit to raise."""
    err_console.print(f"error: {message}", markup=False)
    return typer.Exit(code=USER_ERROR_EXIT)


def user_errors(func: Callable[P, R]) -> Callable[P, R]:
    """Decorate a command so ValueError/OSError become a one-line error and exit code 2."""

    @functools.wraps(func)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return func(*args, **kwargs)
        except (ValueError, OSError) as exc:
            text = " ".join(str(exc).split()) or type(exc).__name__
            raise fail(text) from None

    return wrapper
