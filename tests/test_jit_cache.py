"""agvnav's own numba cache folder: keyed on the whole source, pruned (issue 27: no stale machine code)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from agvnav import _jit


def _tree(root: Path) -> Path:
    (root / "pkg" / "sub").mkdir(parents=True)
    (root / "pkg" / "a.py").write_text("X = 1\n")
    (root / "pkg" / "sub" / "b.py").write_text("def f():\n    return 2\n")
    return root / "pkg"


def test_source_key_changes_with_an_edit_of_any_file(tmp_path: Path) -> None:
    pkg = _tree(tmp_path)
    before = _jit._source_key(pkg)
    assert _jit._source_key(pkg) == before  # repeatable
    callee = pkg / "sub" / "b.py"
    callee.write_text("def f():\n    return 3\n")  # same size: the time tells
    os.utime(callee, ns=(1, 10**18))
    assert _jit._source_key(pkg) != before


def test_source_key_ignores_pycache_and_other_files(tmp_path: Path) -> None:
    pkg = _tree(tmp_path)
    before = _jit._source_key(pkg)
    (pkg / "__pycache__").mkdir()
    (pkg / "__pycache__" / "a.nbi").write_bytes(b"x")
    (pkg / "notes.txt").write_text("n")
    assert _jit._source_key(pkg) == before


def test_prune_keeps_the_newest_caches_and_the_current_one(tmp_path: Path) -> None:
    dirs = []
    for i in range(6):
        d = tmp_path / f"k{i}"
        d.mkdir()
        os.utime(d, (1000 + i, 1000 + i))
        dirs.append(d)
    current = dirs[0]  # the oldest by time, but the one in use
    _jit._prune(tmp_path, keep=current)
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted(["k0", "k5", "k4"][: _jit.KEEP_CACHES])


def test_cache_dir_is_under_the_user_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    d = _jit.cache_dir()
    assert d.parent == tmp_path / "agvnav" / "numba"
    assert len(d.name) == 16
