"""Strict, located YAML documents: every error names the file, the line and the key.

The scenario, map-less route and campaign files share this plumbing. The
schema is a pydantic model that forbids unknown keys (:class:`StrictModel`);
:func:`validate_document` parses YAML text (duplicate keys refused), validates
it and turns the first pydantic error into a :class:`ScenarioError` such as
``guidance.yaml:23: controller.poles_per_m: ...``. Line numbers come from the
YAML composer's node marks: the error location (a key path) is walked down the
composed node tree (:func:`node_line`).
"""

from __future__ import annotations

import ast
import functools
import inspect
import itertools
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any, Self, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from agvnav.world.limits import LIST_LIMITS, MAX_DOCUMENT_BYTES, MAX_LIST_ITEMS, SCAN_MIN_CHARS
from agvnav.world.yaml_strict import compose, find_long_list, safe_load_unique, yaml_error_line

__all__ = [
    "DocumentNotFoundError",
    "Finite",
    "KeyPath",
    "NonNegFloat",
    "PosFloat",
    "ScenarioError",
    "SourcedModel",
    "StrictModel",
    "attach_source",
    "attribute_docs",
    "check_document_size",
    "first_error",
    "format_key",
    "load_yaml_document",
    "node_line",
    "read_document_text",
    "resolve_document",
    "resolve_reference",
    "shipped_name",
    "validate_document",
]

KeyPath = tuple[str | int, ...]

PosFloat = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]
NonNegFloat = Annotated[float, Field(ge=0.0, allow_inf_nan=False)]
Finite = Annotated[float, Field(allow_inf_nan=False)]


class ScenarioError(ValueError):
    """A document problem located by key path and (when known) file line."""

    def __init__(self, message: str, key: KeyPath = (), line: int | None = None, source: str = "") -> None:
        self.key = tuple(key)
        self.line = line
        self.source = source
        self.detail = message
        where = source or "scenario"
        if line is not None:
            where += f":{line}"
        keytext = format_key(self.key)
        super().__init__(f"{where}: {keytext + ': ' if keytext else ''}{message}")


class DocumentNotFoundError(ScenarioError, FileNotFoundError):
    """A document file that does not exist: a located ValueError that is also a FileNotFoundError."""


def format_key(key: KeyPath) -> str:
    """``("path", "segments", 1, "radius_m")`` -> ``path.segments[1].radius_m``."""
    out = ""
    for part in key:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


class StrictModel(BaseModel):
    """A frozen pydantic model that refuses unknown keys.

    A field's meaning is its attribute docstring (the string under it), read by
    :func:`attribute_docs` when the reference is generated. Not through pydantic's
    ``use_attribute_docstrings``: that re-reads and parses every model's source while the
    class is created, about 70 ms of CPU on every start-up of ``agvnav simulate`` for text only
    the documentation reads (issue 11).
    """

    model_config = ConfigDict(extra="forbid", frozen=True)


def attribute_docs(model: type[BaseModel]) -> dict[str, str]:
    """Field name -> attribute docstring (cleaned as :func:`inspect.cleandoc`) of ``model`` and its bases.

    The docstring of a field is the string statement right after its annotated assignment in
    the class body that declares the field last (the nearest class in the MRO whose own
    annotations name it), as pydantic's ``use_attribute_docstrings`` reads it. Each module's
    source is parsed once.
    """
    out: dict[str, str] = {}
    for name in model.model_fields:
        owner = next((c for c in model.__mro__ if name in inspect.get_annotations(c)), None)
        doc = None if owner is None else _class_attribute_docs(owner).get(name)
        if doc is not None:
            out[name] = doc
    return out


def _class_attribute_docs(cls: type) -> dict[str, str]:
    """The attribute docstrings written in the body of ``cls`` itself (its module's parse is cached)."""
    return _module_class_docs(cls.__module__).get(cls.__qualname__, {})


@functools.cache
def _module_class_docs(module: str) -> dict[str, dict[str, str]]:
    """Qualified class name -> its attribute docstrings, for every class in ``module``'s source."""
    try:
        tree = ast.parse(inspect.getsource(sys.modules[module]))
    except (KeyError, OSError, TypeError, SyntaxError):
        return {}
    out: dict[str, dict[str, str]] = {}

    def visit(body: list[ast.stmt], prefix: str) -> None:
        for node in body:
            if isinstance(node, ast.ClassDef):
                qual = prefix + node.name
                docs: dict[str, str] = {}
                for prev, stmt in itertools.pairwise(node.body):
                    if (isinstance(prev, ast.AnnAssign) and isinstance(prev.target, ast.Name)
                            and isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Constant)
                            and isinstance(stmt.value.value, str)):
                        docs[prev.target.id] = inspect.cleandoc(stmt.value.value)
                out[qual] = docs
                visit(node.body, qual + ".")

    visit(tree.body, "")
    return out


