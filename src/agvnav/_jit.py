"""The one way agvnav compiles a scalar kernel: numba ``njit`` with ``cache=True``, no fastmath.

A kernel is written once, in the subset of Python numba compiles (loops over float64
arrays, ``math``), and serves one vehicle or a batch alike. ``cache=True`` keeps the
machine code on disk next to the module (``__pycache__``), so only the first run on a
machine compiles. No ``fastmath``: IEEE arithmetic, operation for operation as written.
numba is imported by the modules that hold kernels (the simulator's hot path), never by
``import agvnav`` or the CLI's ``--help``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar, cast

from numba import njit

__all__ = ["jit"]

F = TypeVar("F", bound=Callable[..., Any])


def jit(fn: F) -> F:
    """Compile ``fn`` with numba (cached on disk), keeping its Python signature for mypy."""
    return cast(F, njit(cache=True)(fn))
