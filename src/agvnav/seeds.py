"""Seed citations: the tag grammar, the equations in scope, and the index of implementing functions.

Every function or class that implements a seed equation says so in its docstring
with one tag per equation, so ``grep -rn "\\[seed000 eq12\\]" src`` finds it:

* ``[seedNNN eqK]`` for a numbered equation, e.g. ``[seed000 eq12]``;
* ``[seedNNN §a.b.c]`` for a model that the seed gives by section without a number,
  e.g. ``[seed003 §3.2.6]``.

No ranges (``eqs 11-13`` is written ``[seed000 eq11] [seed000 eq12] [seed000 eq13]``).
:data:`SCOPE` lists the equations agvnav implements (the scope column of
``/work/shared/seeds/README.md``: seed 000 eqs 1-24, seed 001's one equation, seed 002
eqs 2-26, seed 003's kinematic models §3.2.1-§3.2.7, seed 004 eqs 1-8), each with a
one-line description. A section tag outside :data:`SCOPE` that names a section the seed
has (:data:`SECTIONS`, e.g. ``[seed000 §4.3]`` for an experimental figure, ``[seed004 §II-B]``)
is a *reference*: allowed, indexed and listed apart. Any other tag (``[seed002 eq1]``, which
the seed only uses to define non-holonomy, or a section the seed does not have) is
well-formed but reported by :func:`problems`.

:func:`citation_index` walks the package source with :mod:`ast` (nothing is imported)
and maps each tag to the qualified names of the functions, methods and classes whose
docstrings carry it. ``docs/SEEDS.md`` is :func:`render_markdown` of that index;
regenerate it with ``python -m agvnav.seeds > docs/SEEDS.md``.
"""

from __future__ import annotations

import ast
import functools
import re
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

__all__ = [
    "REGENERATE",
    "SCOPE",
    "SECTIONS",
    "TAG_RE",
    "Citation",
    "citation_index",
    "citations",
    "free_text_citations",
    "is_reference",
    "problems",
    "render_markdown",
]

#: A well-formed tag: ``[seed000 eq12]`` or ``[seed003 §3.2.6]``.
TAG_RE = re.compile(r"\[seed(?P<seed>\d{3}) (?:eq(?P<eq>[1-9]\d*)|§(?P<sec>\d+(?:\.\d+)*|[IVX]+(?:-[A-Z])?))\]")
#: Anything that starts like a tag (``[seed`` followed by a space or digits), well-formed or not.
_TAG_LIKE_RE = re.compile(r"\[seed\s*\d[^\]\n]{0,40}\]?", re.IGNORECASE)

#: An equation cited in free text (``eq. 8``, ``eqs 11-13``, ``Eq 7``): what the tags replace.
_FREE_TEXT_RE = re.compile(r"\b(?:eqs?|equations?)\b\.?\s*\(?\d[^\n,;:]{0,12}", re.IGNORECASE)

#: The command that regenerates ``docs/SEEDS.md`` (run from the repository root).
REGENERATE = "python -m agvnav.seeds > docs/SEEDS.md"

