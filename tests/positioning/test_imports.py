"""positioning imports cleanly: no function-local imports (no hidden cycles) and no scipy.optimize at start-up."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import agvnav.positioning
from agvnav.positioning import estimator, make_estimator
from agvnav.world import load_builtin_map

PACKAGE = Path(agvnav.positioning.__file__).parent

#: The one deferred import allowed: a heavy third-party module inside the one function that uses it.
DEFERRED_THIRD_PARTY = {
    ("bearing_gate.py", "associate_sweep", "scipy.optimize"),
    ("integrity_raim.py", "chi2_threshold", "scipy.stats"),
}


def _function_local_imports(path: Path) -> list[tuple[str, str, str]]:
    """``(file, function, module)`` of every import statement inside a function body."""
    found = []
    for func in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(func, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        for node in ast.walk(func):
            if isinstance(node, ast.Import):
                found += [(path.name, func.name, alias.name) for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                found.append((path.name, func.name, "." * node.level + (node.module or "")))
    return found


def test_no_function_local_imports_in_positioning() -> None:
    modules = sorted(PACKAGE.glob("*.py"))
    assert len(modules) > 10
    found = {imp for path in modules for imp in _function_local_imports(path)}
    assert found - DEFERRED_THIRD_PARTY == set()


def test_the_ast_check_sees_a_function_local_import(tmp_path: Path) -> None:
    """The checker is not blind: it reports an import hidden in a method."""
    source = tmp_path / "m.py"
    source.write_text("class A:\n    def f(self):\n        from agvnav.positioning import ekf\n        return ekf\n")
    assert _function_local_imports(source) == [("m.py", "f", "agvnav.positioning")]


def _modules_after(statement: str) -> set[str]:
    code = f"import sys; {statement}; print('\\n'.join(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout
    return set(out.split())


def test_importing_positioning_does_not_import_scipy_optimize() -> None:
    loaded = _modules_after("import agvnav.positioning")
    assert "agvnav.positioning.identification" in loaded
    assert not any(m == "scipy.optimize" or m.startswith("scipy.optimize.") for m in loaded)


def test_the_start_up_search_still_loads_the_assignment_solver() -> None:
    """The deferred import happens where it is needed (and the subprocess check can see it)."""
    loaded = _modules_after(
        "import numpy as np; from agvnav.positioning import associate_sweep; "
        "associate_sweep([0.1], [0, 0, 0], np.eye(3) * 1e-4, [0, 0, 0], [[5.0, 0.5]], [0.0], 1e-6)"
    )
    assert "scipy.optimize" in loaded


def test_both_factory_paths_are_the_same_function_and_every_method_is_registered() -> None:
    assert estimator.make_estimator is make_estimator
    world = load_builtin_map("lab")
    for method in estimator.METHODS:
        est = make_estimator(method, world, (0.0, 0.0, 0.0))
        assert est.method == method
        assert type(est).__module__ in ("agvnav.positioning.ekf", "agvnav.positioning.dynamic")
