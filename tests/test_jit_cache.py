"""agvnav's own numba cache folder: keyed on the kernel sources, pruned (issue 27: no stale machine code)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from agvnav import _jit


def _tree(root: Path) -> Path:
    """A package ``agvnav``: a kernel module importing a constant through a package ``__init__`` (multi-line)."""
    pkg = root / "agvnav"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "_jit.py").write_text("def jit(f):\n    return f\n")
    (pkg / "kern.py").write_text(
        "from agvnav._jit import jit\nfrom agvnav.sub import (\n    LIMIT,\n)\n\n"
        "@jit\ndef k(x):\n    return x * LIMIT\n"
    )
    (pkg / "sub" / "__init__.py").write_text("from agvnav.sub.consts import LIMIT\n")
    (pkg / "sub" / "consts.py").write_text("LIMIT = 1.0\n")
    (pkg / "cli.py").write_text("from agvnav.kern import k\nprint(k(2.0))\n")  # imports a kernel; none imports it
    return pkg


def _touch(path: Path, text: str) -> None:
    path.write_text(text)  # same size: the time tells
    os.utime(path, ns=(1, 10**18))


def test_kernel_sources_follow_the_kernels_imports_transitively(tmp_path: Path) -> None:
    pkg = _tree(tmp_path)
    names = [p.relative_to(pkg).as_posix() for p in _jit.kernel_sources(pkg)]
    assert names == ["_jit.py", "kern.py", "sub/__init__.py", "sub/consts.py"]


@pytest.mark.parametrize("edited", ["kern.py", "sub/consts.py", "sub/__init__.py"])
def test_source_key_changes_with_an_edit_of_a_kernel_source(tmp_path: Path, edited: str) -> None:
    pkg = _tree(tmp_path)
    before = _jit._source_key(pkg)
    assert _jit._source_key(pkg) == before  # repeatable
    path = pkg / edited
    _touch(path, path.read_text().replace("1.0", "2.0"))
    assert _jit._source_key(pkg) != before


def test_source_key_ignores_modules_no_kernel_imports(tmp_path: Path) -> None:
    pkg = _tree(tmp_path)
    before = _jit._source_key(pkg)
    _touch(pkg / "cli.py", "from agvnav.kern import k\nprint(k(3.0))\n")
    (pkg / "__pycache__").mkdir()
    (pkg / "__pycache__" / "a.nbi").write_bytes(b"x")
    (pkg / "notes.txt").write_text("n")
    assert _jit._source_key(pkg) == before


def test_the_package_kernel_sources_hold_every_kernel_module() -> None:
    root = Path(_jit.__file__).resolve().parent
    found = {p.relative_to(root).as_posix() for p in _jit.kernel_sources(root)}
    assert {"positioning/_fast.py", "positioning/_integrity_fast.py", "sensors/beam.py", "geometry/angles.py"} <= found
    assert "cli/simulate.py" not in found and "sim/engine.py" not in found


def test_prune_keeps_the_newest_caches_and_the_current_one(tmp_path: Path) -> None:
    n = _jit.KEEP_CACHES + 3
    dirs = []
    for i in range(n):
        d = tmp_path / f"k{i}"
        d.mkdir()
        os.utime(d, (1000 + i, 1000 + i))
        dirs.append(d)
    current = dirs[0]  # the oldest by time, but the one in use
    _jit._prune(tmp_path, keep=current)
    left = {p.name for p in tmp_path.iterdir()}
    assert left == {"k0", *(f"k{i}" for i in range(n - _jit.KEEP_CACHES + 1, n))}


def test_cache_dir_is_under_the_user_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    d = _jit.cache_dir()
    assert d.parent == tmp_path / "agvnav" / "numba"
    assert len(d.name) == 16