_SEED000 = {
    1: "r(δ) = 2 sin|δ|: similarity ratio of the error triangle to the centres triangle",
    2: "r = √(A_e/A_c): similarity ratio from the two triangles' areas",
    3: "r = |T_ij T_ik| / |C_ij C_ik|: ratio from finite sides when P is aligned with two reflectors",
    4: "|δ| = arcsin(½ √(A_e/A_c)): heading-error magnitude from the areas",
    5: "|δ| = arcsin(½ |T_ij T_ik| / |C_ij C_ik|): heading-error magnitude from the sides",
    6: "sign(δ) = sign[T_ij T_ik ∧ C_ij C_ik]_z: heading-error sign",
    7: "W_ij = sin α_ij / max(L_ij, 2ρ_ij): weight of the pairwise line intersection P_ij",
    8: "ψ' = v sin γ / L: heading rate of the front-drive, front-steer tricycle",
    9: "ξ_r = ξ + γ: drive-wheel heading error",
    10: "ε_c = ε_o + L sin ξ ≈ ε_o + L ξ: lateral error of C from that of O",
    11: "γ' = −a ε_o − b ξ − c γ: general law, point O (manoeuvring)",
    12: "γ' = −a ε_c − (b − aL) ξ − c γ: general law, point C",
    13: "γ' = −a ε_c − (b − aL) ξ_r − (c − b + aL) γ: general law, point C, wheel heading",
    14: "ε_c' = v sin ξ_r ≈ v ξ_r: lateral error rate of C",
    15: "ε_o' = v sin ξ ≈ v ξ: lateral error rate of O",
    16: "ξ' ≈ v γ / L: heading error rate (linearised)",
    17: "q''' + c q'' + (v/L) b q' + (v²/L) a q = 0: closed-loop error dynamics of the general law",
    18: "a, b, c > 0 and bc/a > v: Routh-Hurwitz conditions for v > 0",
    19: "a > 0, b < 0, c > 0 and |b|c/a > |v|: Routh-Hurwitz conditions for v < 0",
    20: "γ' = −a ε_c − b ξ_r − (v/L) γ: simple law (v > 0), point C, wheel heading",
    21: "γ' = −a ε_c − b ξ − (b + v/L) γ: simple law (v > 0), point C",
    22: "γ' = −a ε_o − (b + aL) ξ − (b + v/L) γ: simple law (v > 0), point O",
    23: "Φ(q) = q'' + b q' + a v q = 0 for ε_c, ξ_r: simple-law error dynamics",
    24: "Φ'(q) + (v/L) Φ(q) = 0 for ε_o, ξ, γ: simple-law error dynamics",
}
_SEED002 = {
    2: "ICR = (x − R sin θ, y + R cos θ): instantaneous centre of rotation",
    3: "ω = v_R/(R + L/2) = v_L/(R − L/2), v = R ω: wheel speeds about the ICR",
    4: "ω = (v_R − v_L)/L, v = (v_R + v_L)/2, R = L(v_R + v_L)/(2(v_R − v_L))",
    5: "X = [x, y, φ]: configuration of the platform",
    6: "v = (v_R + v_L)/2 = r(ω_R + ω_L)/2: linear speed from the wheels",
    7: "ω = (v_R − v_L)/L = r(ω_R − ω_L)/L = θ': yaw rate from the wheels",
    8: "[v_x, v_y, θ'] = [[r/2, r/2], [0, 0], [r/L, −r/L]] [ω_R, ω_L]: body-frame model",
    9: "ẋ = v cos θ, ẏ = v sin θ, θ' = ω: unicycle model in the world frame",
    10: "pose as the time integral of (v cos θ, v sin θ, ω) from 0",
    11: "[ẋ, ẏ, θ'] = [[cos θ, 0], [sin θ, 0], [0, 1]] [v, ω]: matrix unicycle model",
    12: "pose at t as the integral of the wheel speeds from t_k",
    13: "pose at t_(k+1) as the integral of the wheel speeds over [t_k, t_(k+1)]",
    14: "X(k+1) = f(X(k), U(k)) + v(k): odometry process model with noise",
    15: "U(k) = [ΔD(k), Δθ(k)]: odometry input",
    16: "ΔD = (ΔD_R + ΔD_L)/2, Δθ = (ΔD_R − ΔD_L)/L: increments from the wheel odometers",
    17: "Q = diag(K_D ΔD cos θ, K_D ΔD sin θ, K_Dθ ΔD + K_θ Δθ): odometry noise covariance",
    18: "ΔD_L,R = T ∓ Δθ L/2: wheel distances of a translation followed by a rotation",
    19: "ΔD = T, Δθ = Δθ: increments of a translation followed by a rotation",
    20: "x + ΔD cos θ, y + ΔD sin θ, θ + Δθ: translate-then-rotate update",
    21: "ΔD_L,R = Δθ (R ∓ L/2): wheel distances on an arc of radius R",
    22: "ΔD = Δθ R: arc length of the midpoint",
    23: "chord / arc = sin(Δθ/2)/(Δθ/2)",
    24: "chord = ΔD sin(Δθ/2)/(Δθ/2)",
    25: "exact arc update: chord along θ + Δθ/2",
    26: "mid-heading update: x + ΔD cos(θ + Δθ/2), y + ΔD sin(θ + Δθ/2), θ + Δθ",
}
_SEED003 = {
    "3.2.1": "fixed wheel: no lateral slip, rolling without sliding",
    "3.2.2": "castor wheel: offset l, non-holonomic constraints with l θ'",
    "3.2.3": "Swedish wheel: rollers free the lateral constraint (l β')",
    "3.2.4": "differential drive: V_O = (V_1 + V_2)/2, ω = (V_1 − V_2)/(2l), unicycle model",
    "3.2.5": "tricycle: model A (rear drive, θ' = V tan φ / l) and B (front drive, V_d cos φ, V_d sin φ / l)",
    "3.2.6": "Ackermann: two linked front-wheel angles, kinematics like the tricycle",
    "3.2.7": "tractor-trailer: hitch angle rate with offset d and trailer length D",
}
_SEED004 = {
    1: "ω_R = (2 V + ω L)/(2 r): right sprocket speed",
    2: "ω_L = (2 V − ω L)/(2 r): left sprocket speed",
    3: "x += (r/2)(ω_R + ω_L) cos θ Δt: dead-reckoning x",
    4: "y += (r/2)(ω_R + ω_L) sin θ Δt: dead-reckoning y",
    5: "θ += (r/L)(ω_R − ω_L) Δt: dead-reckoning heading",
    6: "θ = −arctan((US2 − US1)/dist): heading from two side rangers (Fig. 5b)",
    7: "θ = arctan((US1 − US2)/dist): heading from two side rangers (Fig. 5c)",
    8: "x = x_lan − US1: position from a ranger and the landmark wall",
}

