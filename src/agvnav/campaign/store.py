"""The campaign's results on disk: a Parquet dataset written one part file per finished batch.

Layout of the output folder::

    campaign.json          what campaign this is (name, fingerprint of spec and base, runs, columns)
    runs/part-*.parquet    one file per finished batch of runs (written to a temporary name, then renamed)
    summary.json           the statistics (written by the runner at the end)

The part files are the index: a run is finished when its ``run`` number is in
one of them, so an interrupted campaign resumes with the runs that are not.
A part file is renamed into place only once complete, so a crash never leaves
half a batch behind; ``campaign.json`` and ``summary.json`` are written the same way.
The folder is the campaign's own (:func:`check_out_dir`): absent, empty, or holding the
``campaign.json`` of the same campaign (it resumes); another campaign's is replaced only
with ``force``, and a folder of other files is never written into. Column types
are fixed per campaign (``param.*`` float64 for numeric parameters, else text;
``metric.*`` float64), so the parts concatenate into one table.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import uuid
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from agvnav._json import json_text

__all__ = [
    "MANIFEST", "check_manifest", "check_out_dir", "finished_runs", "read_results", "records_table", "write_json",
    "write_part",
]

RUNS_DIR = "runs"
MANIFEST = "campaign.json"

_FIXED: dict[str, pa.DataType] = {
    "run": pa.int64(),
    "seed": pa.int64(),
    "outcome": pa.string(),
    "reason": pa.string(),
    "sim_time_s": pa.float64(),
    "cpu_time_s": pa.float64(),
    "overrides": pa.string(),
}


def _column_type(name: str, numeric_params: Mapping[str, bool]) -> pa.DataType:
    if name in _FIXED:
        return _FIXED[name]
    if name.startswith("param."):
        return pa.float64() if numeric_params.get(name[len("param.") :], False) else pa.string()
    return pa.float64()


def _cell(value: Any, dtype: pa.DataType) -> Any:
    if value is None or dtype != pa.string() or isinstance(value, str):
        return value
    return json.dumps(value)


def records_table(records: Sequence[Mapping[str, Any]], numeric_params: Mapping[str, bool]) -> pa.Table:
    """Records (flat dicts) -> an Arrow table with the campaign's fixed column types.

    ``numeric_params`` maps each swept dotted key to True when its values are numbers.
    """
    names: list[str] = []
    for rec in records:
        names += [k for k in rec if k not in names]
    arrays = {}
    for name in names:
        dtype = _column_type(name, numeric_params)
        arrays[name] = pa.array([_cell(rec.get(name), dtype) for rec in records], type=dtype)
    return pa.table(arrays)


def write_part(out_dir: str | Path, table: pa.Table) -> Path:
    """Write one finished batch as ``runs/part-<first run>-<id>.parquet`` atomically; return its path."""
    runs = Path(out_dir) / RUNS_DIR
    runs.mkdir(parents=True, exist_ok=True)
    first = min((int(r) for r in table["run"].to_pylist() if r is not None), default=0)
    final = runs / f"part-{first:07d}-{uuid.uuid4().hex[:8]}.parquet"
    tmp = final.with_suffix(".tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, final)
    return final


def _parts(out_dir: str | Path) -> list[Path]:
    return sorted((Path(out_dir) / RUNS_DIR).glob("part-*.parquet"))


def finished_runs(out_dir: str | Path) -> set[int]:
    """Run indices already in the dataset (reads only the ``run`` column)."""
    done: set[int] = set()
    for part in _parts(out_dir):
        done.update(int(r) for r in pq.read_table(part, columns=["run"])["run"].to_pylist() if r is not None)
    return done


def read_results(out_dir: str | Path) -> pa.Table:
    """Every finished run, one row each, sorted by run index (an empty table when none)."""
    tables = [pq.read_table(p) for p in _parts(out_dir)]
    if not tables:
        return pa.table({"run": pa.array([], pa.int64())})
    table = pa.concat_tables(tables, promote_options="default")
    return table.sort_by("run")


def check_out_dir(out_dir: str | Path, fingerprint: str, force: bool = False) -> None:
    """Refuse ``out_dir`` unless it is absent, empty or this campaign's own folder (the same fingerprint).

    A folder is a campaign's when it holds ``campaign.json``; one of the same campaign resumes (its runs
    are kept). One of another campaign (another fingerprint) is refused unless ``force``; with it, the old
    folder is renamed aside and removed, so ``out_dir`` starts empty (never a mix of two campaigns). A file,
    or a non-empty folder without ``campaign.json``, is refused even with ``force``: agvnav never writes
    into (or deletes) a folder of files it did not write. ValueError names the folder and what to do.
    """
    p = Path(out_dir)
    if not p.exists():
        return
    if not p.is_dir():
        raise ValueError(f"--out {p}: it is a file, not a folder")
    path = p / MANIFEST
    if not path.is_file():
        if any(p.iterdir()):
            raise ValueError(f"--out {p}: the folder holds files that are not an agvnav campaign (no {MANIFEST}); "
                             "choose another folder")
        return
    try:
        old = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        old = {}
    if not isinstance(old, dict):
        old = {}
    if old.get("fingerprint") == fingerprint:
        return
    if not force:
        raise ValueError(
            f"--out {p}: the folder holds results of another campaign ({old.get('name')!r}, a different spec or "
            "base); use --force to replace them, or another --out"
        )
    aside = Path(tempfile.mkdtemp(prefix=f".{p.name}.old-", dir=p.parent))
    os.replace(p, aside / p.name)
    shutil.rmtree(aside, ignore_errors=True)


def write_json(path: str | Path, document: Any) -> Path:
    """Write ``document`` as indented JSON to ``path`` atomically (a temporary sibling renamed); return it."""
    final = Path(path)
    tmp = final.with_name(f".{final.name}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        tmp.write_text(json_text(document, indent=2) + "\n", encoding="utf-8")
        os.replace(tmp, final)
    finally:
        tmp.unlink(missing_ok=True)
    return final


def check_manifest(out_dir: str | Path, manifest: Mapping[str, Any], force: bool = False) -> None:
    """Check ``out_dir`` may hold this campaign (:func:`check_out_dir`), then (re)write ``campaign.json``.

    Raises
    ------
    ValueError
        If ``out_dir`` is a file, holds files that are not a campaign, or (unless ``force``) holds
        results of a different campaign.
    """
    check_out_dir(out_dir, manifest["fingerprint"], force)
    path = Path(out_dir) / MANIFEST
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(path, dict(manifest))
