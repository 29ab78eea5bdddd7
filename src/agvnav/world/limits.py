"""Size limits of the YAML documents agvnav reads (issue 29): refused before they are loaded.

A 6.8 MB scenario of 200,000 path segments took 94 s and 2.9 GB of memory before it
was refused, printing nothing meanwhile. A document is now refused at once, naming
the file (and the key and line of a list that is too long), when

* the file is larger than :data:`MAX_DOCUMENT_BYTES`, checked before it is read;
* a list holds more items than its limit (:data:`LIST_LIMITS`, else
  :data:`MAX_LIST_ITEMS`), found by :func:`agvnav.world.yaml_strict.check_list_lengths`
  from the YAML event stream, which stops at the first item past the limit (before
  any node tree, model or geometry is built).

The limits are far above the shipped data (at most 113 route network edges, 109 map
entries, a few path segments) and above any hall one vehicle drives; a list is
counted wherever it occurs (``*`` stands for any list index). Documents shorter than
:data:`SCAN_MIN_CHARS` are not scanned: no list of valid items in them can reach a
limit (every limited item takes at least 16 characters, so 64 KiB hold fewer than
4,100; a list of numbers, 2 characters an item, stays under :data:`MAX_LIST_ITEMS`).
"""

from __future__ import annotations

from collections.abc import Mapping

__all__ = ["LIST_LIMITS", "MAX_DOCUMENT_BYTES", "MAX_LIST_ITEMS", "SCAN_MIN_CHARS", "limits_reference"]

#: Largest YAML document file (bytes) read: scenario, map, route network, layout, campaign.
MAX_DOCUMENT_BYTES = 8 * 2**20

#: Largest number of items of any list not named in :data:`LIST_LIMITS` (e.g. a wall's points).
MAX_LIST_ITEMS = 100_000

#: Documents shorter than this (characters) are not scanned for long lists (module doc).
SCAN_MIN_CHARS = 64 * 2**10

_PATHS = 10_000
_MAP = 10_000
_NETWORK = 20_000

#: Document kind -> key pattern (``*``: any list index) -> largest number of items of that list.
LIST_LIMITS: Mapping[str, Mapping[tuple[str, ...], int]] = {
    "scenario": {
        ("path", "segments"): _PATHS,
        ("mission", "jobs"): _PATHS,
        ("faults",): _PATHS,
        ("obstacles",): _PATHS,
        ("map", "reflectors"): _MAP,
        ("map", "walls"): _MAP,
    },
    "map": {("reflectors",): _MAP, ("walls",): _MAP},
    "route network": {
        ("nodes",): _NETWORK,
        ("edges",): _NETWORK,
        ("network", "nodes"): _NETWORK,
        ("network", "edges"): _NETWORK,
    },
}


def limits_reference() -> list[str]:
    """Markdown lines documenting the limits (a section of docs/scenarios.md)."""
    lines = [
        "## Size limits",
        "",
        "A document beyond these limits is refused at once, before it is loaded, with the file (and the",
        "key and line of the list that is too long); `agvnav` exits with status 2. A file may be at most",
        f"{MAX_DOCUMENT_BYTES // 2**20} MiB; a list not named below at most {MAX_LIST_ITEMS:,} items.",
        "",
        "| document | list | most items |",
        "| --- | --- | --- |",
    ]
    for kind, limits in LIST_LIMITS.items():
        for pattern, n in limits.items():
            key = ".".join(pattern).replace(".*", "[]")
            lines.append(f"| {kind} | `{key}` | {n:,} |")
    return lines