#: Every equation in scope: tag -> one-line description.
SCOPE: dict[str, str] = {
    **{f"[seed000 eq{k}]": d for k, d in _SEED000.items()},
    "[seed001 eq1]": "r(δ) = 2 sin|δ| ⇒ |δ| = arcsin(½ √(A_e/A_c)): seed 000 eqs 1 and 4 in one line",
    **{f"[seed002 eq{k}]": d for k, d in _SEED002.items()},
    **{f"[seed003 §{k}]": d for k, d in _SEED003.items()},
    **{f"[seed004 eq{k}]": d for k, d in _SEED004.items()},
}

_SECTIONS = {
    "000": "1 2 2.1 2.2 2.3 3 3.1 3.2 3.3 4 4.1 4.2 4.3 5",
    "001": "1 2 3 4 5 6",
    "002": "1 2 3 3.1 3.2 3.3 3.3.1 3.3.2 3.3.3 4 5 6",
    "003": "3.1 3.2 3.2.1 3.2.2 3.2.3 3.2.4 3.2.5 3.2.6 3.2.7 3.3 3.4 3.5 3.6 3.7 3.8 3.9",
    "004": "I II II-A II-B II-C III",
}
#: Every section of the seeds (headings of /work/shared/seeds/*.txt) as a tag; the ones
#: that are not in :data:`SCOPE` may be cited as references (``[seed000 §4.3]``).
SECTIONS: frozenset[str] = frozenset(f"[seed{s} §{n}]" for s, ns in _SECTIONS.items() for n in ns.split())


def is_reference(tag: str) -> bool:
    """Whether ``tag`` cites a section of a seed that is not an equation in scope (allowed, listed apart)."""
    return tag in SECTIONS and tag not in SCOPE