class SourcedModel(StrictModel):
    """A document that remembers where it came from, for errors naming key and line."""

    # Not part of the schema: where the document came from, for error messages.
    _source: str = ""
    _nodes: Any = None
    _base_dir: Path | None = None

    def locate(self, key: KeyPath) -> int | None:
        """1-based file line of the key path ``key`` (None if unknown)."""
        return node_line(self._nodes, key)

    def error(self, key: KeyPath, message: str) -> ScenarioError:
        """A :class:`ScenarioError` for ``key`` with its file line."""
        return ScenarioError(message, key, self.locate(key), self._source)

    @property
    def source(self) -> str:
        """Where the document came from (file name, or ``<string>``)."""
        return self._source

    @property
    def base_dir(self) -> Path | None:
        """Folder of the document's file (relative paths in it resolve against it)."""
        return self._base_dir

    def copy_attached(self, update: dict[str, Any]) -> Self:
        """``model_copy(update=...)`` that keeps the source, line map and folder."""
        new = self.model_copy(update=update)
        attach_source(new, self._source, self._nodes, self._base_dir)
        return new


def attach_source(doc: SourcedModel, source: str, nodes: Any, base_dir: Path | None) -> None:
    """Remember ``source``, its composed YAML ``nodes`` and folder on ``doc`` (outside the schema)."""
    object.__setattr__(doc, "__pydantic_private__", {"_source": source, "_nodes": nodes, "_base_dir": base_dir})


def node_line(root: Any, key: KeyPath) -> int | None:
    """Walk a composed YAML node tree along ``key``; return the deepest line reached (1-based).

    For a mapping key that is present, the line of the *key* is returned (that is
    where the user looks); for an unknown key or index, the line of the deepest
    node that exists.
    """
    node = root
    if node is None:
        return None
    line = node.start_mark.line + 1
    for part in key:
        if isinstance(node, yaml.MappingNode):
            hit = next(((k, v) for k, v in node.value if getattr(k, "value", None) == str(part)), None)
            if hit is None:
                return int(line)
            line, node = hit[0].start_mark.line + 1, hit[1]
        elif isinstance(node, yaml.SequenceNode) and isinstance(part, int) and 0 <= part < len(node.value):
            node = node.value[part]
            line = node.start_mark.line + 1
        else:
            return int(line)
    return int(line)


def _loc_to_key(loc: Sequence[Any], data: Any) -> KeyPath:
    """Keep the parts of a pydantic error location that exist in ``data`` (drop union tags)."""
    key: list[str | int] = []
    node = data
    for i, part in enumerate(loc):
        if isinstance(node, Mapping) and isinstance(part, str) and part in node:
            key.append(part)
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int):
            key.append(part)
            node = node[part] if 0 <= part < len(node) else None
        elif isinstance(node, Mapping) and isinstance(part, str) and i == len(loc) - 1:
            key.append(part)  # an unknown or missing key is the last part of the location
        # other parts are union tags ("line", "tricycle", "function-after[...]"): skipped
    return tuple(key)


def first_error(exc: ValidationError, data: Any) -> tuple[KeyPath, str]:
    """The first pydantic error as ``(key path, one-line message)``."""
    errors = exc.errors(include_url=False)
    err = errors[0]
    key = _loc_to_key(err["loc"], data)
    msg = str(err["msg"]).removeprefix("Value error, ")
    if err["type"] == "extra_forbidden":
        msg = "unknown key"
    elif err["type"] == "missing":
        msg = "required key is missing"
    elif err["type"] == "union_tag_invalid":
        ctx = err.get("ctx") or {}
        msg = f"{ctx.get('discriminator', 'type')} must be one of {ctx.get('expected_tags', '')}".replace("'", "")
    if len(errors) > 1:
        msg += f" (and {len(errors) - 1} more problem{'s' if len(errors) > 2 else ''})"
    return key, msg


def shipped_name(name: str, shipped_dir: Path) -> Path | None:
    """The shipped file ``shipped_dir/<name>.yaml`` when ``name`` is a bare shipped name (``hall_loop``), else None.

    A bare name has no folder, no suffix and no leading ``./``: ``./hall_loop`` and
    ``hall_loop.yaml`` are paths, never shipped names.
    """
    if not name or name != Path(name).name or name in (".", "..") or Path(name).suffix:
        return None
    shipped = shipped_dir / f"{name}.yaml"
    return shipped if shipped.is_file() else None


def resolve_document(path: str | Path, shipped_dir: Path, kind: str) -> Path:
    """The file a name typed on the command line names: a file, or a bare shipped name (``lab``).

    A local *file* of that name wins over the shipped one (the user typed it); a folder
    never does (a folder ``warehouse`` does not hide the shipped ``warehouse``). Names
    written inside a document resolve by :func:`resolve_reference` instead.
    Raises a :class:`ScenarioError` naming ``path`` (and the shipped names) when it is a
    folder or does not exist. ``kind`` is the document's name in messages ("map").
    """
    p = Path(path)
    if not p.is_file():
        shipped = shipped_name(str(path), shipped_dir)
        if shipped is not None:
            return shipped
    return _existing_file(p, str(path), shipped_dir, kind)


