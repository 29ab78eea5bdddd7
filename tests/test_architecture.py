"""The package layout's rules, checked on the source: no import cycles (function-local imports
included), no other package's private names, and data flowing one way between packages."""

from __future__ import annotations

import ast
from functools import cache
from pathlib import Path

import agvnav

SRC = Path(agvnav.__file__).parent


def _module_name(path: Path) -> str:
    rel = path.relative_to(SRC.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {_module_name(p): p for p in SRC.rglob("*.py")}


@cache
def _imports(path: Path) -> list[tuple[str, list[str], int]]:
    """``(module, imported names, line)`` of every ``import``/``from`` anywhere in the file."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    mod = _module_name(path)
    package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
    out = []
    typing_only = {id(n) for b in ast.walk(tree) if _is_type_checking_block(b) for n in ast.walk(b)}
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.Import):
            out += [(a.name, [], node.lineno) for a in node.names if a.name.startswith("agvnav")]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1] + ([base] if base else []))
            if base.startswith("agvnav"):
                out.append((base, [a.name for a in node.names], node.lineno))
    return out


def _is_type_checking_block(node: ast.AST) -> bool:
    """``if TYPE_CHECKING:`` blocks import for annotations only, never at run time."""
    return isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING"


def _targets(base: str, names: list[str]) -> list[str]:
    """The agvnav modules whose names an import statement reads.

    ``from pkg import submodule`` reads only the submodule (the package is
    already initialising as the importer's parent, or imports nothing it needs);
    ``from pkg import name`` reads the package's ``__init__`` too.
    """
    subs = [f"{base}.{n}" for n in names if f"{base}.{n}" in MODULES]
    reads_package = base in MODULES and (not names or len(subs) < len(names))
    return ([base] if reads_package else []) + subs


@cache
def _graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for mod, path in MODULES.items():
        for base, names, _ in _imports(path):
            graph[mod].update(t for t in _targets(base, names) if t != mod)
    return graph


def _package(mod: str) -> str:
    parts = mod.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_no_import_cycles_between_packages_including_function_local_imports():
    """Package-level graph: an edge p -> q when a module of p imports a module of q (anywhere)."""
    cycle = _find_cycle(_package_graph())
    assert cycle is None, f"import cycle between packages: {' -> '.join(cycle or [])}"


def test_no_import_cycles_between_modules():
    cycle = _find_cycle(_graph())
    assert cycle is None, f"import cycle: {' -> '.join(cycle or [])}"


def _find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    colour: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        colour[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if colour.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if colour.get(nxt) is None:
                found = visit(nxt)
                if found:
                    return found
        stack.pop()
        colour[node] = 2
        return None

    for node in sorted(graph):
        if colour.get(node) is None:
            found = visit(node)
            if found:
                return found
    return None


def test_no_private_names_of_another_package():
    """``from agvnav.pkg import _name`` (or of ``agvnav.pkg._module``) only inside ``pkg`` itself.

    The root package's own private helpers (``agvnav._validate``) serve every package.
    """
    bad = []
    for mod, path in MODULES.items():
        for base, names, line in _imports(path):
            if _package(base) in ("", _package(mod)) or (base.count(".") == 1 and _package(base).startswith("_")):
                continue
            private_module = any(part.startswith("_") for part in base.split(".")[1:])
            private_names = [n for n in names if n.startswith("_")]
            if private_module or private_names:
                bad.append(f"{path.relative_to(SRC.parent)}:{line}: {base} {private_names or ''}")
    assert not bad, "private names of another package:\n" + "\n".join(bad)


def _wraps_a_plant(cls: ast.ClassDef) -> bool:
    """A class whose ``__init__`` takes the plant it wraps (e.g. fault injection) adds no physics of its own."""
    for node in cls.body:
        if isinstance(node, ast.FunctionDef) and node.name == "__init__":
            return any(a.arg == "plant" for a in node.args.args)
    return False


def test_sim_only_wires_and_cli_only_calls():
    """Truth vehicles live in ``vehicles`` (sim defines no plant of its own, only wrappers of one).

    Report and lower layers never import cli.
    """
    for mod, path in MODULES.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        classes = [
            n.name for n in ast.walk(tree)
            if isinstance(n, ast.ClassDef) and not any(getattr(b, "id", "") == "Protocol" for b in n.bases)
            and not _wraps_a_plant(n)
        ]
        if _package(mod) == "sim":
            assert not [c for c in classes if c.endswith("Plant")], f"{mod} defines a plant: {classes}"
        if _package(mod) != "cli":
            assert not any(_package(b) == "cli" for b, _, _ in _imports(path)), f"{mod} imports agvnav.cli"


ARCHITECTURE = SRC.parents[1] / "docs" / "ARCHITECTURE.md"


def _package_map() -> dict[str, int]:
    """docs/ARCHITECTURE.md's package map: package -> layer (the table between the map's markers)."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    table = text.split("<!-- package-map", 1)[1].split("<!-- /package-map -->", 1)[0]
    layers: dict[str, int] = {}
    for line in table.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 3 or not cells[0].isdigit():
            continue
        for name in cells[1].split(","):
            package = name.strip().strip("`")
            assert package not in layers, f"{package} is in the package map twice"
            layers[package] = int(cells[0])
    return layers


def _package_graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for mod, targets in _graph().items():
        p = _package(mod)
        graph.setdefault(p, set()).update(_package(t) for t in targets if _package(t) not in ("", p))
    graph.pop("", None)
    return graph


def test_the_package_map_lists_every_package_once():
    layers = _package_map()
    packages = set(_package_graph())
    assert packages - set(layers) == set(), "packages missing from docs/ARCHITECTURE.md's map"
    assert set(layers) - packages == set(), "the map names packages that do not exist"


def _upward(layers: dict[str, int], graph: dict[str, set[str]]) -> list[str]:
    """Every package edge that does not go to a strictly lower layer."""
    return [
        f"{p} (layer {layers[p]}) imports {q} (layer {layers[q]})"
        for p, targets in sorted(graph.items()) for q in sorted(targets) if layers[q] >= layers[p]
    ]


def test_every_package_imports_only_lower_layers_of_the_map():
    """The layering the architecture page draws is the one the code has (function-local imports included)."""
    upward = _upward(_package_map(), _package_graph())
    assert not upward, "imports against docs/ARCHITECTURE.md's package map:\n" + "\n".join(upward)


def test_the_layer_check_reports_an_upward_or_sideways_import():
    """The check can fail: a known upward and a known same-layer edge are both reported."""
    graph = _package_graph()
    graph["geometry"] = graph["geometry"] | {"sim", "kinematics"}
    assert _upward(_package_map(), graph) == [
        "geometry (layer 1) imports kinematics (layer 1)", "geometry (layer 1) imports sim (layer 6)"
    ]