@dataclass(frozen=True)
class Citation:
    """One tag-like string found in a docstring.

    Attributes
    ----------
    tag : the text as written, e.g. ``"[seed000 eq12]"``.
    where : qualified name of the function, method or class (or module) carrying it.
    path : source file, relative to the package's parent directory.
    line : line of the definition in that file (1-based).
    is_definition : True for a function, method or class; False for a module docstring.
    """

    tag: str
    where: str
    path: str
    line: int
    is_definition: bool

    @property
    def well_formed(self) -> bool:
        """Whether the tag follows the grammar of :data:`TAG_RE` exactly."""
        return TAG_RE.fullmatch(self.tag) is not None


def _package_dir() -> Path:
    return Path(__file__).resolve().parent


def _docstrings(tree: ast.Module, module: str) -> Iterator[tuple[str, int, bool, str]]:
    """``(qualified name, line, is_definition, docstring)`` for the module and every def/class."""
    yield module, 1, False, ast.get_docstring(tree, clean=False) or ""
    stack: list[tuple[ast.AST, str]] = [(tree, module)]
    while stack:
        node, prefix = stack.pop()
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                name = f"{prefix}.{child.name}"
                yield name, child.lineno, True, ast.get_docstring(child, clean=False) or ""
                stack.append((child, name))