def resolve_reference(name: str, base_dir: Path | None, shipped_dir: Path, kind: str) -> Path:
    """The file a name written *inside* a document names (a scenario's ``mission.network``).

    A bare shipped name (:func:`shipped_name`) always means the shipped file, whatever
    lies in the current folder or beside the document: a shipped scenario gives the
    same results wherever it is run, and a user's copy of it too. Any other name is a
    path relative to ``base_dir``, the folder of the document that names it (the
    current folder only for a document with no file). To name a file of one's own
    called like a shipped one, write it as a path (``./hall_loop``). Raises a
    :class:`ScenarioError` (the message in ``detail``) for a folder or a missing file.
    """
    shipped = shipped_name(name, shipped_dir)
    if shipped is not None:
        return shipped
    p = Path(name)
    if not p.is_absolute() and base_dir is not None:
        p = base_dir / p
    return _existing_file(p, str(p), shipped_dir, kind)


def _existing_file(p: Path, where: str, shipped_dir: Path, kind: str) -> Path:
    """``p`` when it is a file; else a ScenarioError naming ``where`` (a folder, or missing: the shipped names)."""
    if p.is_dir():
        raise ScenarioError(f"is a directory, not a {kind} file", (), None, where)
    if not p.is_file():
        names = ", ".join(sorted(q.stem for q in shipped_dir.glob("*.yaml"))) or "none"
        raise DocumentNotFoundError(f"no such {kind} file (shipped {kind}s: {names})", (), None, where)
    return p


def read_document_text(path: str | Path, kind: str, source: str | None = None) -> str:
    """The UTF-8 text of a YAML document file; every failure a one-line ScenarioError naming the file.

    A binary file (NUL bytes, or not UTF-8) and an unreadable one are refused with the
    file's name (``source``, default ``path``) instead of a decoder traceback; so is a file
    larger than :data:`~agvnav.world.limits.MAX_DOCUMENT_BYTES`, before it is read.
    """
    where = str(path) if source is None else source
    try:
        size = Path(path).stat().st_size
        if size > MAX_DOCUMENT_BYTES:
            raise ScenarioError(_too_big(size, kind), (), None, where)
        raw = Path(path).read_bytes()
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise ScenarioError(f"cannot read the {kind} file ({reason})", (), None, where) from None
    if b"\x00" in raw:
        raise ScenarioError(f"is a binary file, not a {kind} (YAML text)", (), None, where)
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ScenarioError(f"is not a UTF-8 text file (a {kind} is YAML text)", (), None, where) from None


def _too_big(size: int, kind: str) -> str:
    return (f"is {size / 2**20:.1f} MiB; a {kind} file may be at most {MAX_DOCUMENT_BYTES // 2**20} MiB "
            "(size limits: docs/scenarios.md)")


def check_document_size(text: str, source: str, kind: str) -> None:
    """Refuse YAML ``text`` beyond the size limits of a ``kind`` document (:mod:`agvnav.world.limits`).

    Before anything is built: a text longer than ``MAX_DOCUMENT_BYTES`` characters, and the
    first list with more items than its limit (the ScenarioError names its key and line;
    the event stream is read only up to that item).
    """
    if len(text) > MAX_DOCUMENT_BYTES:
        raise ScenarioError(_too_big(len(text), kind), (), None, source)
    if len(text) < SCAN_MIN_CHARS:
        return
    hit = find_long_list(text, LIST_LIMITS.get(kind, {}), MAX_LIST_ITEMS)
    if hit is not None:
        key, line, limit = hit
        message = f"more than {limit:,} items: refused before loading (size limits: docs/scenarios.md)"
        raise ScenarioError(message, key, line, source)


def load_yaml_document(text: str, source: str, kind: str = "") -> tuple[Any, Any]:
    """``(data, composed nodes)`` of YAML ``text``; a ScenarioError with the line on bad YAML.

    ``kind`` ("scenario", "route network", ...) selects the list limits checked first
    (:func:`check_document_size`).
    """
    check_document_size(text, source, kind or "YAML")
    try:
        nodes = compose(text)
        data = safe_load_unique(text)
    except yaml.YAMLError as exc:
        problem = getattr(exc, "problem", None) or str(exc)
        raise ScenarioError(f"invalid YAML: {problem}", (), yaml_error_line(exc), source) from None
    if not isinstance(data, Mapping):
        raise ScenarioError("the document must be a YAML mapping of keys", (), 1, source)
    return data, nodes


M = TypeVar("M", bound=SourcedModel)


def validate_document(model: type[M], data: Any, nodes: Any, source: str, base_dir: Path | None) -> M:
    """Validate ``data`` against ``model``; the first error becomes a located ScenarioError."""
    try:
        doc = model.model_validate(data)
    except ValidationError as exc:
        key, msg = first_error(exc, data)
        raise ScenarioError(msg, key, node_line(nodes, key), source) from None
    attach_source(doc, source, nodes, base_dir)
    return doc
