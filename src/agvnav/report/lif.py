"""Files of the LIF exchange: a LIF JSON written from a network, a route network YAML from a LIF.

Both writers are atomic (a temporary file beside the target, renamed over it) and refuse an
existing file unless ``force`` (:class:`agvnav.report.files.OutputFolderError`, a ValueError).
The YAML is parsed back before it is written: what is written loads as the network imported.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import yaml

from agvnav._json import json_text
from agvnav.report.files import OutputFolderError
from agvnav.routes.network import parse_network

__all__ = ["check_out_file", "network_yaml", "write_lif", "write_network_yaml", "write_text_atomic"]


def check_out_file(path: str | Path, force: bool, option: str = "--out") -> Path:
    """Refuse ``path`` when it is a folder, its folder is missing, or it exists (unless ``force``)."""
    p = Path(path)
    if p.is_dir():
        raise OutputFolderError(f"{option} {p}: it is a folder, not a file")
    if not p.parent.is_dir():
        raise OutputFolderError(f"{option} {p}: the folder {p.parent} does not exist")
    if p.exists() and not force:
        raise OutputFolderError(f"{option} {p}: the file exists; choose another file, or use --force to replace it")
    return p


def write_text_atomic(path: str | Path, text: str, force: bool, option: str = "--out") -> Path:
    """Write ``text`` to ``path`` atomically; an existing file only with ``force``, a folder never."""
    p = check_out_file(path, force, option)
    fd, name = tempfile.mkstemp(prefix=f".{p.name}.partial-", dir=p.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(name, p)
    finally:
        Path(name).unlink(missing_ok=True)
    return p


def write_lif(document: dict[str, Any], path: str | Path, force: bool = False) -> Path:
    """Write a LIF document (indented JSON) to ``path`` (module doc)."""
    return write_text_atomic(path, json_text(document, indent=1) + "\n", force)


def network_yaml(data: dict[str, Any], header: str) -> str:
    """The route network ``data`` as YAML text with a comment ``header``; parsed back to check it (ValueError)."""
    text = "".join(f"# {line}\n" for line in header.splitlines())
    text += yaml.safe_dump(data, sort_keys=False, allow_unicode=True, width=120)
    parse_network(text, "<imported network>")
    return text


def write_network_yaml(data: dict[str, Any], header: str, path: str | Path, force: bool = False) -> Path:
    """Write route network ``data`` as YAML to ``path`` (module doc)."""
    return write_text_atomic(path, network_yaml(data, header), force)