@functools.lru_cache(maxsize=4096)
def _file_docstrings(path: Path, stamp: tuple[int, int], module: str) -> tuple[tuple[str, int, bool, str], ...]:
    """Docstrings of one file in line order; cached per ``(path, (mtime_ns, size))``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    return tuple(sorted(_docstrings(tree, module), key=lambda d: d[1]))


def _scan(package_dir: Path | None, pattern: re.Pattern[str], strip_tags: bool) -> list[Citation]:
    root = (package_dir or _package_dir()).resolve()
    found: list[Citation] = []
    for path in sorted(root.rglob("*.py")):
        if path == Path(__file__).resolve():
            continue  # this module's docstrings show the grammar, good and bad examples
        rel = path.relative_to(root.parent)
        parts = rel.with_suffix("").parts
        module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        st = path.stat()
        for where, line, is_def, doc in _file_docstrings(path, (st.st_mtime_ns, st.st_size), module):
            text = TAG_RE.sub("", doc) if strip_tags else doc
            found += [Citation(m.group(0), where, rel.as_posix(), line, is_def) for m in pattern.finditer(text)]
    return found


def citations(package_dir: Path | None = None) -> list[Citation]:
    """Every tag-like string in the docstrings under ``package_dir`` (default: agvnav's source).

    Parameters
    ----------
    package_dir : directory of the package to scan; its name is the top-level module name.

    Returns
    -------
    list of :class:`Citation`, in file order; malformed tags (``[seed 000 eq 12]``,
    ``[seed000 eqs 11-13]``) are included so that :func:`problems` can name them.
    """
    return _scan(package_dir, _TAG_LIKE_RE, strip_tags=False)


def free_text_citations(package_dir: Path | None = None) -> list[Citation]:
    """Equations cited in free text (``eq. 8``, ``eqs 11-13``) in docstrings, outside any tag.

    These are what the tags replace: ``grep`` for one equation misses a range, and the
    index cannot see them. ``Citation.tag`` holds the matched text.

    Parameters
    ----------
    package_dir : directory of the package to scan (default: agvnav's source).
    """
    return _scan(package_dir, _FREE_TEXT_RE, strip_tags=True)


def citation_index(package_dir: Path | None = None) -> dict[str, list[str]]:
    """Map every well-formed tag to the functions, methods and classes that implement it.

    Only definitions count (a tag in a module docstring is checked, not indexed).

    Parameters
    ----------
    package_dir : directory of the package to scan (default: agvnav's source).

    Returns
    -------
    dict tag -> sorted unique qualified names, e.g.
    ``{"[seed002 eq16]": ["agvnav.odometry.increments.differential_increments", ...]}``;
    tags in :data:`SCOPE` order first, then section references (:func:`is_reference`),
    then any out-of-scope tags, each group sorted.
    """
    index: dict[str, set[str]] = {}
    for c in citations(package_dir):
        if c.is_definition and c.well_formed:
            index.setdefault(c.tag, set()).add(c.where)
    refs = sorted(t for t in index if is_reference(t))
    order = [t for t in SCOPE if t in index] + refs + sorted(t for t in index if t not in SCOPE and t not in refs)
    return {t: sorted(index[t]) for t in order}


def problems(package_dir: Path | None = None) -> list[str]:
    """Everything wrong with the citations; empty when the tags are consistent with :data:`SCOPE`.

    Reports malformed tags, tags naming an equation out of scope or a section the seed
    does not have, and in-scope equations that no function, method or class implements. Each message names the
    tag and where it is.
    """
    found = citations(package_dir)
    out = [f"{c.path}:{c.line} {c.where}: malformed tag {c.tag!r} (write [seed000 eq12] or [seed003 §3.2.6])"
           for c in found if not c.well_formed]
    out += [f"{c.path}:{c.line} {c.where}: {c.tag} is not an equation in scope (see agvnav.seeds.SCOPE)"
            for c in found if c.well_formed and c.tag not in SCOPE and not is_reference(c.tag)]
    implemented = {c.tag for c in found if c.is_definition and c.well_formed}
    out += [f"{tag} ({SCOPE[tag]}) has no implementing function" for tag in SCOPE if tag not in implemented]
    return out


def render_markdown(index: dict[str, list[str]] | None = None) -> str:
    """``docs/SEEDS.md``: every equation in scope, its description and its implementing functions.

    Parameters
    ----------
    index : the output of :func:`citation_index` (computed when omitted).

    Returns
    -------
    The Markdown text, ending with a newline.
    """
    index = citation_index() if index is None else index
    lines = [
        "# Seed equations and the functions that implement them",
        "",
        f"Generated by `agvnav.seeds.render_markdown`; do not edit. Regenerate with `{REGENERATE}`;",
        "`tests/test_seeds.py` fails when this file is stale, when an equation in scope has no",
        "implementing function, or when a docstring tag is malformed or out of scope.",
        "",
        "Tag grammar (in the docstring of the function that implements the equation, one tag per",
        "equation, no ranges): `[seed000 eq12]` for numbered equations, `[seed003 §3.2.6]` for",
        "models the seed gives by section; other sections may be cited as references",
        "(`[seed000 §4.3]`, `[seed004 §II-B]`), listed after the table. Find the implementations of an equation with",
        "`grep -rnF '[seed000 eq12]' src`. The seeds are indexed in `/work/shared/seeds/README.md`.",
        "",
        "| tag | equation | implemented by |",
        "| --- | --- | --- |",
    ]
    for tag, desc in SCOPE.items():
        names = "<br>".join(f"`{n}`" for n in index.get(tag, [])) or "**none**"
        lines.append(f"| `{tag}` | {desc.replace('|', '&#124;')} | {names} |")
    refs = [t for t in index if is_reference(t)]
    if refs:
        lines += ["", "## Section references", "", "| tag | cited by |", "| --- | --- |"]
        lines += [f"| `{t}` | " + "<br>".join(f"`{n}`" for n in index[t]) + " |" for t in refs]
    extra = [t for t in index if t not in SCOPE and not is_reference(t)]
    if extra:
        lines += ["", "Tags out of scope (fix them):", ""]
        lines += [f"- `{t}`: " + ", ".join(f"`{n}`" for n in index[t]) for t in extra]
    return "\n".join(lines) + "\n"


def main() -> int:
    """Print ``docs/SEEDS.md`` to stdout; report citation problems on stderr (exit 1 if any)."""
    sys.stdout.write(render_markdown())
    found = problems()
    for p in found:
        sys.stderr.write(p + "\n")
    return 1 if found else 0


if __name__ == "__main__":
    raise SystemExit(main())
