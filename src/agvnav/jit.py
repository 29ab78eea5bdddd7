"""Which mode the compiled kernels run in: the public face of :mod:`agvnav._jit` (issue 11).

A process runs every kernel compiled (numba) or as plain Python, the numbers agreeing to
rounding (a seeded run is bit-identical to itself within one mode); :func:`set_compiled_for_run`
picks the cheaper mode for one run, ``AGVNAV_JIT=0/1`` in the environment overrides it and
``set_compiled(on, force=True)`` (``agvnav simulate --jit on|off``) overrides both. :func:`mode`
names the mode in force for a run's metadata; :func:`by_mode` runs the implementation of an
algorithm that suits the mode, so no caller outside the kernels asks which one runs. Importing
this module does not import numba.
"""

from __future__ import annotations

from agvnav._jit import (
    COMPILED_STARTUP_S,
    INTERPRETED_S_PER_REFLECTOR_S,
    Kernel,
    by_mode,
    compiled,
    jit,
    kernels,
    mode,
    set_compiled,
    set_compiled_for_run,
)

__all__ = [
    "COMPILED_STARTUP_S", "INTERPRETED_S_PER_REFLECTOR_S", "Kernel", "by_mode", "compiled", "jit", "kernels",
    "mode", "set_compiled", "set_compiled_for_run",
]
