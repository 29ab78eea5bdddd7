"""The campaign's results on disk: a Parquet dataset written one part file per finished batch.

Layout of the output folder::

    campaign.json          what campaign this is (name, fingerprint of spec and base, runs, columns)
    runs/part-*.parquet    one file per finished batch of runs (written to a temporary name, then renamed)
    summary.json           the statistics (written by the runner at the end)

The part files are the index: a run is finished when its ``run`` number is in
one of them, so an interrupted campaign resumes with the runs that are not.
A part file is renamed into place only once complete, so a crash never leaves
half a batch behind. Column types are fixed per campaign (``param.*`` float64
for numeric parameters, else text; ``metric.*`` float64), so the parts
concatenate into one table.
"""

from __future__ import annotations

import json
import os
import uuid
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from agvnav.bench.common import json_text

__all__ = ["check_manifest", "finished_runs", "read_results", "records_table", "write_part"]

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


def check_manifest(out_dir: str | Path, manifest: Mapping[str, Any]) -> None:
    """Check that ``out_dir`` holds no other campaign (another fingerprint), then (re)write ``campaign.json``.

    Raises
    ------
    ValueError
        If ``out_dir`` already holds results of a different campaign.
    """
    path = Path(out_dir) / MANIFEST
    if path.is_file():
        old = json.loads(path.read_text(encoding="utf-8"))
        if old.get("fingerprint") != manifest["fingerprint"]:
            raise ValueError(
                f"{out_dir} holds results of another campaign ({old.get('name')!r}, a different spec or base); "
                "use another --out or remove it"
            )
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json_text(dict(manifest), indent=2) + "\n", encoding="utf-8")
