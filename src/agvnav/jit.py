"""Which mode the compiled kernels run in: the public face of :mod:`agvnav._jit` (issue 11).

A process runs every kernel compiled (numba) or as plain Python, with the same numbers
either way; :func:`set_compiled_for_run` picks the cheaper mode for one run, ``AGVNAV_JIT=0/1``
in the environment overrides. Importing this module does not import numba.
"""

from __future__ import annotations

from agvnav._jit import (
    COMPILED_STARTUP_S,
    INTERPRETED_S_PER_REFLECTOR_S,
    Kernel,
    compiled,
    jit,
    kernels,
    set_compiled,
    set_compiled_for_run,
)

__all__ = [
    "COMPILED_STARTUP_S", "INTERPRETED_S_PER_REFLECTOR_S", "Kernel", "compiled", "jit", "kernels", "set_compiled",
    "set_compiled_for_run",
]
