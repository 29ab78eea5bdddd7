"""The one way agvnav compiles a scalar kernel: numba ``njit`` with ``cache=True``, no fastmath.

A kernel is written once, in the subset of Python numba compiles (loops over float64
arrays, ``math``), and serves one vehicle or a batch alike. ``cache=True`` keeps the
machine code on disk next to the module (``__pycache__``), so only the first run on a
machine compiles. No ``fastmath``: IEEE arithmetic, operation for operation as written.

Lazy, and compiled only where it pays (issue 11, ``agvnav simulate`` start-up): the
decorator returns a :class:`Kernel` that imports numba on its first call, and only in
compiled mode. Importing numba and readying its CPU target (which loads the cached
machine code) costs about 0.7 s of CPU once per process, more than the whole default
closed loop (26 s simulated) spends in the kernels run as plain Python. So a process
picks a mode once (:func:`set_compiled`): compiled for campaigns, benchmarks and long
runs, interpreted for one short ``agvnav simulate``.

Determinism is within one mode (issue 27). A seeded run repeats itself bit for bit on the
same platform in the same mode. The two modes run the same source with plain ``math``
(``math.hypot``, ``x * x``, ``round``, ``sum`` in order) and agree to rounding, about
1e-12 relative per kernel (``tests/test_jit.py``: one parametrized property test over every
kernel), not bit for bit: CPython and numba take some functions from different places
(``math.hypot``, ``x ** 2``). A closed loop may therefore take another path in the other mode
at a decision within rounding of its threshold (a gate, a check): compare runs of the two
modes statistically, not by hash. The mode a run used is in its metadata (``kernels``).
A kernel must not use ``math.fma`` (none in numba) nor NumPy reductions whose order
differs (``np.sum`` sums pairwise in NumPy and in order in numba) where the order matters
beyond rounding. Where ``math`` raises ``ValueError`` on a non-finite or out-of-domain
argument (``cos(inf)``, ``sqrt(-1)``), a compiled kernel returns NaN; the kernels' inputs are finite.

numba's on-disk cache keys a kernel on its own source file only: a kernel that calls one in
another file (``wrap_angle_kernel`` of ``geometry.angles`` from ``sensors.beam``,
``positioning._fast``'s bearing and noise kernels from ``positioning._integrity_fast``) or reads
another module's constant would keep stale machine code after an edit of the callee alone. So
agvnav keeps its machine code in a cache folder of its own whose name is a key over the kernel
sources (:func:`cache_dir`): every module that defines a kernel and every agvnav module those
import, transitively (path, size, modification time; :func:`kernel_sources`). An edit of any of
them starts a fresh cache; an edit elsewhere (the simulator, the CLI, a bench) keeps the machine
code. The previous caches are pruned (the newest :data:`KEEP_CACHES` stay, one per checkout or
state of the kernels). A user's own ``NUMBA_CACHE_DIR`` wins.

The mode is ``AGVNAV_JIT=0`` / ``1`` from the environment when set, else compiled unless
a caller said otherwise (:func:`set_compiled`). It is resolved once, at the first call of
:func:`compiled` and again at each :func:`set_compiled` (the environment is read then, not
on every call: the closed loop asks for the mode a few times per step). numba is never
imported by ``import agvnav``, the CLI's ``--help`` or an interpreted run.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import re
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any, ParamSpec, TypeVar, cast

__all__ = [
    "Kernel",
    "by_mode",
    "cache_dir",
    "compiled",
    "jit",
    "kernel_sources",
    "kernels",
    "mode",
    "set_compiled",
    "set_compiled_for_run",
]

F = TypeVar("F", bound=Callable[..., Any])
P = ParamSpec("P")
R = TypeVar("R")

_ENV = "AGVNAV_JIT"
_KERNELS: list[Kernel] = []
_state: dict[str, bool] = {}
_mode: list[bool] = []  # the resolved mode (empty until the first compiled() or set_compiled())


def _env_mode() -> bool | None:
    value = os.environ.get(_ENV, "").strip().lower()
    if value in ("", "auto"):
        return None
    if value in ("0", "false", "no", "off"):
        return False
    if value in ("1", "true", "yes", "on"):
        return True
    raise ValueError(f"{_ENV}={value!r}: expected 0 or 1")


def _resolve() -> bool:
    """The mode from ``AGVNAV_JIT`` (when set) or the last :func:`set_compiled` (default compiled), kept.

    A :func:`set_compiled` with ``force`` wins over the environment.
    """
    env = None if _state.get("forced") else _env_mode()
    mode = env if env is not None else _state.get("compiled", True)
    _mode[:] = [mode]
    return mode


def compiled() -> bool:
    """Whether this process runs the kernels compiled (numba) rather than as plain Python.

    Resolved at the first call and at each :func:`set_compiled` (``AGVNAV_JIT`` is read then).
    """
    return _mode[0] if _mode else _resolve()


def by_mode(when_compiled: Callable[P, R], when_interpreted: Callable[P, R]) -> Callable[P, R]:
    """One function that runs ``when_compiled`` while the process runs compiled, else ``when_interpreted``.

    For an algorithm with two implementations, each the faster in its mode (the route planner's
    A* kernel compiled, SciPy's Dijkstra interpreted): the caller calls one function and never
    asks which mode runs (issue 27). The mode is looked up at each call (:func:`compiled`).
    """

    def run(*args: P.args, **kwargs: P.kwargs) -> R:
        return (when_compiled if compiled() else when_interpreted)(*args, **kwargs)

    return run


def mode() -> str:
    """``"compiled"`` or ``"interpreted"``: the kernels' mode in force, as a run's metadata records it."""
    return "compiled" if compiled() else "interpreted"


def set_compiled(on: bool, force: bool = False) -> None:
    """Run every kernel compiled (``True``, numba) or interpreted (``False``) from now on.

    ``AGVNAV_JIT`` in the environment wins over this call (read now: a malformed value raises
    ValueError here) unless ``force`` (a user's explicit choice, ``agvnav simulate --jit on|off``);
    a later call without ``force`` gives the environment back its say. Switching is allowed at
    any time (each kernel resolves again on its next call); results agree to rounding either way.
    """
    _state["compiled"] = bool(on)
    _state["forced"] = bool(force)
    _resolve()
    for k in _KERNELS:
        k._impl = None


#: Extra CPU the kernels cost run as plain Python, per reflector in the map and simulated second (s),
#: measured on the shipped scenarios (issue 11; interpreted against compiled loop, best of 4 each, first
#: 30 s): 1.2-1.4 ms in guidance_test (9 reflectors), 0.9 ms in differential_loop (14), 0.6 ms in
#: warehouse_mission (102), none in positioning_validation (its cost lies outside the kernels). Earlier
#: code gave 1.1-1.2 ms and 3.8 ms (positioning_validation); this is the upper end of today's figures.
INTERPRETED_S_PER_REFLECTOR_S = 1.2e-3

#: CPU (s) that importing numba and loading the cached machine code costs once per process: measured
#: 0.7-0.8 s, and again 0.65-0.76 s (import 0.15-0.24 s, then 0.47-0.52 s for the 8 kernels of guidance_test).
COMPILED_STARTUP_S = 0.75


def set_compiled_for_run(sim_seconds: float, reflectors: int, extra_s: float = 0.0) -> bool:
    """Pick the cheaper mode for one run of ``sim_seconds`` simulated seconds (s) with ``reflectors`` in the map.

    Interpreted when the kernels' estimated extra cost as plain Python (the goniometer's, plus
    ``extra_s`` (s) the caller estimates for its other kernels, e.g. a safety scanner's rays) stays
    below numba's start-up (:data:`COMPILED_STARTUP_S`), compiled otherwise; sets it (:func:`set_compiled`)
    and returns whether the kernels now run compiled (:func:`compiled`: ``AGVNAV_JIT`` wins).
    The numbers agree to rounding either way; mainly time differs.
    """
    if sim_seconds < 0.0 or reflectors < 0 or not extra_s >= 0.0:
        raise ValueError(f"sim_seconds {sim_seconds}, reflectors {reflectors} and extra_s {extra_s} must be >= 0")
    on = sim_seconds * max(reflectors, 1) * INTERPRETED_S_PER_REFLECTOR_S + extra_s > COMPILED_STARTUP_S
    set_compiled(on)
    return compiled()  # the mode in force: AGVNAV_JIT in the environment wins over the estimate


def kernels() -> tuple[Kernel, ...]:
    """Every kernel defined so far (imported modules only), for the two modes' property test."""
    return tuple(_KERNELS)


class Kernel:
    """A scalar kernel that runs compiled by numba or as its plain Python source.

    Calling it runs :attr:`py_func` or its numba dispatcher (:meth:`dispatcher`, built on
    first use), as :func:`compiled` says. Inside another compiled kernel a ``Kernel``
    global is typed as its dispatcher, so kernels call kernels in either mode.
    """

    def __init__(self, fn: Callable[..., Any]) -> None:
        self.py_func = fn
        self._impl: Callable[..., Any] | None = None
        self._dispatcher: Any = None
        functools.update_wrapper(self, fn)

    def dispatcher(self) -> Any:
        """The numba dispatcher (``njit(cache=True)``), created on first use (imports numba)."""
        if self._dispatcher is None:
            _register_with_numba()
            from numba import njit  # noqa: PLC0415  (lazy on purpose: see the module docstring)

            self._dispatcher = njit(cache=True)(self.py_func)
        return self._dispatcher

    def bound(self) -> Callable[..., Any]:
        """The callable a call runs now: the numba dispatcher (compiled) or :attr:`py_func` (interpreted).

        For a hot loop that calls the kernel many times: calling the result skips this wrapper's
        own frame and argument repacking (issue 11: ~0.3 us a call, twice per reflection). Ask
        again after :func:`set_compiled` (the mode it was bound in is kept by the callable).
        """
        impl = self._impl
        if impl is None:
            impl = self._impl = self.dispatcher() if compiled() else self.py_func
        return impl

    def __call__(self, *args: Any) -> Any:
        return (self._impl or self.bound())(*args)

    def __repr__(self) -> str:
        return f"Kernel({self.py_func.__module__}.{self.py_func.__qualname__})"


#: How many of agvnav's kernel caches (one per state of the kernel sources) stay on disk.
KEEP_CACHES = 6

#: A module defines kernels when its text holds one of these: it imports this module or calls numba's ``njit``.
_KERNEL_MARKS = ("from agvnav._jit import", "from agvnav import _jit", "njit(")
#: The agvnav modules a module imports (absolute imports: the package uses no relative ones).
_IMPORTS = re.compile(r"^[ \t]*(?:from (agvnav(?:\.\w+)*) import (\([^)]*\)|[\w, ]+)|import (agvnav(?:\.\w+)*))", re.M)


def _module_files(root: Path) -> dict[str, Path]:
    """Every module of the package under ``root``: dotted name -> file (a package's ``__init__.py``)."""
    out: dict[str, Path] = {}
    for path in root.rglob("*.py"):
        if "__pycache__" in path.parts:
            continue
        parts = path.relative_to(root.parent).with_suffix("").parts
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def kernel_sources(root: Path) -> list[Path]:
    """The files a kernel's machine code can depend on: the kernel modules and their agvnav imports, transitively.

    A name imported ``from agvnav.pkg import name`` counts as the module ``agvnav.pkg.name``
    when that is a module, and as ``agvnav.pkg`` (its ``__init__``, which re-exports it) otherwise.
    Sorted, for a stable key.
    """
    files = _module_files(root)
    texts = {m: f.read_text(encoding="utf-8") for m, f in files.items()}
    todo = [m for m, text in texts.items() if any(k in text for k in _KERNEL_MARKS)]
    seen: set[str] = set()
    while todo:
        m = todo.pop()
        if m in seen or m not in texts:
            continue
        seen.add(m)
        for frm, names, plain in _IMPORTS.findall(texts[m]):
            if plain:
                todo.append(plain)
                continue
            for name in re.findall(r"\w+", names):
                todo.append(f"{frm}.{name}" if f"{frm}.{name}" in texts else frm)
    return sorted(files[m] for m in seen)


def _source_key(root: Path) -> str:
    """A key over the kernel sources under ``root`` (:func:`kernel_sources`): relative path, size, mtime (ns)."""
    h = hashlib.blake2b(digest_size=8)
    for path in kernel_sources(root):
        st = path.stat()
        h.update(f"{path.relative_to(root)}:{st.st_size}:{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


def cache_dir() -> Path:
    """The folder numba keeps agvnav's machine code in: ``$XDG_CACHE_HOME/agvnav/numba/<source key>``.

    The key changes with any edit of a kernel source (:func:`kernel_sources`), so a kernel never
    runs machine code compiled against another file's old kernels or constants.
    """
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "agvnav" / "numba"
    return base / _source_key(Path(__file__).resolve().parent)


def _use_own_cache() -> None:
    """Point numba's cache at :func:`cache_dir` (unless the user set ``NUMBA_CACHE_DIR``); prune old ones."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    from numba.core import config  # noqa: PLC0415

    here = cache_dir()
    try:
        here.mkdir(parents=True, exist_ok=True)
        os.utime(here)
        _prune(here.parent, keep=here)
    except OSError:
        return  # an unwritable home: numba's default place (next to the sources) serves
    config.CACHE_DIR = str(here)  # type: ignore[attr-defined]  # numba reads it when a cached dispatcher is made


def _prune(base: Path, keep: Path) -> None:
    """Remove all but the :data:`KEEP_CACHES` most recently used caches under ``base`` (never ``keep``)."""
    caches = sorted((p for p in base.iterdir() if p.is_dir()), key=lambda p: p.stat().st_mtime, reverse=True)
    for old in [p for p in caches if p != keep][KEEP_CACHES - 1:]:
        shutil.rmtree(old, ignore_errors=True)


def _register_with_numba() -> None:
    """Teach numba's typing that a :class:`Kernel` global is its dispatcher (once per process)."""
    if _state.get("registered"):
        return
    _use_own_cache()
    import numpy as np  # noqa: PLC0415
    from numba import types  # noqa: PLC0415
    from numba.extending import overload, typeof_impl  # noqa: PLC0415

    @typeof_impl.register(Kernel)
    def _typeof_kernel(val: Kernel, c: Any) -> Any:
        return typeof_impl(val.dispatcher(), c)

    @overload(math.fmod)
    def _fmod(x, y):  # type: ignore[no-untyped-def]  # unannotated: numba compares it with the lambda's
        # numba has no math.fmod: C's fmod, as CPython's (exact), NaN where CPython raises (+-inf)
        if isinstance(x, types.Float) and isinstance(y, types.Float):
            return lambda x, y: np.fmod(x, y)
        return None

    _state["registered"] = True


def jit(fn: F) -> F:
    """Make ``fn`` a :class:`Kernel` (compiled with numba, cached on disk, when the process runs compiled)."""
    k = Kernel(fn)
    _KERNELS.append(k)
    return cast(F, k)
